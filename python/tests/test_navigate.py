"""The navigator from Python against the program (`ins-gnss run`) on the sample data:
the same numbers to the digits the program prints, the same verdicts, the same RMS; the
arrays path against the files path bit for bit; pyins-style DataFrames without a file."""

import json
import math
import os
import subprocess

import numpy as np
import pandas as pd
import pytest

import estimator
from conftest import DATA, read_zst

ROOT = DATA.parent

NAVEGO = DATA / "navego" / "kf-gins-ADIS16488.yaml"
TRUTH = DATA / "navego" / "truth.nav.zst"

# decimals the program prints, per column
NAV_DECIMALS = [6, 10, 10, 4, 5, 5, 5, 8, 8, 8]
STD_DECIMALS = [6] + [6] * 6 + [8] * 3 + [6] * 6
ERR_DECIMALS = [6] * 7

# the datasheet noise of the navego configurations (data/navego/noinit.toml)
NOISE = {"arw": [0.3] * 3, "vrw": [0.029] * 3, "gyro_bias_std": [6.5] * 3,
         "accel_bias_std": [98.0665] * 3, "corr_time": 0.027778}


def fixed(v: float, d: int) -> str:
    """`v` with `d` decimals as the program writes its files (ins-gnss-core's `io::fixed`):
    `round(v · 10^d)` in f64, halves away from zero, no sign on a zero."""
    s = float(v) * float(10**d)
    if not math.isfinite(s) or abs(s) >= 9.0e18:
        return f"{v:.{d}f}"
    a = abs(s)
    n = int(math.floor(a))
    n += 1 if a - n >= 0.5 else 0
    digits = str(n).rjust(d + 1, "0")
    text = digits[: len(digits) - d] + ("." + digits[len(digits) - d:] if d else "")
    return ("-" if math.copysign(1.0, v) < 0 and n != 0 else "") + text


def assert_printed(python: np.ndarray, path, decimals, what: str, skip_columns=0):
    """Python's numbers, printed as the program prints them, are the program's text,
    character for character."""
    lines = path.read_text().splitlines()
    assert python.shape[0] == len(lines), f"{what}: {python.shape[0]} rows vs {len(lines)}"
    for k, (row, line) in enumerate(zip(python, lines)):
        ours = [fixed(v, d) for v, d in zip(row, decimals)]
        theirs = line.split()[skip_columns:]
        assert ours == theirs, f"{what} line {k + 1}: {ours} vs {theirs}"


@pytest.fixture(scope="module")
def both(cli, tmp_path_factory):
    """navego smoothed by the program and by the bindings (the shipped YAML as it is)."""
    out = tmp_path_factory.mktemp("cli")
    subprocess.run(
        [str(cli), "run", str(NAVEGO), "--smooth", "--quiet", "--accept-inconsistent",
         "--out", str(out)],
        check=True,
    )
    py = estimator.navigate(NAVEGO, smooth=True, accept_inconsistent=True)
    return out, py


def test_python_gives_the_programs_numbers_on_navego(both):
    out, py = both
    assert_printed(py.nav.to_numpy(), out / "nav.txt", NAV_DECIMALS, "nav.txt", 1)
    assert_printed(py.std.to_numpy(), out / "std.txt", STD_DECIMALS, "std.txt")
    assert_printed(py.imu_errors.to_numpy(), out / "imu_errors.txt", ERR_DECIMALS,
                   "imu_errors.txt")
    assert_printed(py.smoothed.to_numpy(), out / "nav_smoothed.txt", NAV_DECIMALS,
                   "nav_smoothed.txt", 1)
    assert_printed(py.smoothed_std.to_numpy(), out / "std_smoothed.txt", STD_DECIMALS,
                   "std_smoothed.txt")


def test_python_gives_the_programs_updates_on_navego(both):
    out, py = both
    csv = pd.read_csv(out / "updates.csv", dtype=str, keep_default_na=False)
    assert len(csv) == len(py.updates) > 2000
    for col in ["stream", "decision", "reason"]:
        assert (csv[col] == py.updates[col].astype(str)).all(), col
    assert (csv["dim"] == py.updates["dim"].astype(str)).all()
    # written with the standard formatter (correctly rounded; NaN as `NaN`)
    text = lambda v: "NaN" if math.isnan(v) else f"{v:.6f}"  # noqa: E731
    for col in ["time", "nis", "nis_adapted", "dom", "lambda_p", "lambda_r"]:
        assert (csv[col] == py.updates[col].map(text)).all(), col
    for col in ["scaling_fallback", "not_helping"]:
        assert (csv[col] == py.updates[col].map(lambda b: str(int(b)))).all(), col


def test_python_rms_equals_the_programs_to_the_printed_digit(both, cli):
    out, py = both
    ev = json.loads(subprocess.run(
        [str(cli), "eval", str(out), str(TRUTH), "--json"], check=True,
        capture_output=True, text=True).stdout)
    for label, smoothed in [("forward", False), ("smoothed", True)]:
        cli_stats = ev[label]["overall"] if label in ev else ev["outputs"][label]["overall"]
        py_stats = py.evaluate(TRUTH, smoothed=smoothed)["overall"]
        for key in ["north", "east", "down", "horizontal", "position_3d", "velocity_3d",
                    "roll", "pitch", "yaw"]:
            a, b = py_stats[key]["rms"], cli_stats[key]["rms"]
            # printed to 3 decimals (m) and 4 (deg, m/s): the same digits
            assert abs(a - b) <= 5e-5, f"{label} {key}: {a} vs {b}"
    summary = py.summary
    assert summary["gnss_epochs"] == 2186 and summary["smoothed_rows"] == len(py.smoothed)


def test_per_epoch_errors_and_the_truth_reader_agree_with_independent_paths(both):
    """``evaluate()``'s per-epoch DataFrame against its own statistics, the truth read by
    the library (no zstandard) against the test's own reader, and NEES against the run's
    σ (navego's shipped YAML: hand-written ``[init]``, the gate on)."""
    _, py = both
    truth = estimator.read_truth(TRUTH)
    raw = read_zst(TRUTH)
    assert len(truth) == len(raw)
    np.testing.assert_allclose(truth[["time", "lat", "lon", "height"]].to_numpy(),
                               raw[:, 1:5], rtol=0, atol=1e-9)
    for smoothed in (False, True):
        ev = py.evaluate(TRUTH, skip=30.0, smoothed=smoothed)
        ep = ev["epochs"]
        assert len(ep) == ev["overall"]["epochs"] > 10000
        for col in ["north", "east", "down", "horizontal", "yaw"]:
            rms = float(np.sqrt(np.mean(ep[col] ** 2)))
            assert abs(rms - ev["overall"][col]["rms"]) <= 1e-9 * max(1.0, rms), col
        assert ep["sigma_n"].notna().mean() > 0.99
        # the position NEES is a χ²(3) when the σ covers the error: its mean is finite
        # and positive; the per-epoch column is what a user plots, not judged here
        assert np.isfinite(ep["nees_pos"]).mean() > 0.99 and ep["nees_pos"].median() > 0


def test_arrays_run_exactly_as_the_files(navego_arrays):
    imu, gnss = navego_arrays
    files = estimator.navigate(NAVEGO, smooth=True, accept_inconsistent=True)
    arrays = estimator.navigate(NAVEGO, imu, gnss, smooth=True, accept_inconsistent=True)
    for name in ["nav", "std", "imu_errors", "smoothed", "smoothed_std"]:
        a, b = getattr(arrays, name).to_numpy(), getattr(files, name).to_numpy()
        assert np.array_equal(a, b), name
    assert arrays.updates.equals(files.updates)


def test_pyins_style_rates_dataframe_runs_without_a_file(navego_arrays, tmp_path):
    """A rate-type IMU DataFrame at 100 Hz and GNSS position + velocity at 1 Hz, the
    configuration a dict without an initial state: nothing is written."""
    imu, _ = navego_arrays
    posvel = read_zst(DATA / "navego" / "GNSS-POSVEL.txt.zst")
    # 200 Hz increments -> 100 Hz increments (pairs summed) -> rates
    n = (len(imu) // 2) * 2
    t = imu[1:n:2, 0]
    inc = imu[0:n:2, 1:7] + imu[1:n:2, 1:7]
    rates = inc / np.diff(np.concatenate([[t[0] - 0.01], t]))[:, None]
    imu_df = pd.DataFrame(rates, columns=["gyro_x", "gyro_y", "gyro_z",
                                          "accel_x", "accel_y", "accel_z"],
                          index=pd.Index(t, name="time"))
    one_hz = posvel[np.isclose(posvel[:, 0] % 1.0, 0.0, atol=1e-6)]
    gnss_df = pd.DataFrame(one_hz, columns=["time", "lat", "lon", "height", "sigma_n",
                                            "sigma_e", "sigma_d", "vn", "ve", "vd",
                                            "sigma_vn", "sigma_ve", "sigma_vd"])
    config = {"data": {"imu_rate": 100.0}, "imu_noise": NOISE}
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        before = set(os.listdir(tmp_path))
        run = estimator.navigate(config, imu_df, gnss_df, smooth=True)
        assert set(os.listdir(tmp_path)) == before, "a file was written"
    finally:
        os.chdir(cwd)
    assert 400 <= len(one_hz) <= 440
    assert len(run.nav) == len(imu_df) - 1
    assert run.summary["gnss_epochs"] > 350
    assert any("position" in s for s in run.updates["stream"])
    horizontal = run.evaluate(TRUTH, skip=60)["overall"]["horizontal"]["rms"]
    smoothed = run.evaluate(TRUTH, skip=60, smoothed=True)["overall"]["horizontal"]["rms"]
    print(f"pyins-style: horizontal RMS {horizontal:.3f} m, smoothed {smoothed:.3f} m")
    assert horizontal < 3.0 and smoothed < horizontal


def test_bad_rows_are_refused_with_the_array_and_row(navego_arrays):
    imu, gnss = navego_arrays
    bad = imu[:5000].copy()
    bad[99, 0] = bad[97, 0]  # row 100 goes back in time
    with pytest.raises(estimator.EstimatorError, match=r"imu array row:100: time goes backwards"):
        estimator.navigate(NAVEGO, bad, gnss)
    bad_gnss = gnss.copy()
    bad_gnss[4, 1] = 132.0  # latitude out of range
    with pytest.raises(estimator.EstimatorError, match=r"gnss array row:5: latitude 132"):
        estimator.navigate(NAVEGO, imu, bad_gnss)
    with pytest.raises(ValueError, match="imu has no columns"):
        estimator.navigate(NAVEGO, imu[:, :0], gnss)


def test_a_column_map_with_arrays_is_refused(navego_arrays):
    imu, gnss = navego_arrays
    config = {"data": {"imu_rate": 200.0, "imu_columns": {"time": "t_ms", "time_unit": "ms"}},
              "imu_noise": NOISE}
    with pytest.raises(estimator.EstimatorError, match="imu_columns"):
        estimator.navigate(config, imu[:1000], gnss[:10])


def test_a_bad_configuration_names_its_key():
    with pytest.raises(estimator.EstimatorError, match="imu_rate"):
        estimator.navigate({"data": {"imu_rate": -5.0, "imu": "a", "gnss": "b"},
                            "imu_noise": NOISE})
    with pytest.raises(estimator.EstimatorError, match="imu_noise"):
        estimator.navigate({"data": {"imu_rate": 100.0, "imu": "a", "gnss": "b"}})
    with pytest.raises(estimator.EstimatorError, match="no_such_file"):
        estimator.navigate(DATA / "no_such_file.toml")
    with pytest.raises(ValueError, match="15 or 21"):
        estimator.navigate(NAVEGO, states=17)
    with pytest.raises(estimator.EstimatorError, match="strategy"):
        estimator.navigate(NAVEGO, strategy="kalman-magic")


def test_an_error_carries_the_programs_message_and_location(cli, navego_arrays, tmp_path):
    imu, gnss = navego_arrays
    lines = [" ".join(f"{v:.12g}" for v in row) for row in imu[:4000]]
    lines[49] = lines[49].replace(" ", " x", 1)  # line 50: a field that is not a number
    (tmp_path / "imu.txt").write_text("\n".join(lines) + "\n")
    (tmp_path / "gnss.txt").write_text(
        "\n".join(" ".join(f"{v:.12g}" for v in row) for row in gnss[:100]) + "\n")
    noise = "\n".join(f"{k} = {v}" for k, v in NOISE.items())
    (tmp_path / "run.toml").write_text(
        f'[data]\nimu = "imu.txt"\ngnss = "gnss.txt"\nimu_rate = 200.0\n\n[imu_noise]\n{noise}\n')
    program = subprocess.run([str(cli), "run", str(tmp_path / "run.toml"), "--quiet",
                              "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert program.returncode != 0
    with pytest.raises(estimator.EstimatorError) as raised:
        estimator.navigate(tmp_path / "run.toml")
    message = str(raised.value)
    assert "imu.txt:50" in message and "not a number" in message, message
    assert message in program.stderr, (message, program.stderr)


def test_a_ros_bag_runs_from_python_as_from_the_program(cli, tmp_path):
    """robot_localization's Husky bag through `[data.ros]`, as shipped (no `[init]`: the
    heading from the start's bank of headings, judged by the wheels): the program exits 3
    (its GNSS innovations flagged) and Python raises the same verdict; accepted, the same
    nav.txt as the program and the recording and the bank named in the start report."""
    shipped = DATA / "ros-husky" / "husky.toml"
    r = subprocess.run([str(cli), "run", str(shipped), "--quiet", "--out", str(tmp_path / "no")],
                       capture_output=True, text=True)
    assert r.returncode == 3 and "cannot be trusted" in r.stderr, r.stderr
    with pytest.raises(ValueError, match="accept_inconsistent=True"):
        estimator.navigate(shipped)
    text = shipped.read_text().replace('recording = "test1.bag"',
                                       f'recording = "{DATA / "ros-husky" / "test1.bag"}"')
    config = tmp_path / "husky.toml"
    config.write_text(text)
    out = tmp_path / "cli"
    subprocess.run([str(cli), "run", str(config), "--quiet", "--accept-inconsistent",
                    "--out", str(out)], check=True)
    py = estimator.navigate(config, accept_inconsistent=True)
    assert_printed(py.nav.to_numpy(), out / "nav.txt", NAV_DECIMALS, "nav.txt", 1)
    assert any("recording" in line and "/imu/data" in line for line in py.summary["start"])
    assert any("from a bank of 16 hypotheses" in line for line in py.summary["start"])


def test_a_tight_run_from_a_ubx_log_runs_from_python_as_from_the_program(cli, tmp_path):
    """Tight coupling from Python: the GPS + BeiDou u-blox log (`data/ubx-sim/bds.ubx.zst`,
    its ephemerides inside, no `[init]`) with an IMU simulated along its drive by the
    program; the same nav.txt as the program's, and each BeiDou satellite a pseudorange
    stream of its own in the summary."""
    subprocess.run([str(cli), "simulate", str(DATA / "ubx-sim" / "drive.toml"), "--out",
                    str(tmp_path)], check=True, capture_output=True)
    text = (tmp_path / "config.toml").read_text()
    text = text.replace('gnss = "GNSS.txt"', f'gnss = "{DATA / "ubx-sim" / "bds.ubx.zst"}"')
    start, end = text.index("\n[init]\n"), text.index("\n[imu]\n")
    text = text[:start] + text[end:]
    text = text.replace("use_velocity = true\n", 'use_velocity = true\ncoupling = "tight"\n', 1)
    config = tmp_path / "tight.toml"
    config.write_text(text)
    out = tmp_path / "cli"
    subprocess.run([str(cli), "run", str(config), "--quiet", "--accept-inconsistent",
                    "--out", str(out)], check=True)
    py = estimator.navigate(config, accept_inconsistent=True)
    assert_printed(py.nav.to_numpy(), out / "nav.txt", NAV_DECIMALS, "nav.txt", 1)
    streams = json.dumps(py.summary)
    for sat in ["C01", "C02", "C03", "C09", "C19", "C24"]:
        assert f"pr {sat}" in streams, sat


def test_the_three_figures_are_drawn(both):
    """``plot``: the track with the truth's, the errors with ±3σ, the NIS per stream
    (matplotlib, a FilterPy dependency, draws off-screen)."""
    import matplotlib

    matplotlib.use("Agg")
    _, py = both
    track, errors, nis = py.plot(TRUTH)
    assert len(track.axes[0].lines) == 2  # estimate and truth
    assert len(errors.axes) == 4 and all(len(a.lines) >= 3 for a in errors.axes)
    assert len(nis.axes[0].lines) >= 1
    # the north error drawn is evaluate()'s
    ep = py.evaluate(TRUTH)["epochs"]
    drawn = errors.axes[0].lines[0].get_ydata()
    assert np.allclose(drawn, ep["north"].to_numpy())


def test_an_rtk_run_runs_from_python_as_from_the_program(cli, tmp_path):
    """RTK in the INS filter from Python (`gnss.coupling = "rtk"`): the program's
    simulated rover and base station (`ins-gnss/scenarios/rtk.toml`, GPS L1 + L2, no
    `[init]`); the same nav.txt as the program's, and the summary's `rtk` dict carries the
    fix metrics the program prints."""
    scenario = (ROOT / "ins-gnss" / "scenarios" / "rtk.toml").read_text()
    scenario = scenario.replace("../../data/", f"{DATA}/")
    spec = tmp_path / "rtk.toml"
    spec.write_text(scenario)
    data = tmp_path / "data"
    subprocess.run([str(cli), "simulate", str(spec), "--out", str(data)], check=True,
                   capture_output=True)
    text = (data / "config.toml").read_text()
    start = text.index("\n[init]\n")
    end = text.index("\n[", start + 1)
    config = data / "noinit.toml"
    config.write_text(text[:start] + text[end:])
    out = tmp_path / "cli"
    printed = subprocess.run([str(cli), "run", str(config), "--out", str(out)], check=True,
                             capture_output=True, text=True).stdout
    py = estimator.navigate(config)
    assert_printed(py.nav.to_numpy(), out / "nav.txt", NAV_DECIMALS, "nav.txt", 1)
    rtk = py.summary["rtk"]
    assert rtk["epochs"] == 600 and rtk["fixed"] >= 0.95 * rtk["epochs"]
    assert 0.0 <= rtk["time_to_first_fix"] <= 40.0 and rtk["gated"] == 0
    line = next(line for line in py.summary["lines"] if line.startswith("RTK: "))
    assert line in printed and f"{rtk['fixed']} fixed" in line
