"""Shared fixtures: the repository's sample data, the program built from the same
sources (to compare the bindings with it), and the data decompressed."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data"


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `ins-gnss` program: `$INS_GNSS`, or built here (release) from the sources."""
    exe = os.environ.get("INS_GNSS")
    if exe:
        return Path(exe)
    subprocess.run(["cargo", "build", "--release", "-p", "ins-gnss"], cwd=REPO, check=True)
    return REPO / "target" / "release" / "ins-gnss"


def read_zst(path: Path) -> np.ndarray:
    """A numeric text file compressed with zstd, as rows."""
    import zstandard

    text = zstandard.ZstdDecompressor().stream_reader(path.open("rb")).read()
    return np.loadtxt(text.decode().splitlines(), ndmin=2)


@pytest.fixture(scope="session")
def navego_arrays():
    """navego's ADIS16488 IMU (increments, 200 Hz) and GNSS positions, as rows."""
    return read_zst(DATA / "navego" / "IMU-ADIS16488.txt.zst"), read_zst(
        DATA / "navego" / "GNSS-POS.txt.zst"
    )
