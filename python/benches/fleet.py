"""N logs on this machine's cores: one after the other in this process, against
`estimator.fleet` on a local Dask cluster of 2 workers (its start included, and with a
cluster already running). `python python/benches/fleet.py [N]`: N runs of drive-0708's
KF-GINS YAML; `python python/benches/fleet.py --corrupted [N]`: N logs, navego and
drive-0708 in turn, each with its GNSS fixes corrupted by its own seed
(:func:`corrupted_jobs`, what `python/tests/test_fleet.py` runs), and one broken log."""

import io
import os
import sys
import tempfile
import time

import numpy as np

import estimator
from estimator.fleet import run_job

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
SETS = {  # name: (folder, KF-GINS YAML, its GNSS file, the truth)
    "navego": ("navego", "kf-gins-ADIS16488.yaml", "GNSS-POS.txt.zst", "truth.nav.zst"),
    "drive-0708": ("drive-0708", "kf-gins-outage15.yaml", "GNSS-RTK-outage10x15.txt.zst",
                   "ref_rtkfix.txt.zst"),
}


def _read_zst(path):
    import zstandard

    with open(path, "rb") as f:
        return np.loadtxt(io.TextIOWrapper(zstandard.ZstdDecompressor().stream_reader(f)))


def corrupted_jobs(folder, n, share=0.05, size=30.0, first_seed=1):
    """`n` jobs, navego and drive-0708 in turn, each a copy of the set's KF-GINS YAML whose
    GNSS file has `share` of its fixes moved `size` m at random bearings by its seed,
    written into `folder`; and one broken log (a GNSS file with a malformed line) last."""
    gnss = {k: _read_zst(os.path.join(ROOT, "data", d, g)) for k, (d, _, g, _) in SETS.items()}
    jobs = []
    for k in range(n):
        name = list(SETS)[k % len(SETS)]
        d, yaml, _, truth = SETS[name]
        seed = first_seed + k
        rng = np.random.default_rng(seed)
        rows = gnss[name].copy()
        hit = rng.random(len(rows)) < share
        bearing = rng.uniform(0.0, 2.0 * np.pi, len(rows))
        lat = np.radians(rows[:, 1])
        rows[hit, 1] += np.degrees(size * np.cos(bearing[hit]) / 6378137.0)
        rows[hit, 2] += np.degrees(size * np.sin(bearing[hit]) / (6378137.0 * np.cos(lat[hit])))
        path = os.path.join(folder, f"{name}-{seed}.txt")
        np.savetxt(path, rows, fmt="%.9f")
        jobs.append(estimator.Job(f"{name} seed {seed}", _yaml(folder, d, yaml, path, seed),
                                  truth=os.path.join(ROOT, "data", d, truth), skip=60))
    broken = os.path.join(folder, "broken.txt")
    rows = gnss["navego"]
    with open(broken, "w") as f:   # navego's fixes with a malformed line 101
        np.savetxt(f, rows[:100], fmt="%.9f")
        f.write("not a number\n")
        np.savetxt(f, rows[100:], fmt="%.9f")
    d, yaml, _, _ = SETS["navego"]
    jobs.append(estimator.Job("broken", _yaml(folder, d, yaml, broken, "broken")))
    return jobs


def _yaml(folder, d, yaml, gnss_path, tag):
    """The set's KF-GINS YAML with absolute paths and `gnss_path` as its GNSS file."""
    text = open(os.path.join(ROOT, "data", d, yaml)).read().splitlines()
    out = []
    for line in text:
        key = line.split(":")[0].strip()
        if key == "imupath":
            imu = line.split(":", 1)[1].strip().strip('"')
            line = f'imupath: "{os.path.join(ROOT, "data", d, imu)}"'
        elif key == "gnsspath":
            line = f'gnsspath: "{gnss_path}"'
        elif key == "outputpath":
            line = f'outputpath: "{os.path.join(folder, f"out-{tag}")}"'
        out.append(line)
    path = os.path.join(folder, f"{d}-{tag}.yaml")
    open(path, "w").write("\n".join(out) + "\n")
    return path


def main():
    from dask.distributed import Client, LocalCluster

    corrupted = "--corrupted" in sys.argv
    args = [a for a in sys.argv[1:] if a != "--corrupted"]
    N = int(args[0]) if args else 8
    folder = tempfile.mkdtemp(prefix="fleet-")
    if corrupted:
        jobs = corrupted_jobs(folder, N)
        CONFIG = "navego and drive-0708 corrupted by seed, and one broken log"
    else:
        CONFIG = "data/drive-0708/kf-gins-outage15.yaml"
        jobs = [estimator.Job(f"run {k}", CONFIG) for k in range(N)]

    t0 = time.perf_counter()
    for j in jobs:
        run_job(j)
    seq = time.perf_counter() - t0

    t0 = time.perf_counter()
    table = estimator.fleet(jobs, workers=2, progress=False)
    with_start = time.perf_counter() - t0
    assert table["ok"].sum() == N, table["error"].tolist()

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    estimator.fleet(jobs[:2], client=client, progress=False)  # (workers warmed up)
    t0 = time.perf_counter()
    estimator.fleet(jobs, client=client, progress=False)
    running = time.perf_counter() - t0
    client.close()
    cluster.close()
    print(f"{len(jobs)} runs of {CONFIG}: sequential {seq:.2f} s; fleet of 2 workers {with_start:.2f} s "
          f"with the cluster's start, {running:.2f} s on a running cluster "
          f"({seq / running:.2f}× faster)")


if __name__ == "__main__":  # (the workers are spawned processes)
    main()
