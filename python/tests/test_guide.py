"""Every Python block of the README and of the guide (`docs/guide/*.md`), run as a script
from the repository's root: the documentation's examples are code that runs, so they
cannot go stale unnoticed."""

import re
import subprocess
import sys

import pytest

from conftest import REPO

FILES = [REPO / "README.md", *sorted((REPO / "docs" / "guide").glob("*.md"))]


def blocks():
    for path in FILES:
        text = path.read_text()
        for k, m in enumerate(re.finditer(r"^```python\n(.*?)^```", text, re.S | re.M)):
            line = text[: m.start()].count("\n") + 1
            yield pytest.param(m.group(1), id=f"{path.name}:{line}")


def test_there_are_blocks_to_run():
    assert len(list(blocks())) >= 4


@pytest.mark.parametrize("code", list(blocks()))
def test_the_block_runs(code, tmp_path):
    script = tmp_path / "block.py"
    script.write_text(code)
    r = subprocess.run([sys.executable, str(script)], cwd=REPO, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
