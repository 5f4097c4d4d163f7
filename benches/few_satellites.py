#!/usr/bin/env python3
"""Few-satellite campaigns (the RTK issue's item 1: "a tight run never worse than a single
point"), run as a user runs them: `ins-gnss simulate` writes a drive or a walk with raw
observations (single frequency as the program uses them, the simulator's error budget:
URA 2.4 m, 0.3 m code biases, half the Klobuchar delay, the troposphere's residual, all
constant per satellite and run), a consumer MEMS IMU and a sky mask; its `[init]` is
removed (the start from the data), the default gate, the noise learned. Per seed:

- the tight run of the observations (`ins-gnss run`, `gnss.coupling = "tight"`),
- the single point of the same observations (`ins-gnss spp --mask 10`, the simulator's
  mask),
- loose coupling of that single point (its `.pos` as the fixes; no fix where fewer than
  four satellites are left).

Cells: a 600 s drive (scenarios/tight.toml's) and a 600 s walk (1.4 m/s, 10 s standing,
straight legs of 10–40 s and turns of 45° or 90°), keeping the 4 or the 5 highest
satellites throughout; and a 60 s canyon (300–360 s) of the 3 or 2 highest on the full
sky otherwise. Scores against the simulator's truth at the 1 Hz epochs: the horizontal
RMS after the first 30 s (sky cells), the largest horizontal error inside the canyon and
what the canyon added to the error at its entry (canyon cells); the tight run's heading
against its own σ (`std.txt`) at every epoch, and the share of its epochs after 30 s whose
horizontal error lies beyond its own 99 % ellipse.

    python3 benches/few_satellites.py [SEEDS] [CELL-FILTER]

`SEEDS`: N for 1..N (default 20). The release binary is built first. Prints one Markdown
row per cell: runs, refused (non-zero exit other than 3), flagged (exit 3), the pooled RMS
of tight and single point and the seeds where tight is worse (sky cells), or the median
and largest canyon maximum of tight and loose and the seeds where tight is above ⅓ of
loose or above 5 m (canyon cells). `KEEP=DIR` keeps each seed's files there;
`INS_GNSS=PATH` runs another build of the program (not built here); `VERBOSE=1` prints
each seed's exits and heading on stderr; `EXTRA='[gnss.tight]\ndoppler = false'` appends
TOML tables to the tight runs' configuration (one change to measure).
"""
import concurrent.futures as cf
import math
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("INS_GNSS") or os.path.join(ROOT, "target", "release", "ins-gnss")
NAV = os.path.join(ROOT, "data", "rinex-rtklib", "07590920.05n.zst")
CANYON = (300.0, 360.0)


def scenario(cell, seed):
    """The scenario file's text for a cell and seed."""
    base = open(os.path.join(ROOT, "ins-gnss", "scenarios", "tight.toml")).read()
    head, rest = base.split("[imu]", 1)
    sensors = "[imu]" + rest.split("[raw]")[0]
    motion, sky = cell.split("-")
    if motion == "drive":
        seg = head
    else:
        rnd = random.Random(1000 + seed)
        seg = "seed = 11\n[start]\ntime = 529200.0\nposition = [30.5, 114.3, 25.0]\n"
        seg += "yaw = %.1f\n" % rnd.uniform(-180, 180)
        seg += '[[segment]]\nkind = "stop"\nduration = 10.0\n'
        seg += '[[segment]]\nkind = "accelerate"\nduration = 1.0\naccel = 1.4\n'
        t = 11.0
        while t < 590.0:
            d = rnd.uniform(10.0, 40.0)
            seg += '[[segment]]\nkind = "straight"\nduration = %.1f\n' % d
            r = rnd.choice([-90, -45, 45, 90])
            seg += '[[segment]]\nkind = "turn"\nduration = 2.0\nrate = %.1f\n' % (r / 2)
            t += d + 2.0
        seg += '[[segment]]\nkind = "decelerate"\nduration = 1.0\naccel = 1.4\n'
        seg += '[[segment]]\nkind = "stop"\nduration = 5.0\n'
    seg = re.sub(r"^seed = \d+", "seed = %d" % seed, seg, flags=re.M)
    keep = int(sky[-1])
    if sky.startswith("canyon"):
        masks = "[[%.1f, %.1f, %d.0]]" % (CANYON[0], CANYON[1], keep)
    else:
        masks = "[[0.0, 1000.0, %d.0]]" % keep
    raw = '[raw]\nnav = "%s"\nweek = 1316\nmasks = %s\n' % (NAV, masks)
    return seg + sensors + raw


def load(path):
    """(t, lat, lon) rows of an 11-column navigation file or an RTKLIB .pos (GPST week,
    seconds)."""
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("%") or not line.strip():
                continue
            p = line.split()
            rows.append((float(p[1]), float(p[2]), float(p[3]), float(p[10]) if len(p) > 10 else 0.0))
    return rows


# the antenna's lever arm (forward, right; m) in scenarios/tight.toml: a single point is the
# antenna's position, the truth and the runs' nav.txt the IMU's
LEVER = (0.4, 0.1)


def errors(result, truth, t0, antenna=False):
    """Horizontal errors (t from the start, m) at the whole seconds both files hold; with
    `antenna`, against the antenna's truth (the IMU's moved by the lever arm, turned by
    the truth's heading)."""
    at = {round(r[0], 2): r for r in truth}
    out = []
    for t, lat, lon, _ in result:
        if abs(t - round(t)) > 1e-6 or round(t, 2) not in at:
            continue
        _, la, lo, yaw = at[round(t, 2)]
        dn = math.radians(lat - la) * 6378137.0
        de = math.radians(lon - lo) * 6378137.0 * math.cos(math.radians(la))
        if antenna:
            c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
            dn -= c * LEVER[0] - s * LEVER[1]
            de -= s * LEVER[0] + c * LEVER[1]
        out.append((t - t0, math.hypot(dn, de)))
    return out


def heading_over_sigma(run_dir, truth):
    """The largest heading error over its own σ (std.txt) at the epochs both hold, and the
    largest heading error (deg)."""
    yaw = {}
    with open(os.path.join(run_dir, "nav.txt")) as f:
        for line in f:
            p = line.split()
            yaw[round(float(p[1]), 2)] = float(p[10])
    at = {round(float(r[0]), 2): r[3] for r in truth}
    worst, worst_deg = 0.0, 0.0
    with open(os.path.join(run_dir, "std.txt")) as f:
        for line in f:
            p = line.split()
            t = round(float(p[0]), 2)
            if t not in yaw or t not in at:
                continue
            e = abs((yaw[t] - at[t] + 180.0) % 360.0 - 180.0)
            worst = max(worst, e / max(float(p[9]), 1e-9))
            worst_deg = max(worst_deg, e)
    return worst, worst_deg


def beyond_ellipse(run_dir, truth, skip):
    """The share of the epochs after `skip` s whose horizontal error lies beyond the run's
    own 99 % ellipse (σ N and E of std.txt, χ²₂ 9.21)."""
    pos = {}
    with open(os.path.join(run_dir, "nav.txt")) as f:
        for line in f:
            p = line.split()
            pos[round(float(p[1]), 2)] = (float(p[2]), float(p[3]))
    at = {round(float(r[0]), 2): r for r in truth}
    t0 = truth[0][0]
    out, n = 0, 0
    with open(os.path.join(run_dir, "std.txt")) as f:
        for line in f:
            p = line.split()
            t = round(float(p[0]), 2)
            if t not in pos or t not in at or t - t0 < skip:
                continue
            _, la, lo, _ = at[t]
            dn = math.radians(pos[t][0] - la) * 6378137.0
            de = math.radians(pos[t][1] - lo) * 6378137.0 * math.cos(math.radians(la))
            n += 1
            out += (dn / float(p[1])) ** 2 + (de / float(p[2])) ** 2 > 9.21
    return out / n if n else float("nan")


def rms_after(e, skip):
    v = [x * x for t, x in e if t >= skip]
    return math.sqrt(sum(v) / len(v)) if v else float("nan")


def max_in(e, a, b):
    v = [x for t, x in e if a <= t < b]
    return max(v) if v else float("nan")


def one(cell, seed, keep):
    d = tempfile.mkdtemp(prefix="few-")
    try:
        open(os.path.join(d, "scen.toml"), "w").write(scenario(cell, seed))
        run = lambda *a: subprocess.run([BIN, *a], cwd=d, capture_output=True, text=True)
        sim = run("simulate", "scen.toml", "--out", ".")
        if sim.returncode != 0:
            return cell, seed, {"error": sim.stderr.strip()}
        text = open(os.path.join(d, "config.toml")).read()
        # the user's run: no [init]
        text = re.sub(r"\n\[init\]\n.*?(?=\n\[imu\])", "\n", text, flags=re.S)
        tight = text.replace('output = "out"', 'output = "tight"')
        # (EXTRA: TOML tables appended to the tight run's configuration, e.g. one change)
        tight += "\n" + os.environ.get("EXTRA", "").replace("\\n", "\n") + "\n"
        open(os.path.join(d, "tight.toml"), "w").write(tight)
        loose = text.replace('output = "out"', 'output = "loose"')
        loose = loose.replace('gnss = "obs.rnx"', 'gnss = "spp.pos"')
        loose = loose.replace('coupling = "tight"', 'coupling = "loose"')
        loose = re.sub(r"nav = \[.*?\]\n", "", loose)
        open(os.path.join(d, "loose.toml"), "w").write(loose)
        run("spp", "obs.rnx", os.path.basename(NAV), "--mask", "10", "-o", "spp.pos")
        out = {}
        for name in ["tight", "loose"]:
            r = run("run", name + ".toml")
            out[name + "_exit"] = r.returncode
            if r.returncode != 0 and r.returncode != 3:
                out[name + "_why"] = (r.stderr.strip().splitlines() or [""])[-1]
        truth = load(os.path.join(d, "truth.nav"))
        t0 = truth[0][0]
        for name, path in [("tight", "tight/nav.txt"), ("loose", "loose/nav.txt"), ("spp", "spp.pos")]:
            p = os.path.join(d, path)
            out[name] = errors(load(p), truth, t0, name == "spp") if os.path.exists(p) else None
        if out["tight"]:
            out["heading"] = heading_over_sigma(os.path.join(d, "tight"), truth)
            out["beyond"] = beyond_ellipse(os.path.join(d, "tight"), truth, 30.0)
        return cell, seed, out
    finally:
        if keep:
            dest = os.path.join(keep, "%s-%d" % (cell, seed))
            shutil.rmtree(dest, ignore_errors=True)
            shutil.copytree(d, dest)
        shutil.rmtree(d, ignore_errors=True)


def main():
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    only = sys.argv[2] if len(sys.argv) > 2 else ""
    keep = os.environ.get("KEEP")
    if not os.environ.get("INS_GNSS"):
        subprocess.run(["cargo", "build", "--release", "-q", "-p", "ins-gnss"], cwd=ROOT, check=True)
    cells = ["drive-sky4", "drive-sky5", "walk-sky4", "walk-sky5",
             "drive-canyon3", "drive-canyon2", "walk-canyon3"]
    cells = [c for c in cells if only in c]
    jobs = [(c, s) for c in cells for s in range(1, seeds + 1)]
    with cf.ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        done = list(pool.map(lambda j: one(j[0], j[1], keep), jobs))
    if os.environ.get("VERBOSE"):
        for c, seed, o in done:
            h = o.get("heading") or (float("nan"), float("nan"))
            print("%s seed %d: exits %s/%s, heading worst %.2f σ, %.2f°"
                  % (c, seed, o.get("tight_exit"), o.get("loose_exit"), h[0], h[1]), file=sys.stderr)
    print("| cell | runs | refused | flagged | tight | single point / loose | tight worse on | tight heading ≤ 3σ throughout (worst error median) | tight beyond its 99 % ellipse | first refusal |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for c in cells:
        rows = [o for cc, s, o in done if cc == c]
        refused = [o for o in rows if "tight_why" in o or "error" in o]
        flagged = sum(1 for o in rows if o.get("tight_exit") == 3)
        ran = [o for o in rows if o.get("tight")]
        hd = sorted(o["heading"][1] for o in ran)
        beyond = sum(o["beyond"] for o in ran) / len(ran) if ran else float("nan")
        covered = "%d of %d (%.2f°)" % (sum(1 for o in ran if o["heading"][0] <= 3.0), len(ran),
                                        hd[len(hd) // 2] if hd else float("nan"))
        why = (refused[0].get("tight_why") or refused[0].get("error", ""))[:120] if refused else ""
        if "canyon" in c:
            a, b = CANYON
            pairs = [(max_in(o["tight"], a, b), max_in(o["loose"], a, b) if o.get("loose") else float("nan")) for o in ran]
            tm = sorted(p[0] for p in pairs)
            lm = sorted(p[1] for p in pairs if not math.isnan(p[1]))
            worse = sum(1 for t, l in pairs if t > 5.0 or (not math.isnan(l) and t > l / 3.0))
            med = lambda v: v[len(v) // 2] if v else float("nan")
            # what the canyon added: its largest error less the error at its entry
            grown = lambda e: max_in(e, a, b) - max_in(e, a - 1.0, a)
            tg = sorted(grown(o["tight"]) for o in ran)
            lg = sorted(grown(o["loose"]) for o in ran if o.get("loose"))
            print("| %s | %d | %d | %d | canyon max median %.2f, largest %.2f m; grown by median %.2f, largest %.2f m | loose: max median %.2f, largest %.2f m; grown by median %.2f, largest %.2f m (%d ran) | %d (> ⅓ loose or > 5 m) | %s | %.1f %% | %s |"
                  % (c, len(rows), len(refused), flagged, med(tm), tm[-1] if tm else float("nan"),
                     med(tg), tg[-1] if tg else float("nan"),
                     med(lm), lm[-1] if lm else float("nan"), med(lg), lg[-1] if lg else float("nan"),
                     len(lm), worse, covered, 100 * beyond, why))
        else:
            pairs = [(rms_after(o["tight"], 30.0), rms_after(o["spp"], 30.0)) for o in ran if o.get("spp")]
            pool_rms = lambda i: math.sqrt(sum(p[i] ** 2 for p in pairs) / len(pairs)) if pairs else float("nan")
            worse = sum(1 for t, s in pairs if t > s)
            print("| %s | %d | %d | %d | RMS %.2f m | single point RMS %.2f m | %d of %d (by ≤ %.2f m) | %s | %.1f %% | %s |"
                  % (c, len(rows), len(refused), flagged, pool_rms(0), pool_rms(1), worse, len(pairs),
                     max([t - s for t, s in pairs] + [0.0]), covered, 100 * beyond, why))


if __name__ == "__main__":
    main()
