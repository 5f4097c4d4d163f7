"""RTK from Python against the program (`ins-gnss rtk`) on the shipped stations (a 3.3 km
baseline): the same solutions to the digits its `.pos` prints, the metrics consistent
with the solutions, the comparison with RTKLIB's solution, settings out of range
refused by name."""

import subprocess

import numpy as np
import pytest

import estimator
from conftest import DATA

ST = DATA / "rinex-rtklib"
ROVER, BASE, NAV = ST / "07590920.05o.zst", ST / "30400920.05o.zst", ST / "07590920.05n.zst"
RTKLIB_L1 = ST / "rtklib" / "rtk0759-kinematic-l1.pos.zst"
RTKLIB_STATIC = ST / "rtklib" / "rtk0759-static-l1l2.pos.zst"


def read_pos(path):
    """Our `.pos` (week, tow, lat, lon, h, Q, ns, sdn, sde, sdu, …) as rows."""
    rows = [line.split() for line in path.read_text().splitlines()
            if line.strip() and not line.startswith("%")]
    return np.array([[float(v) for v in r] for r in rows])


def test_rtk_gives_the_programs_solutions_and_metrics(cli, tmp_path):
    out = tmp_path / "l1.pos"
    done = subprocess.run([str(cli), "rtk", str(ROVER), str(BASE), str(NAV), "--frequencies", "1",
                           "--out", str(out)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    theirs = read_pos(out)
    r = estimator.rtk(ROVER, BASE, NAV, frequencies=1, against=RTKLIB_L1)
    s, m = r["solutions"], r["metrics"]
    assert list(s.columns) == estimator.RTK_COLUMNS
    assert len(s) == len(theirs) == m["solved"] == 120 and m["epochs"] == 120
    # the program's digits: time, latitude and longitude (1e-11°), height (1e-6 m), Q,
    # satellites, σ (1e-6 m; the .pos's third is up, ours down: the same σ)
    assert np.array_equal(s["week"], theirs[:, 0])
    assert np.allclose(s["tow"], theirs[:, 1], atol=6e-5, rtol=0)
    assert np.allclose(s[["lat", "lon"]], theirs[:, 2:4], atol=6e-11, rtol=0)
    assert np.allclose(s["h"], theirs[:, 4], atol=6e-7, rtol=0)
    assert np.array_equal(s["q"], theirs[:, 5]) and np.array_equal(s["sats"], theirs[:, 6])
    assert np.allclose(s[["sdn", "sde", "sdd"]], theirs[:, 7:10], atol=6e-7, rtol=0)
    # the metrics are the solutions' (L1 alone on this baseline: the first fix at 360 s,
    # docs/guide/program.md)
    fixed = s["q"] == 1
    assert m["fixed"] == fixed.sum() == 108
    assert m["fix_rate"] == pytest.approx(108 / 120)
    assert m["time_to_first_fix"] == pytest.approx(s["tow"][fixed].iloc[0] - s["tow"].iloc[0])
    assert m["refix_times"] == [] and m["failures"] == {}
    ratios = s["ratio"][fixed]
    assert m["ratio_fixed"][0] == pytest.approx(ratios.min())
    assert (s["fixed_ambiguities"][fixed] > 0).all() and (s["fixed_ambiguities"][~fixed] == 0).all()
    # against RTKLIB's L1 solution: no fixed epoch 10 cm from it
    a = r["against"]
    assert a["common"] == 115 and a["wrong_fixes"] == 0 and a["fixed_compared"] == 103
    assert a["rms"] < 0.1
    lat, lon, h = r["base"]
    assert lat == pytest.approx(35.16, abs=0.1) and lon == pytest.approx(139.6, abs=0.1)


def test_a_static_rover_fixes_every_epoch_within_millimetres_of_rtklib():
    r = estimator.rtk(ROVER, BASE, [NAV], static=True, against=RTKLIB_STATIC)
    m, a = r["metrics"], r["against"]
    assert m["fixed"] == m["solved"] == 120 and m["fix_rate"] == 1.0
    assert m["time_to_first_fix"] == pytest.approx(0.0, abs=1e-3)
    assert a["wrong_fixes"] == 0 and a["rms"] < 0.002


@pytest.mark.parametrize("setting, value", [("frequencies", 3), ("mask", 95.0), ("ratio", 0.5),
                                            ("max_age", 0.0), ("min_success_rate", 1.5),
                                            ("code_bias_sigma", -1.0), ("code_bias_tau", 0.0),
                                            ("frequencies", -1), ("hold", -1),
                                            ("base_position", [1.0, 2.0])])
def test_a_setting_out_of_range_is_refused_by_name(setting, value):
    with pytest.raises(estimator.EstimatorError, match=f"`{setting}`"):
        estimator.rtk(ROVER, BASE, NAV, **{setting: value})


def test_a_missing_file_is_named():
    with pytest.raises(FileNotFoundError, match="base"):
        estimator.rtk(ROVER, ST / "nothing.05o", NAV)
