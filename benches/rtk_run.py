#!/usr/bin/env python3
"""RTK in the program's run (`gnss.coupling = "rtk"`) over seeds, against the truth.

`python3 benches/rtk_run.py SEEDS [FREQUENCIES...]` (default 20 seeds, 1 and 2): for each
seed, `ins-gnss simulate ins-gnss/scenarios/rtk.toml` with that seed (a rover and a base
4.9 km away under one sky, GPS L1 + L2, the 600 s drive of `tight.toml` with a consumer
MEMS IMU and a 60 s canyon of 3 satellites from 300 s), the configuration's `[init]`
removed (the run starts from the data), smoothing on, `gnss.rtk.frequencies` set; then
`ins-gnss run`. Per cell: the fix rate (RTK's summary), wrong fixes (`nav.pos` rows with
Q = 1 more than 10 cm from the truth, 3D), the forward horizontal RMS after the first
fix outside the canyon and the minute after it, the error at the canyon's end, the
smoothed horizontal RMS, the forward and smoothed position NEES beyond their 99 %
quantile (`ins-gnss` prints them), exit codes, and the longest time to fix again after an
outage of the fix. `INS_GNSS` names the binary (default `target/release/ins-gnss`); `EXTRA`
adds configuration lines to `[gnss.rtk]`; `MASKS` replaces the scenario's sky masks (e.g.
`MASKS='[[300.0, 330.0, 0.0]]'`: a 30 s tunnel instead of the canyon; the canyon columns
then read the tunnel).
"""

import math
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("INS_GNSS", str(ROOT / "target/release/ins-gnss"))
CANYON = (300.0, 360.0)
T0 = 529200.0


def dataset(tmp: Path, seed: int) -> Path:
    d = tmp / f"s{seed}"
    global CANYON
    m = re.match(r"\[\[([\d.]+), ([\d.]+)", os.environ.get("MASKS", ""))
    if m:
        CANYON = (float(m.group(1)), float(m.group(2)))
    if (d / "config.toml").exists():
        return d
    text = (ROOT / "ins-gnss/scenarios/rtk.toml").read_text()
    text = re.sub(r"^seed = \d+", f"seed = {seed}", text, flags=re.M)
    text = text.replace("../../data/", str(ROOT / "data") + "/")
    if "MASKS" in os.environ:
        text = re.sub(r"^masks = .*$", f"masks = {os.environ['MASKS']}", text, flags=re.M)
    spec = tmp / f"s{seed}.toml"
    spec.write_text(text)
    subprocess.run([BIN, "simulate", str(spec), "--out", str(d)], check=True, capture_output=True)
    return d


def configure(d: Path, freqs: int) -> Path:
    text = (d / "config.toml").read_text()
    a = text.index("[init]")
    b = text.index("\n[", a + 1)
    text = text[:a] + text[b + 1 :]
    text = text.replace("smooth = false", "smooth = true")
    text = text.replace('output = "out"', f'output = "out{freqs}"')
    extra = os.environ.get("EXTRA", "").replace("\\n", "\n")
    text += f"\n[gnss.rtk]\nfrequencies = {freqs}\n{extra}\n"
    p = d / f"run{freqs}.toml"
    p.write_text(text)
    return p


def truth(d: Path):
    out = {}
    for line in (d / "truth.nav").read_text().splitlines():
        v = [float(x) for x in line.split()]
        out[round(v[1] * 100)] = v
    return out


def ned(v, t):
    lat = math.radians(t[2])
    dn = math.radians(v[2] - t[2]) * 6378137.0
    de = math.radians(v[3] - t[3]) * 6378137.0 * math.cos(lat)
    return dn, de, -(v[4] - t[4])


def one(d: Path, freqs: int):
    cfg = configure(d, freqs)
    r = subprocess.run([BIN, "run", str(cfg)], capture_output=True, text=True)
    log = r.stdout + r.stderr
    out = d / f"out{freqs}"
    tr = truth(d)
    m = re.search(r"RTK: (\d+) of (\d+) rover epochs solved, (\d+) fixed", log)
    first = re.search(r"time to first fix (\d+) s", log)
    refix = re.search(r"fixed again after (\d+) s at most", log)
    fixed, epochs = (int(m.group(3)), int(m.group(2))) if m else (0, 0)
    wrong = q1 = 0
    back = None
    for line in (out / "nav.pos").read_text().splitlines():
        if line.startswith("%"):
            continue
        v = [float(x) for x in line.split()[:6]]
        if v[5] == 1 and back is None and v[1] - T0 >= CANYON[1] - 0.5:
            back = v[1] - T0 - CANYON[1]
        t = tr.get(round(v[1] * 100))
        if v[5] != 1 or t is None:
            continue
        q1 += 1
        wrong += math.dist((0, 0, 0), ned(v, t)) > 0.10

    def errors(name):
        rows = []
        for line in (out / name).read_text().splitlines():
            v = [float(x) for x in line.split()]
            k = round(v[1] * 100)
            if k % 100 or k not in tr:
                continue
            rows.append((v[1] - T0, *ned(v, tr[k])))
        return rows

    fwd, sm = errors("nav.txt"), errors("nav_smoothed.txt")
    t_first = int(first.group(1)) if first else None

    def rms(rows, start):
        h = [
            e[1] ** 2 + e[2] ** 2
            for e in rows
            if e[0] >= start and not (CANYON[0] <= e[0] < CANYON[1] + 60.0)
        ]
        return math.sqrt(sum(h) / len(h)) if h else float("nan")

    end = [e for e in fwd if e[0] <= CANYON[1] + 0.5][-1]
    nees = re.findall(r"position NEES/dof ([\d.]+), ([\d.]+) % of", log)
    return {
        "exit": r.returncode,
        "fixed": fixed,
        "epochs": epochs,
        "first": t_first,
        "q1": q1,
        "wrong": wrong,
        "fwd": rms(fwd, (t_first or 600) + 20.0),
        "end": math.dist((0, 0, 0), end[1:]),
        "sm": rms(sm, 10.0),
        "sm_canyon": max(math.hypot(e[1], e[2]) for e in sm if CANYON[0] <= e[0] < CANYON[1]),
        "beyond": [float(x[1]) for x in nees],
        "refix": int(refix.group(1)) if refix else None,
        "back": back if back is not None else 10**9,
    }


def refixes(rs):
    v = sorted(r["refix"] for r in rs if r["refix"] is not None)
    return f"{v[len(v) // 2]} / {v[-1]}" if v else "–"


def main():
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    freqs = [int(f) for f in sys.argv[2:]] or [1, 2]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cells = {f: [] for f in freqs}
        for seed in range(seeds):
            d = dataset(tmp, seed)
            for f in freqs:
                r = one(d, f)
                cells[f].append(r)
                print(f"seed {seed} L{f}: {r}", file=sys.stderr, flush=True)
    print(f"{seeds} seeds; wrong: a Q = 1 row of nav.pos more than 10 cm from the truth\n")
    print(
        "| frequencies | exit 0 / 3 / other | fix rate, mean (worst seed) | first fix, s: median / worst"
        " | wrong fixes | forward H RMS after the first fix, m: median / worst | canyon end, m: median / worst"
        " | smoothed H RMS, m: median / worst | smoothed canyon max, m: median / worst"
        " | position beyond 99 %: forward / smoothed, mean % | longest time to fix again, s: median / worst | first Q = 1 row after the canyon (tunnel), s: median / worst |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for f, rs in cells.items():
        med = lambda v: sorted(v)[len(v) // 2]  # noqa: E731
        worst = lambda v: max(v)  # noqa: E731
        rates = [r["fixed"] / max(r["epochs"], 1) for r in rs]
        firsts = [r["first"] if r["first"] is not None else 10**9 for r in rs]
        ex = [r["exit"] for r in rs]
        fm = lambda v: "never" if v >= 10**9 else f"{v}"  # noqa: E731
        col = lambda k: f"{med([r[k] for r in rs]):.3f} / {worst([r[k] for r in rs]):.3f}"  # noqa: E731
        beyond = [sum(r["beyond"][i] for r in rs) / len(rs) for i in range(2)]
        print(
            f"| L1{'+L2' if f == 2 else ''} | {ex.count(0)} / {ex.count(3)} / {len(ex) - ex.count(0) - ex.count(3)}"
            f" | {100 * sum(rates) / len(rates):.1f} % ({100 * min(rates):.1f} %)"
            f" | {fm(med(firsts))} / {fm(worst(firsts))}"
            f" | {sum(r['wrong'] for r in rs)} of {sum(r['q1'] for r in rs)}"
            f" | {col('fwd')} | {col('end')} | {col('sm')} | {col('sm_canyon')}"
            f" | {beyond[0]:.1f} / {beyond[1]:.1f} | {refixes(rs)}"
            f" | {fm(round(med([r['back'] for r in rs])))} / {fm(round(worst([r['back'] for r in rs])))} |"
        )


if __name__ == "__main__":
    main()
