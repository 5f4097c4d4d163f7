"""Whole-run timings of the bindings against the program, on navego (not part of CI).

    python python/benches/compare.py [path/to/ins-gnss] [runs]

1. The call overhead: `estimator.navigate(...)` in this process against `ins-gnss run
   ... --out DIR` as a process, alternated, median of `runs` (10) each, forward and
   smoothed.
2. Many logs: 8 navego runs sequentially, then in a process pool of 2 workers
   (multiprocessing, spawn), then in a thread pool of 2 (the runs release the GIL).
"""

import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import estimator

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "data" / "navego" / "kf-gins-ADIS16488.yaml"


def one(smooth=False):
    return len(estimator.navigate(CONFIG, smooth=smooth, accept_inconsistent=True).nav)


def main():
    exe = sys.argv[1] if len(sys.argv) > 1 else str(REPO / "target" / "release" / "ins-gnss")
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 10
    out = tempfile.mkdtemp()
    one()  # warm the page cache
    for smooth in (False, True):
        cli, py = [], []
        for _ in range(runs):
            args = [exe, "run", str(CONFIG), "--quiet", "--accept-inconsistent", "--out", out]
            t = time.perf_counter()
            subprocess.run(args + (["--smooth"] if smooth else []), check=True,
                           stdout=subprocess.DEVNULL)
            cli.append(time.perf_counter() - t)
            t = time.perf_counter()
            one(smooth)
            py.append(time.perf_counter() - t)
        c, p = statistics.median(cli), statistics.median(py)
        print(f"{'smoothed' if smooth else 'forward '}: program {c:.3f} s, Python call "
              f"{p:.3f} s, overhead {100 * (p / c - 1):+.1f} % (median of {runs})")
    t, cpu = time.perf_counter(), time.process_time()
    for _ in range(8):
        one()
    seq, cpu = time.perf_counter() - t, time.process_time() - cpu
    with get_context("spawn").Pool(2) as pool:
        pool.map(one, [False] * 2)  # start the workers (imports) before timing
        t = time.perf_counter()
        pool.map(one, [False] * 8)
        pooled = time.perf_counter() - t
    with ThreadPoolExecutor(2) as threads:
        t = time.perf_counter()
        list(threads.map(one, [False] * 8))
        threaded = time.perf_counter() - t
    print(f"8 navego runs: sequential {seq:.2f} s wall, {cpu:.2f} s CPU (each run uses "
          f"{cpu / seq:.2f} cores: reader, filter and writer threads); process pool of 2 "
          f"{pooled:.2f} s ({pooled / seq:.2f}×), thread pool of 2 {threaded:.2f} s "
          f"({threaded / seq:.2f}×); the floor on 2 cores, CPU / 2: {cpu / 2:.2f} s "
          f"({cpu / 2 / seq:.2f}×)")


if __name__ == "__main__":
    main()
