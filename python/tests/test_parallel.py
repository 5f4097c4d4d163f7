"""Many logs at once: the runs release the GIL (threads) and run in worker processes
(multiprocessing), each giving the sequential run's numbers."""

from concurrent.futures import ThreadPoolExecutor
from multiprocessing import get_context

import numpy as np

import estimator
from conftest import DATA

CONFIGS = [DATA / "navego" / "kf-gins-ADIS16488.yaml", DATA / "navego" / "kf-gins-ADIS16405.yaml"]


def horizontal(config) -> "tuple[float, np.ndarray]":
    run = estimator.navigate(config, accept_inconsistent=True)
    rms = run.evaluate(DATA / "navego" / "truth.nav.zst")["overall"]["horizontal"]["rms"]
    return rms, run.nav.to_numpy()[-1]


def test_eight_logs_in_a_process_pool_and_in_threads_match_the_sequential_runs():
    logs = [CONFIGS[k % 2] for k in range(8)]
    sequential = [horizontal(c) for c in logs]
    with get_context("spawn").Pool(2) as pool:
        pooled = pool.map(horizontal, logs)
    with ThreadPoolExecutor(2) as threads:
        threaded = list(threads.map(horizontal, logs))
    for (rms, last), (p_rms, p_last), (t_rms, t_last) in zip(sequential, pooled, threaded):
        assert rms == p_rms == t_rms
        assert np.array_equal(last, p_last) and np.array_equal(last, t_last)
    # the two IMUs give different results (the runs are not all the same run)
    assert sequential[0][0] != sequential[1][0]
