#!/usr/bin/env python3
"""Whole-run timings in alternating pairs (docs/history/benches.md, "The second pass and the day").

    python3 benches/pairs.py binaries N CONFIG BIN_A BIN_B [RUN ARGS...]
        BIN_A and BIN_B alternate on `run CONFIG --quiet --accept-inconsistent ARGS`;
        medians of wall and CPU time, and the median of the pair ratios B / A.
    python3 benches/pairs.py smooth N CONFIG BIN [RUN ARGS...]
        one binary, a forward run and a `--smooth` run alternating; the median of the
        pair ratios smoothed / forward.
    python3 benches/pairs.py rerun N CONFIG BIN_A BIN_B [RUN ARGS...]
        as `binaries`, but each binary writes over its own earlier result (a re-run: the
        program keeps the earlier files aside until its verdict), after `sync` (outside
        the timing) so that the earlier files are on the disk, as after a pause.

Each run writes into a fresh temporary directory, removed afterwards (`rerun`: one
directory per binary, kept through the pairs). Wall time is
`time.perf_counter` around the process, CPU time the children's user + system time.
"""
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def run(binary, config, args, over=None):
    out = over or tempfile.mkdtemp(prefix="pairs-")
    if over:
        os.sync()
    try:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        cmd = [binary, "run", config, "--quiet", "--accept-inconsistent", *args, "--out", out]
        done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    finally:
        if not over:
            shutil.rmtree(out, ignore_errors=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} exited {done.returncode}: {done.stderr.decode()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def summary(name, runs):
    wall = statistics.median(r[0] for r in runs) * 1e3
    cpu = statistics.median(r[1] for r in runs) * 1e3
    return f"{name}: wall median {wall:.1f} ms, CPU median {cpu:.1f} ms"


def main():
    if len(sys.argv) < 5 or sys.argv[1] not in ("binaries", "smooth", "rerun"):
        sys.exit(__doc__)
    mode, n, config = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    if mode in ("binaries", "rerun"):
        a, b, args = sys.argv[4], sys.argv[5], sys.argv[6:]
        first, second = (a, args), (b, args)
    else:
        binary, args = sys.argv[4], sys.argv[5:]
        first, second = (binary, args), (binary, [*args, "--smooth"])
    over = [None, None]
    parent = tempfile.mkdtemp(prefix="pairs-") if mode == "rerun" else None
    if parent:
        over = [os.path.join(parent, "a"), os.path.join(parent, "b")]
    try:
        pairs = [(run(first[0], config, first[1], over[0]),
                  run(second[0], config, second[1], over[1])) for _ in range(n)]
    finally:
        if parent:
            shutil.rmtree(parent, ignore_errors=True)
    print(summary(f"{first[0]} {' '.join(first[1])}".strip(), [p[0] for p in pairs]))
    print(summary(f"{second[0]} {' '.join(second[1])}".strip(), [p[1] for p in pairs]))
    ratios = [p[1][0] / p[0][0] for p in pairs]
    print(f"pair ratio (second / first), {n} pairs: median {statistics.median(ratios):.3f}, "
          f"range {min(ratios):.3f}-{max(ratios):.3f}")


if __name__ == "__main__":
    main()
