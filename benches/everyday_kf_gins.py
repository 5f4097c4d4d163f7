#!/usr/bin/env python3
"""KF-GINS side by side on the everyday corpus's drive-0708 cells (the everyday-GNSS issue).

    DUMP=/tmp/dump cargo run --release --features campaigns --example everyday_corpus 20 "drive-0708 yaml | wander 1.5/1.5/3 m τ 100 s +0.3 | ×1$"
    python3 benches/everyday_kf_gins.py /tmp/dump [KF-GINS]

For each `gnss-drive-0708-yaml-SEED.txt` the corpus wrote (drive-0708's RTK fixes moved by
the cell's errors, their σ columns as declared), runs KF-GINS (default
`../shared/bin/kf-gins`) with drive-0708's shipped YAML (its hand-written initial state
and datasheet noise) reading that file, and prints per seed and over the seeds: the
outages' score (the RMS over the ten 15 s outages of the largest horizontal error
against `ref_rtkfix`, as the corpus scores ours) and the share of the epochs with a fix
whose horizontal error lies beyond KF-GINS's own 99 % ellipse (σ N, E of
`KF_GINS_STD.txt`, χ²₂ 9.21). Needs Python's standard library and the `zstd` command.
"""
import json, math, os, re, subprocess, sys, tempfile
from bisect import bisect_left

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "data", "drive-0708")
EARTH = 6378137.0


def rows(path):
    text = subprocess.run(["zstd", "-dqc", path], check=True, capture_output=True, text=True).stdout
    return [[float(x) for x in l.split()] for l in text.splitlines() if l.strip() and not l.startswith("#")]


def main():
    dump = sys.argv[1]
    kf = os.path.abspath(sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "..", "shared", "bin", "kf-gins"))
    truth = [(r[0], math.radians(r[1]), math.radians(r[2])) for r in rows(os.path.join(DATA, "ref_rtkfix.txt.zst"))]
    tt = [r[0] for r in truth]
    windows = json.load(open(os.path.join(DATA, "outage_windows_15s.json")))

    def herr(t, lat, lon):
        k = bisect_left(tt, t)
        if k == 0 or k >= len(tt):
            return None
        a, b = truth[k - 1], truth[k]
        if b[0] - a[0] > 1.0:
            return None
        f = (t - a[0]) / (b[0] - a[0])
        tl, tn = a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])
        return ((math.radians(lat) - tl) * EARTH, (math.radians(lon) - tn) * EARTH * math.cos(tl))

    work = tempfile.mkdtemp()
    imu = os.path.join(work, "IMU.txt")
    subprocess.run(["zstd", "-dqf", os.path.join(DATA, "IMU.txt.zst"), "-o", imu], check=True)
    yaml = open(os.path.join(DATA, "kf-gins-outage15.yaml")).read()
    files = sorted(f for f in os.listdir(dump) if re.fullmatch(r"gnss-drive-0708-yaml-\d+\.txt", f))
    scores, covers = [], []
    for f in files:
        seed = int(re.findall(r"\d+", f)[-1])
        out = os.path.join(work, "out%d" % seed)
        os.makedirs(out, exist_ok=True)
        cfg = re.sub(r'(?m)^imupath:.*$', 'imupath: "%s"' % imu, yaml)
        cfg = re.sub(r'(?m)^gnsspath:.*$', 'gnsspath: "%s"' % os.path.join(os.path.abspath(dump), f), cfg)
        cfg = re.sub(r'(?m)^outputpath:.*$', 'outputpath: "%s"' % out, cfg)
        path = os.path.join(work, "k%d.yaml" % seed)
        open(path, "w").write(cfg)
        subprocess.run([kf, path], check=True, capture_output=True, cwd=work)
        nav = [[float(x) for x in l.split()] for l in open(os.path.join(out, "KF_GINS_Navresult.nav"))]
        std = [[float(x) for x in l.split()] for l in open(os.path.join(out, "KF_GINS_STD.txt"))]
        fixes = sorted(float(l.split()[0]) for l in open(os.path.join(dump, f)) if l.strip())
        worst = []
        for a, b in windows:
            e = [herr(r[1], r[2], r[3]) for r in nav if a <= r[1] <= b]
            worst.append(max((math.hypot(*x) for x in e if x), default=0.0))
        score = math.sqrt(sum(w * w for w in worst) / len(worst))
        # the epochs with a fix (the first IMU row at or after it)
        n = beyond = 0
        times = [r[1] for r in nav]
        for tf in fixes:
            k = bisect_left(times, tf - 1e-6)
            if k >= len(nav) or nav[k][1] - tf > 0.011:
                continue
            e = herr(nav[k][1], nav[k][2], nav[k][3])
            if e is None:
                continue
            n += 1
            sn, se = std[k][1], std[k][2]
            beyond += (e[0] / sn) ** 2 + (e[1] / se) ** 2 > 9.21
        scores.append(score)
        covers.append(beyond / max(n, 1))
        print("seed %d: outages' score %.3f m, %.1f %% beyond its 99 %% ellipse" % (seed, score, 100 * covers[-1]))
    if scores:
        print("KF-GINS over %d seeds: mean score %.3f m, %.1f %% beyond" % (len(scores), sum(scores) / len(scores), 100 * sum(covers) / len(covers)))


if __name__ == "__main__":
    main()
