#!/usr/bin/env python3
"""The effect of `filter.covariance_interval` on the shipped real data sets.

Each configuration runs forward (`ins-gnss run CONFIG --covariance-interval C
--accept-inconsistent`, default gate, no `--no-gate`) at each interval and is scored as the
README scores it: navego, horizontal RMS against `truth.nav.zst` after 60 s; drive-0708,
the RMS over the ten 15 s outages of each one's largest horizontal error against
`ref_rtkfix.txt.zst`. Prints a Markdown table, the change against the exact mode (0) in
brackets. With `--smooth` the runs smooth and `nav_smoothed.txt` is scored the same way.
Run from the repository root after `cargo build --release -p ins-gnss`:

    python3 benches/covariance_interval.py [BINARY] [--smooth]
"""
import json, os, subprocess, sys, tempfile
SMOOTH = "--smooth" in sys.argv[1:]
ARGS = [a for a in sys.argv[1:] if a != "--smooth"]
B = ARGS[0] if ARGS else "target/release/ins-gnss"
intervals = [0, 0.01, 0.02, 0.05, 0.1]
NAV = "/nav_smoothed.txt" if SMOOTH else "/nav.txt"
W = json.load(open("data/drive-0708/outage_windows_15s.json"))
def run(cfg, ci, extra=()):
    out = os.path.join(tempfile.gettempdir(), "covariance-interval", f"{abs(hash((cfg, ci, extra)))}")
    r = subprocess.run([B, "run", cfg, "--accept-inconsistent", "--quiet", "--out", out,
                        "--covariance-interval", str(ci), *extra, *(["--smooth"] if SMOOTH else [])],
                       capture_output=True, text=True)
    if r.returncode != 0:
        return None, r.stderr[-300:]
    return out, None
def navego(cfg, ci):
    out, e = run(cfg, ci)
    if e: return e
    j = json.loads(subprocess.run([B, "eval", out + NAV, "data/navego/truth.nav.zst", "--skip", "60", "--json"], capture_output=True, text=True).stdout)
    return j["overall"]["horizontal"]["rms"]
def drive(cfg, ci):
    out, e = run(cfg, ci)
    if e: return e
    args = [B, "eval", out + NAV, "data/drive-0708/ref_rtkfix.txt.zst", "--json"]
    for a, b in W: args += ["--window", f"{a},{b}"]
    j = json.loads(subprocess.run(args, capture_output=True, text=True).stdout)
    return j["windows_rms_of_max_horizontal"]
rows = [("navego kf-gins-ADIS16488.yaml", navego, "data/navego/kf-gins-ADIS16488.yaml"),
        ("navego noinit.toml", navego, "data/navego/noinit.toml"),
        ("drive-0708 kf-gins-outage15.yaml", drive, "data/drive-0708/kf-gins-outage15.yaml"),
        ("drive-0708 aided-noinit.toml", drive, "data/drive-0708/aided-noinit.toml"),
        ("drive-0708 aided.toml", drive, "data/drive-0708/aided.toml")]
print("| data, configuration | " + " | ".join(f"{c} s" for c in intervals) + " |")
for name, f, cfg in rows:
    vals = [f(cfg, c) for c in intervals]
    base = vals[0]
    cells = []
    for v in vals:
        if isinstance(v, str): cells.append("fail: " + v.replace("\n", " ")[:80])
        else: cells.append(f"{v:.3f} m ({100*(v/base-1):+.2f} %)" if not isinstance(base, str) else f"{v:.3f}")
    print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
