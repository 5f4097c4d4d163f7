#!/usr/bin/env python3
"""Accuracy on the shipped data against its peer: `docs/history/results.md`'s first table.

    cargo build --release -p ins-gnss
    python3 benches/peers.py [BINARY] [KF-GINS]

For each KF-GINS configuration shipped in `data/` (navego's two IMUs, drive-0708's
outage file) runs ours forward and `--smooth` as the file says (default gate, noise
learned, no `--no-gate`) and KF-GINS (default `../shared/bin/kf-gins`) with the same
file on plain-text copies of its inputs; and ours on the shipped TOML files that give no
`[init]` (KF-GINS cannot start without one). Scores as the README does: navego, the
horizontal and 3D RMS and the yaw RMS against `truth.nav.zst` after 60 s; drive-0708, the
RMS over the ten 15 s outages of each one's largest horizontal error against
`ref_rtkfix.txt.zst`. Prints a Markdown table with each run's exit status (0 trusted,
3 judged untrustworthy, its result still scored). Needs Python's standard library and
the `zstd` command.
"""
import os, re, shutil, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scores  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
B = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else os.path.join(ROOT, "target/release/ins-gnss")
KF = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else os.path.join(ROOT, "../shared/bin/kf-gins")
WORK = tempfile.mkdtemp(prefix="peers-")


def score(kind, nav):
    return scores.score(B, kind, nav)


def ours(cfg, smooth):
    out = os.path.join(WORK, re.sub(r"\W", "_", cfg) + ("-s" if smooth else ""))
    r = subprocess.run([B, "run", os.path.join(ROOT, cfg), "--quiet", "--out", out,
                        *(["--smooth"] if smooth else [])], capture_output=True, text=True)
    return r.returncode, os.path.join(out, "nav_smoothed.txt" if smooth else "nav.txt")


def kf_gins(cfg):
    src = os.path.join(ROOT, cfg)
    here = os.path.join(WORK, "kf-" + re.sub(r"\W", "_", cfg))
    os.makedirs(os.path.join(here, "out"))
    text = open(src).read()
    for key in ("imupath", "gnsspath"):
        name = re.search(rf'^{key}:\s*"?([^"\n#]+)"?', text, re.M).group(1).strip()
        path = os.path.join(os.path.dirname(src), name)
        with open(os.path.join(here, key + ".txt"), "wb") as f:
            if path.endswith(".zst"):
                subprocess.run(["zstd", "-dqc", path], stdout=f, check=True)
            else:
                shutil.copyfileobj(open(path, "rb"), f)
        text = re.sub(rf"^{key}:.*$", f'{key}: "{key}.txt"', text, flags=re.M)
    text = re.sub(r"^outputpath:.*$", 'outputpath: "out"', text, flags=re.M)
    open(os.path.join(here, "config.yaml"), "w").write(text)
    r = subprocess.run([KF, "config.yaml"], cwd=here, capture_output=True, text=True)
    return r.returncode, os.path.join(here, "out", "KF_GINS_Navresult.nav")


def fmt(s, key="h"):
    return "—" if s is None or s.get(key) is None else f"{s[key]:.3f}"


rows = [("navego ADIS16488, KF-GINS's YAML", "navego", "data/navego/kf-gins-ADIS16488.yaml", True),
        ("navego ADIS16405, KF-GINS's YAML", "navego", "data/navego/kf-gins-ADIS16405.yaml", True),
        ("navego ADIS16488, `noinit.toml` (no `[init]`)", "navego", "data/navego/noinit.toml", False),
        ("drive-0708, KF-GINS's YAML", "drive", "data/drive-0708/kf-gins-outage15.yaml", True),
        ("drive-0708, `aided.toml` (NHC, ZUPT, 21 states)", "drive", "data/drive-0708/aided.toml", False),
        ("drive-0708, `aided-noinit.toml` (the same, no `[init]`)", "drive", "data/drive-0708/aided-noinit.toml", False)]
print("| data, configuration | score | ours forward (exit) | ours smoothed (exit) | KF-GINS | ours ÷ KF-GINS | ours: position beyond its 99 % ellipsoid (navego), forward / smoothed |")
print("|---|---|---|---|---|---|---|")
for name, kind, cfg, peer in rows:
    e0, n0 = ours(cfg, False)
    e1, n1 = ours(cfg, True)
    s0, s1 = score(kind, n0), score(kind, n1)
    sk = None
    if peer:
        ek, nk = kf_gins(cfg)
        sk = score(kind, nk) if ek == 0 else None
    what = "horizontal RMS after 60 s, m (yaw RMS, °)" if kind == "navego" else "outages' RMS of max horizontal, m"
    cell = lambda s: f"{fmt(s)} ({fmt(s, 'yaw')}°)" if kind == "navego" and s and s.get("yaw") is not None else fmt(s)
    ratio = f"{s0['h'] / sk['h']:.2f}" if s0 and sk else "—"
    beyond = lambda s: "—" if not s or s.get("beyond") is None else f"{s['beyond']:.1f} %"
    print(f"| {name} | {what} | {cell(s0)} ({e0}) | {cell(s1)} ({e1}) | {cell(sk) if peer else 'cannot start'} | {ratio} "
          f"| {beyond(s0)} / {beyond(s1)} |", flush=True)
shutil.rmtree(WORK, ignore_errors=True)
