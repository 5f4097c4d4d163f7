#!/usr/bin/env python3
"""Campaigns of the program's automatic decisions: real logs x corruption patterns x seeds.

Each run takes a shipped data set, corrupts its GNSS file by seed (gross errors of a given
size at random bearings on a share of the fixes, from the first fix or after a delay),
runs `ins-gnss run` on it exactly as a user would (no `--no-gate`, no
`--accept-inconsistent`), and evaluates the result against the truth. The table counts,
per cell: runs refused before they start (exit 1), runs flagged untrustworthy (exit 3),
runs beyond the error bound, and the confusion matrix flagged/not flagged against
wrong/right (wrong: horizontal RMS beyond the bound).

    python3 benches/campaign.py --bin target/release/ins-gnss --seeds 50 \
        --rates 0,2,5,10,20,50 --starts 0,60 --configs yaml,noinit --csv /tmp/c.csv
    python3 benches/campaign.py --walk --seeds 50     # the self-start in a small yard
    python3 benches/campaign.py --rover --seeds 20    # a slow rover, true and 100x-low IMU noise
    python3 benches/campaign.py --walk --seeds 50 --fleet   # on a Dask cluster (estimator.fleet)
    python3 benches/campaign.py --reversed --seeds 30  # the odometer verdict: heading right and 180° off

Every run's row goes to the CSV (config, rate, start, seed, exit status, horizontal RMS,
refused share, the first line of the error); the table is printed as Markdown.
Needs only Python's standard library and the `zstd` command.
"""

import argparse
import concurrent.futures as cf
import csv
import json
import math
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NAVEGO = os.path.join(ROOT, "data", "navego")
EARTH = 6378137.0

# The configurations as shipped: KF-GINS's YAML with its own initial state, and the TOML
# with no [init] (the start found from the data).
CONFIGS = {
    "yaml": "kf-gins-ADIS16488.yaml",
    "noinit": "noinit.toml",
}


def unpack(src, dst):
    if not os.path.exists(dst):
        subprocess.run(["zstd", "-dqf", src, "-o", dst], check=True)


def corrupt(lines, rate, start, size, seed):
    """The GNSS lines with `rate` (0-1) of the fixes after `start` s moved `size` m at a
    random bearing, and how many were moved."""
    rng = random.Random(seed)
    out, moved, t0 = [], 0, None
    for line in lines:
        f = line.split()
        if len(f) < 4 or line.lstrip().startswith("#"):
            out.append(line)
            continue
        t = float(f[0])
        t0 = t if t0 is None else t0
        u, b = rng.random(), rng.random() * 2.0 * math.pi
        if t >= t0 + start and u < rate:
            lat = math.radians(float(f[1]))
            f[1] = "%.10f" % (float(f[1]) + math.degrees(size * math.cos(b) / EARTH))
            f[2] = "%.10f" % (
                float(f[2]) + math.degrees(size * math.sin(b) / (EARTH * math.cos(lat)))
            )
            moved += 1
        out.append(" ".join(f) + "\n")
    return out, moved


def write_config(kind, work, gnss, imu):
    src = os.path.join(NAVEGO, CONFIGS[kind])
    text = open(src).read()
    if kind == "yaml":
        text = re.sub(r'imupath:.*', 'imupath: "%s"' % imu, text)
        text = re.sub(r'gnsspath:.*', 'gnsspath: "%s"' % gnss, text)
        text = re.sub(r'outputpath:.*', 'outputpath: "out"', text)
        path = os.path.join(work, "run.yaml")
    else:
        text = re.sub(r'(?m)^imu = .*', 'imu = "%s"' % imu, text)
        text = re.sub(r'(?m)^gnss = .*', 'gnss = "%s"' % gnss, text)
        path = os.path.join(work, "run.toml")
    open(path, "w").write(text)
    return path


def one(job):
    (binary, kind, rate, start, size, seed, cache, extra) = job
    work = tempfile.mkdtemp(prefix="campaign-")
    try:
        lines = open(os.path.join(cache, "GNSS-POS")).readlines()
        bad, moved = corrupt(lines, rate / 100.0, start, size, seed)
        gnss = os.path.join(work, "gnss.txt")
        open(gnss, "w").writelines(bad)
        cfg = write_config(kind, work, gnss, os.path.join(cache, "IMU-ADIS16488"))
        out = os.path.join(work, "out")
        p = subprocess.run(
            [binary, "run", cfg, "--out", out, "--quiet"] + extra,
            capture_output=True,
            text=True,
        )
        row = {
            "config": kind,
            "rate": rate,
            "start": start,
            "size": size,
            "seed": seed,
            "moved": moved,
            "exit": p.returncode,
            "horiz_rms": float("nan"),
            "refused_share": float("nan"),
            "error": "",
        }
        m = re.search(r"(\d+) GNSS epochs: (\d+) accepted, (\d+) inflated, (\d+) rejected", p.stdout)
        if m:
            row["refused_share"] = int(m.group(4)) / max(1, int(m.group(1)))
        if p.returncode != 0:
            err = [l for l in p.stderr.splitlines() if l.strip()]
            row["error"] = " | ".join(err[:3])[:400]
        nav = os.path.join(out, "nav.txt")
        if os.path.exists(nav):
            e = subprocess.run(
                [binary, "eval", nav, os.path.join(cache, "truth.nav"), "--json"],
                capture_output=True,
                text=True,
            )
            if e.returncode == 0:
                row["horiz_rms"] = json.loads(e.stdout)["overall"]["horizontal"]["rms"]
        return row
    finally:
        shutil.rmtree(work, ignore_errors=True)


def table(rows, bound):
    cells = {}
    for r in rows:
        cells.setdefault((r["config"], r["rate"], r["start"]), []).append(r)
    print(
        "| config | outliers %% | from s | runs | refused (exit 1) | flagged (exit 3) | "
        "beyond %g m | flagged & wrong | flagged & right | unflagged & wrong | median m | max m |"
        % bound
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for key in sorted(cells):
        rs = cells[key]
        n = len(rs)
        refused = sum(r["exit"] not in (0, 3) for r in rs)
        flagged = [r for r in rs if r["exit"] == 3]
        err = [r["horiz_rms"] for r in rs if not math.isnan(r["horiz_rms"])]
        wrong = lambda r: math.isnan(r["horiz_rms"]) or r["horiz_rms"] > bound
        ran = [r for r in rs if r["exit"] in (0, 3)]
        fw = sum(1 for r in ran if r["exit"] == 3 and wrong(r))
        fr = sum(1 for r in ran if r["exit"] == 3 and not wrong(r))
        uw = sum(1 for r in ran if r["exit"] == 0 and wrong(r))
        beyond = sum(1 for r in ran if wrong(r))
        err.sort()
        med = err[len(err) // 2] if err else float("nan")
        mx = err[-1] if err else float("nan")
        print(
            "| %s | %g | %g | %d | %d | %d | %d | %d | %d | %d | %.2f | %.2f |"
            % (key[0], key[1], key[2], n, refused, len(flagged), beyond, fw, fr, uw, med, mx)
        )


# the self-start's heading and its σ in the run's summary
HEADING = r"heading (-?[\d.]+)° from the in-motion alignment \([^)]*\), σ ([\d.]+)°"


def strip_init(text):
    out, skip = [], False
    for line in text.splitlines():
        if line.startswith("["):
            skip = line.strip() == "[init]"
        if not skip:
            out.append(line)
    return "\n".join(out) + "\n"


def simulated(binary, work, scenario, seed, velocity=True):
    """`ins-gnss/scenarios/SCENARIO` with `seed` (without its GNSS velocity when
    `velocity` is false) simulated into `WORK/d`; returns that folder and its
    `config.toml`'s text."""
    text = open(os.path.join(ROOT, "ins-gnss", "scenarios", scenario)).read()
    text = re.sub(r"(?m)^seed = .*", "seed = %d" % seed, text)
    if not velocity:
        text = re.sub(r"(?m)^velocity_std = .*remove for a 7-column.*\n", "", text)
    open(os.path.join(work, "s.toml"), "w").write(text)
    d = os.path.join(work, "d")
    subprocess.run([binary, "simulate", os.path.join(work, "s.toml"), "--out", d],
                   check=True, capture_output=True)
    return d, open(os.path.join(d, "config.toml")).read()


def walk_one(job):
    """One seed of `scenarios/walk.toml` (with or without GNSS velocity): the run given the
    simulator's initial state and the run with no `[init]`; their outage scores (largest
    horizontal error inside the outage window) and the self-start's heading error and σ."""
    (binary, seed, velocity, extra) = job
    work = tempfile.mkdtemp(prefix="walk-")
    try:
        d, cfg = simulated(binary, work, "walk.toml", seed, velocity)
        open(os.path.join(d, "noinit.toml"), "w").write(strip_init(cfg))
        truth = os.path.join(d, "truth.nav")
        yaw0 = float(open(truth).readline().split()[10])
        row = {"seed": seed, "velocity": velocity}
        for name in ("config", "noinit"):
            out = os.path.join(work, "o_" + name)
            p = subprocess.run([binary, "run", os.path.join(d, name + ".toml"), "--out", out, "--quiet"]
                               + extra, capture_output=True, text=True)
            row[name + "_exit"] = p.returncode
            row[name + "_score"] = float("nan")
            if name == "noinit":
                m = re.search(HEADING, p.stdout)
                err = float("nan")
                if m:
                    err = (float(m.group(1)) - yaw0 + 180.0) % 360.0 - 180.0
                row["heading_err"] = err
                row["heading_std"] = float(m.group(2)) if m else float("nan")
                row["error"] = " | ".join(l for l in p.stderr.splitlines() if l.strip())[:300]
            if os.path.exists(os.path.join(out, "nav.txt")):
                e = subprocess.run([binary, "eval", os.path.join(out, "nav.txt"), truth, "--json",
                                    "--window", "80,90"], capture_output=True, text=True)
                if e.returncode == 0:
                    row[name + "_score"] = json.loads(e.stdout)["windows"][0]["horizontal"]["max"]
        return row
    finally:
        shutil.rmtree(work, ignore_errors=True)


# `--fleet [ADDRESS]`: the runs go to a Dask cluster through the Python package's
# `estimator.fleet` (a local cluster of `--jobs` workers, or the scheduler at ADDRESS)
# instead of this process's threads; `None`: threads.
FLEET = None


def _call(fn, job):
    """One run as a fleet job: `fn(job)`'s row (a failure is the fleet's row, with why)."""
    return fn(job)


def dispatch(fn, todo, jobs):
    """`fn` over `todo`, in order: on `jobs` threads, or on the fleet (`--fleet`)."""
    if FLEET is None:
        with cf.ThreadPoolExecutor(jobs) as ex:
            return list(ex.map(fn, todo))
    import estimator  # the Python package (pip install ./python, with dask)

    table = estimator.fleet(
        [estimator.Job(f"run {k}", run=_call, options={"fn": fn, "job": j})
         for k, j in enumerate(todo)],
        address=FLEET or None, workers=jobs)
    failed = table[~table["ok"]]
    if len(failed):
        raise SystemExit("%d runs failed on the fleet, the first: %s"
                         % (len(failed), failed["error"].iloc[0]))
    # the fleet's own columns; `error` is the run's when the run has one
    own = ["name", "ok", "time_s"] + (["error"] if table["error"].isna().all() else [])
    keep = [c for c in table.columns if c not in own and c != "error"]
    keep += [] if "error" in own else ["error"]   # (last, where the runs put it)
    return [{k: r[k] for k in keep} for r in table.to_dict("records")]


def run_seeds(one_seed, todo, jobs, csv_path):
    """Run `one_seed` over `todo` on `jobs` threads (or the fleet); write every row to
    `csv_path` if given."""
    rows = dispatch(one_seed, todo, jobs)
    if csv_path:
        with open(csv_path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=sorted({k for r in rows for k in r}))
            w.writeheader()
            w.writerows(rows)
    return rows


def walk(binary, seeds, first, jobs, csv_path, extra):
    todo = [(binary, first + s, v, extra) for v in (True, False) for s in range(seeds)]
    rows = run_seeds(walk_one, todo, jobs, csv_path)
    print("| GNSS | seeds | started (no `[init]`) | heading within 3σ | score within 20 % of given | "
          "median score found / given m | largest heading error / its σ |")
    print("|---|---|---|---|---|---|---|")
    for v in (True, False):
        rs = [r for r in rows if r["velocity"] == v]
        started = [r for r in rs if r["noinit_exit"] in (0, 3) and not math.isnan(r["noinit_score"])]
        within = [r for r in started if abs(r["heading_err"]) <= 3 * r["heading_std"]]
        close = [r for r in started if r["noinit_score"] <= 1.2 * r["config_score"]]
        med = lambda xs: sorted(xs)[len(xs) // 2] if xs else float("nan")
        worst = max(started, key=lambda r: abs(r["heading_err"]) / r["heading_std"], default=None)
        print("| %s | %d | %d | %d | %d | %.3f / %.3f | %s |" % (
            "position + velocity" if v else "position only", len(rs), len(started), len(within),
            len(close), med([r["noinit_score"] for r in started]),
            med([r["config_score"] for r in rs if not math.isnan(r["config_score"])]),
            "%.2f° / %.2f°" % (worst["heading_err"], worst["heading_std"]) if worst else "-"))


def reversed_one(job):
    """One seed of `scenarios/car-aided.toml` (with GNSS velocity, or position only) run
    with `--odometer` three ways: as simulated (its `[init]`), with no `[init]` (the
    self-start), and with the given heading turned 180°. The exit status, and whether the
    odometer verdict ("the filter moves the other way") named it."""
    (binary, seed, velocity, extra) = job
    work = tempfile.mkdtemp(prefix="reversed-")
    try:
        d, cfg = simulated(binary, work, "car-aided.toml", seed, velocity)
        att = re.search(r"(?m)^attitude = \[([^\]]*)\]", cfg)
        roll, pitch, yaw = [float(x) for x in att.group(1).split(",") if x.strip()]
        flipped = cfg.replace(att.group(0), "attitude = [%r, %r, %r]" % (roll, pitch, yaw + 180.0))
        open(os.path.join(d, "given.toml"), "w").write(cfg)
        open(os.path.join(d, "noinit.toml"), "w").write(strip_init(cfg))
        open(os.path.join(d, "reversed.toml"), "w").write(flipped)
        row = {"seed": seed, "velocity": velocity}
        for name in ("given", "noinit", "reversed"):
            p = subprocess.run([binary, "run", os.path.join(d, name + ".toml"), "--odometer",
                                "--out", os.path.join(work, "o_" + name), "--quiet"] + extra,
                               capture_output=True, text=True)
            row[name + "_exit"] = p.returncode
            row[name + "_flagged"] = "odometer: for" in p.stderr
        return row
    finally:
        shutil.rmtree(work, ignore_errors=True)


def reversed_heading(binary, seeds, first, jobs, csv_path, extra):
    todo = [(binary, first + s, v, extra) for v in (True, False) for s in range(seeds)]
    rows = run_seeds(reversed_one, todo, jobs, csv_path)
    print("| GNSS | start | seeds | exit 0 | exit 3 (flagged) | named by the odometer verdict | other exit |")
    print("|---|---|---|---|---|---|---|")
    for v in (True, False):
        rs = [r for r in rows if r["velocity"] == v]
        for name, what in (("given", "as simulated"), ("noinit", "no [init]"),
                           ("reversed", "heading given 180° off")):
            print("| %s | %s | %d | %d | %d | %d | %d |" % (
                "position + velocity" if v else "position only", what, len(rs),
                sum(r[name + "_exit"] == 0 for r in rs), sum(r[name + "_exit"] == 3 for r in rs),
                sum(r[name + "_flagged"] for r in rs),
                sum(r[name + "_exit"] not in (0, 3) for r in rs)))


def scale_noise(text, factor):
    """`[imu_noise]` ARW and VRW divided by `factor` (a peer's "optimised" settings)."""
    def one(m):
        vals = [float(x) / factor for x in m.group(2).replace("\n", " ").split(",") if x.strip()]
        return m.group(1) + ", ".join("%g" % v for v in vals) + m.group(3)
    for key in ("arw", "vrw"):
        text = re.sub(r"(?s)(\n%s = \[)([^\]]*)(\])" % key, one, text)
    return text


def rover_one(job):
    """One seed of `scenarios/rover.toml`, no `[init]`: with the true IMU noise and with
    ARW and VRW declared `low`× smaller; forward and smoothed horizontal RMS, the
    self-start's heading error and σ, the exit status and the diagnosis."""
    (binary, seed, low, keep_init, extra) = job
    work = tempfile.mkdtemp(prefix="rover-")
    try:
        d, cfg = simulated(binary, work, "rover.toml", seed)
        cfg = cfg if keep_init else strip_init(cfg)
        open(os.path.join(d, "true.toml"), "w").write(cfg)
        open(os.path.join(d, "low.toml"), "w").write(scale_noise(cfg, low))
        truth = os.path.join(d, "truth.nav")
        yaw0 = float(open(truth).readline().split()[10])
        row = {"seed": seed, "init": keep_init}
        for name in ("true", "low"):
            out = os.path.join(work, "o_" + name)
            p = subprocess.run([binary, "run", os.path.join(d, name + ".toml"), "--out", out,
                                "--quiet", "--smooth"] + extra, capture_output=True, text=True)
            row[name + "_exit"] = p.returncode
            m = re.search(HEADING, p.stdout)
            row[name + "_heading_err"] = (float(m.group(1)) - yaw0 + 180.0) % 360.0 - 180.0 if m else float("nan")
            row[name + "_heading_std"] = float(m.group(2)) if m else float("nan")
            row[name + "_message"] = " | ".join(l for l in (p.stderr + p.stdout).splitlines()
                                                if "cause" in l or l.startswith("  - ") or l.startswith("error"))[:400]
            for part in ("forward", "smoothed"):
                row["%s_%s" % (name, part)] = float("nan")
            if os.path.exists(os.path.join(out, "nav.txt")):
                e = subprocess.run([binary, "eval", out, truth, "--json"], capture_output=True, text=True)
                if e.returncode == 0:
                    j = json.loads(e.stdout)
                    for part in ("forward", "smoothed"):
                        if part in j:
                            row["%s_%s" % (name, part)] = j[part]["overall"]["horizontal"]["rms"]
        return row
    finally:
        shutil.rmtree(work, ignore_errors=True)


def rover(binary, seeds, first, jobs, low, keep_init, csv_path, extra):
    todo = [(binary, first + s, low, keep_init, extra) for s in range(seeds)]
    rows = run_seeds(rover_one, todo, jobs, csv_path)
    med = lambda xs: sorted(xs)[len(xs) // 2] if xs else float("nan")
    print("| IMU noise declared | seeds | started | exit 3 | heading within 3σ | median forward / "
          "smoothed m | smoothed worse than forward |")
    print("|---|---|---|---|---|---|---|")
    for name in ("true", "low"):
        st = [r for r in rows if not math.isnan(r[name + "_forward"])]
        within = [r for r in st if abs(r[name + "_heading_err"]) <= 3 * r[name + "_heading_std"]]
        worse = [r for r in st if r[name + "_smoothed"] > r[name + "_forward"]]
        print("| %s | %d | %d | %d | %s | %.3f / %.3f | %d |" % (
            ("as simulated" if name == "true" else "ARW, VRW %g× too small" % low) + (", `[init]` given" if rows and rows[0].get("init") else ""),
            len(rows), len(st),
            sum(r[name + "_exit"] == 3 for r in rows), "n/a" if rows and rows[0]["init"] else len(within),
            med([r[name + "_forward"] for r in st]), med([r[name + "_smoothed"] for r in st]), len(worse)))
    ratio = [r["low_forward"] / r["true_forward"] for r in rows
             if not math.isnan(r["low_forward"]) and not math.isnan(r["true_forward"])]
    ratio_s = [r["low_smoothed"] / r["true_smoothed"] for r in rows
               if not math.isnan(r["low_smoothed"]) and not math.isnan(r["true_smoothed"])]
    print("\nlow / true, forward: median %.2f, max %.2f; smoothed: median %.2f, max %.2f (%d seeds both ran)"
          % (med(ratio), max(ratio, default=float("nan")), med(ratio_s), max(ratio_s, default=float("nan")),
             len(ratio)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "ins-gnss"))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--rates", default="0,2,5,10,20,50")
    ap.add_argument("--starts", default="0,60")
    ap.add_argument("--size", type=float, default=1000.0)
    ap.add_argument("--configs", default="yaml,noinit")
    ap.add_argument("--bound", type=float, default=5.0, help="horizontal RMS bound, m")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--csv")
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "campaign-navego"))
    ap.add_argument("extra", nargs="*", help="more arguments for `ins-gnss run` (after --)")
    ap.add_argument("--table", help="print the table of an earlier run's CSV and stop")
    ap.add_argument("--rover", action="store_true",
                    help="the slow-rover campaign instead: scenarios/rover.toml by seed, no `[init]`, "
                         "with the true IMU noise and with ARW and VRW declared --low times smaller")
    ap.add_argument("--low", type=float, default=100.0)
    ap.add_argument("--init", action="store_true",
                    help="--rover: keep the simulator's `[init]` (the noise's effect alone)")
    ap.add_argument("--walk", action="store_true",
                    help="the self-start campaign instead: scenarios/walk.toml by seed, with and "
                         "without GNSS velocity, no [init] against the given state")
    ap.add_argument("--fleet", nargs="?", const="", default=None, metavar="ADDRESS",
                    help="run on a Dask cluster through estimator.fleet: a local one of --jobs "
                         "workers, or the scheduler at ADDRESS (needs the Python package)")
    ap.add_argument("--reversed", action="store_true",
                    help="the odometer verdict's campaign instead: scenarios/car-aided.toml by "
                         "seed with --odometer, its heading as simulated, found, and 180° off")
    a = ap.parse_args()
    global FLEET
    FLEET = a.fleet
    if a.rover:
        rover(os.path.abspath(a.bin), a.seeds, a.first_seed, a.jobs, a.low, a.init, a.csv, a.extra)
        return
    if a.reversed:
        reversed_heading(os.path.abspath(a.bin), a.seeds, a.first_seed, a.jobs, a.csv, a.extra)
        return
    if a.walk:
        walk(os.path.abspath(a.bin), a.seeds, a.first_seed, a.jobs, a.csv, a.extra)
        return
    if a.table:
        rows = list(csv.DictReader(open(a.table)))
        for r in rows:
            for k in ("rate", "start", "horiz_rms", "refused_share"):
                r[k] = float(r[k])
            r["exit"] = int(r["exit"])
        table(rows, a.bound)
        return
    os.makedirs(a.cache, exist_ok=True)
    unpack(os.path.join(NAVEGO, "GNSS-POS.txt.zst"), os.path.join(a.cache, "GNSS-POS"))
    unpack(os.path.join(NAVEGO, "IMU-ADIS16488.txt.zst"), os.path.join(a.cache, "IMU-ADIS16488"))
    unpack(os.path.join(NAVEGO, "truth.nav.zst"), os.path.join(a.cache, "truth.nav"))
    rates = [float(x) for x in a.rates.split(",")]
    starts = [float(x) for x in a.starts.split(",")]
    jobs = []
    for kind in a.configs.split(","):
        for rate in rates:
            for start in starts if rate > 0 else starts[:1]:
                for s in range(a.seeds):
                    jobs.append((os.path.abspath(a.bin), kind, rate, start, a.size, a.first_seed + s, a.cache, a.extra))
    rows = dispatch(one, jobs, a.jobs)
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)
    table(rows, a.bound)


if __name__ == "__main__":
    main()
