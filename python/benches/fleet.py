"""N logs on this machine's cores: one after the other in this process, against
`estimator.fleet` on a local Dask cluster of 2 workers (its start included, and with a
cluster already running). `python python/benches/fleet.py [N]`."""

import sys
import time

import estimator
from estimator.fleet import run_job
from dask.distributed import Client, LocalCluster


def main():
    N = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    CONFIG = "data/drive-0708/kf-gins-outage15.yaml"
    jobs = [estimator.Job(f"run {k}", CONFIG) for k in range(N)]

    t0 = time.perf_counter()
    for j in jobs:
        run_job(j)
    seq = time.perf_counter() - t0

    t0 = time.perf_counter()
    table = estimator.fleet(jobs, workers=2, progress=False)
    with_start = time.perf_counter() - t0
    assert table["ok"].all(), table["error"].tolist()

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    estimator.fleet(jobs[:2], client=client, progress=False)  # (workers warmed up)
    t0 = time.perf_counter()
    estimator.fleet(jobs, client=client, progress=False)
    running = time.perf_counter() - t0
    client.close()
    cluster.close()
    print(f"{N} runs of {CONFIG}: sequential {seq:.2f} s; fleet of 2 workers {with_start:.2f} s "
          f"with the cluster's start, {running:.2f} s on a running cluster "
          f"({seq / running:.2f}× faster)")


if __name__ == "__main__":  # (the workers are spawned processes)
    main()
