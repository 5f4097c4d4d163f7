#!/usr/bin/env python3
"""The gate's learned GNSS noise (`filter.gate.learn`, on by default) on the shipped data.

Each configuration runs forward, and smoothed with `--smooth`, as the user's file says
(default gate, no `--no-gate`), once learning each stream's noise (the default) and once
with `--declared-noise`; scored as the README scores it: navego, horizontal RMS against
`truth.nav.zst` after 60 s; drive-0708, the RMS over the ten 15 s outages of each one's
largest horizontal error against `ref_rtkfix.txt.zst`. Prints a Markdown table with the
exit status of each run (0 trusted, 3 judged untrustworthy: its result is still scored)
and the σ factor the summary says each stream's data showed. Run from the repository root
after `cargo build --release -p ins-gnss`:

    python3 benches/learned_noise.py [BINARY] [--smooth]
"""
import os, re, subprocess, sys, tempfile
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scores  # noqa: E402
SMOOTH = "--smooth" in sys.argv[1:]
ARGS = [a for a in sys.argv[1:] if a != "--smooth"]
B = ARGS[0] if ARGS else "target/release/ins-gnss"
NAV = "/nav_smoothed.txt" if SMOOTH else "/nav.txt"
def run(cfg, declared):
    out = os.path.join(tempfile.gettempdir(), "learned-noise", f"{abs(hash((cfg, declared, SMOOTH)))}")
    r = subprocess.run([B, "run", cfg, "--quiet", "--out", out,
                        *(["--declared-noise"] if declared else []), *(["--smooth"] if SMOOTH else [])],
                       capture_output=True, text=True)
    learned = re.findall(r"noise learned: (.*)", r.stdout + r.stderr)
    return out, r.returncode, (learned[0] if learned else "")
def score(kind, out):
    s = scores.score(B, kind, out + NAV)
    return s and s["h"]
rows = [("navego kf-gins-ADIS16488.yaml", "navego", "data/navego/kf-gins-ADIS16488.yaml"),
        ("navego kf-gins-ADIS16405.yaml", "navego", "data/navego/kf-gins-ADIS16405.yaml"),
        ("navego noinit.toml", "navego", "data/navego/noinit.toml"),
        ("drive-0708 kf-gins-outage15.yaml", "drive", "data/drive-0708/kf-gins-outage15.yaml"),
        ("drive-0708 aided-noinit.toml", "drive", "data/drive-0708/aided-noinit.toml"),
        ("drive-0708 aided.toml", "drive", "data/drive-0708/aided.toml")]
print(f"{'smoothed' if SMOOTH else 'forward'}\n")
print("| data, configuration | declared noise (exit) | learned (exit) | change | learned σ factors |")
print("|---|---|---|---|---|")
for name, kind, cfg in rows:
    o0, e0, _ = run(cfg, True)
    o1, e1, l1 = run(cfg, False)
    v0, v1 = score(kind, o0), score(kind, o1)
    ch = f"{100*(v1/v0-1):+.2f} %" if v0 and v1 else "—"
    f = lambda v: "—" if v is None else f"{v:.3f} m"
    print(f"| {name} | {f(v0)} ({e0}) | {f(v1)} ({e1}) | {ch} | {l1} |", flush=True)
