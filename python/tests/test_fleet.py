"""Fleets on Dask: a two-worker local cluster runs navego logs and a bad one; the table
has a row per job in order, the numbers of the sequential runs, the verdict, and the
bad log's message without stopping the others. And a campaign of seeds of one's own."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import estimator
from conftest import REPO

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "data")
NAVEGO = os.path.join(DATA, "navego", "kf-gins-ADIS16488.yaml")
TRUTH = os.path.join(DATA, "navego", "truth.nav.zst")


def seed_row(seed):
    """A campaign's job of one's own: one simulated figure per seed."""
    rng = np.random.default_rng(seed)
    return {"seed": seed, "figure": float(rng.normal())}


def test_fleet_on_a_two_worker_local_cluster(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[data]\nimu = 'missing.txt'\ngnss = 'missing.txt'\nimu_rate = 100.0\n"
                   "[imu_noise]\narw = [0.2, 0.2, 0.2]\nvrw = [0.1, 0.1, 0.1]\n"
                   "gyro_bias_std = [10.0, 10.0, 10.0]\naccel_bias_std = [100.0, 100.0, 100.0]\n"
                   "corr_time = 1.0\n")
    jobs = [estimator.Job(f"navego {s}", NAVEGO, truth=TRUTH, skip=60,
                          options={"strategy": s})
            for s in ("fixed", "sage-husa", "fused")]
    jobs.insert(1, estimator.Job("bad", str(bad)))
    table = estimator.fleet(jobs, workers=2)
    assert list(table["name"]) == ["navego fixed", "bad", "navego sage-husa", "navego fused"]
    assert list(table["ok"]) == [True, False, True, True]
    assert "missing.txt" in table.loc[1, "error"], table.loc[1, "error"]
    # the numbers of the same runs made here, one after the other
    for k, s in ((0, "fixed"), (2, "sage-husa"), (3, "fused")):
        nav = estimator.navigate(NAVEGO, strategy=s, accept_inconsistent=True)
        rms = nav.evaluate(TRUTH, 60)["overall"]["horizontal"]["rms"]
        assert table.loc[k, "horizontal_rms"] == rms
        assert table.loc[k, "verdict"] == ("trusted" if nav.summary["warning"] is None
                                          else "flagged")
    assert math.isclose(table.loc[0, "horizontal_rms"], 1.438, abs_tol=0.001)  # noise learned (docs/history/results.md, step 1)
    assert (table.loc[[0, 2, 3], "refused_share"] >= 0).all()
    assert (table["time_s"] > 0).all()
    assert "fleet [" in capsys.readouterr().err  # the progress bar

    seeds = estimator.fleet([estimator.Job(f"seed {s}", run=seed_row, options={"seed": s})
                             for s in range(6)], workers=2, progress=False)
    assert list(seeds["seed"]) == list(range(6))
    assert list(seeds["figure"]) == [seed_row(s)["figure"] for s in range(6)]


def test_the_campaign_runner_on_the_fleet_gives_the_threads_rows(cli, tmp_path):
    """`benches/campaign.py --fleet` (the decisions' campaigns on Dask through
    `estimator.fleet`) writes the same rows as its thread pool: the walk self-start
    campaign over two seeds, with and without GNSS velocity."""
    script = REPO / "benches" / "campaign.py"
    out = {}
    for name, extra in [("threads", []), ("fleet", ["--fleet"])]:
        csv = tmp_path / f"{name}.csv"
        r = subprocess.run([sys.executable, str(script), "--bin", str(cli), "--walk",
                            "--seeds", "2", "--jobs", "2", "--csv", str(csv), *extra],
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-2000:]
        out[name] = csv.read_text()
    assert out["threads"] == out["fleet"]
    assert len(out["fleet"].splitlines()) == 1 + 4


def test_a_fleet_of_twenty_corrupted_logs_and_a_broken_one(tmp_path):
    """20 logs — navego and drive-0708 in turn, 5 % of each one's fixes moved 30 m by its
    own seed — and one broken log on a two-worker local cluster: a row for every log in
    order, the broken one with the reader's message, the others with their errors against
    the truth, the gate's refusals and a verdict; the numbers those of the same runs made
    one after the other here."""
    sys.path.insert(0, str(REPO / "python" / "benches"))
    from fleet import corrupted_jobs

    jobs = corrupted_jobs(str(tmp_path), 20)
    table = estimator.fleet(jobs, workers=2, progress=False)
    assert list(table["name"]) == [j.name for j in jobs] and len(table) == 21
    assert list(table["ok"]) == [True] * 20 + [False]
    assert "broken.txt:101" in table.loc[20, "error"], table.loc[20, "error"]
    good = table.iloc[:20]
    assert good["horizontal_rms"].notna().all() and (good["refused_share"] > 0).all()
    assert set(good["verdict"]) <= {"trusted", "flagged"}
    # each set's errors stay where its clean run is (navego 1.4 m; drive-0708 12 m with its
    # ten outages): the gate keeps the 30 m fixes out
    navego = good[good["name"].str.startswith("navego")]["horizontal_rms"]
    drive = good[good["name"].str.startswith("drive")]["horizontal_rms"]
    assert navego.max() < 3.0 and drive.max() < 20.0, (navego.tolist(), drive.tolist())
    for k in (0, 1):
        nav = estimator.navigate(jobs[k].config, accept_inconsistent=True)
        rms = nav.evaluate(jobs[k].truth, 60)["overall"]["horizontal"]["rms"]
        assert table.loc[k, "horizontal_rms"] == rms
