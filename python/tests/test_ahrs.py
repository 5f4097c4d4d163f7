"""The AHRS from Python: the paper's flight through the bindings gives the library's own
experiment's errors, every variant; the CS-MAEKF beats the conventional filter there."""

import numpy as np
import pytest

import estimator


def errors(run, samples):
    """Max and RMS roll, pitch, yaw errors (deg), as the experiment computes them."""
    e = np.degrees(np.angle(np.exp(1j * (np.radians(run[["roll", "pitch", "yaw"]].to_numpy())
                                         - samples[["roll", "pitch", "yaw"]].to_numpy()))))
    return np.abs(e).max(axis=0), np.sqrt((e**2).mean(axis=0))


@pytest.mark.parametrize("variant,name", [("conventional", "conventional"),
                                          ("modified", "modified"),
                                          ("modified-tuned", "modified, q = 0.1"),
                                          ("cs-maekf", "cs-maekf")])
def test_the_paper_flight_through_python_gives_the_experiments_errors(variant, name):
    flight = estimator.ahrs_flight(seed=3)
    s = flight["samples"]
    cols = lambda p: s[[f"{p}_x", f"{p}_y", f"{p}_z"]].to_numpy()  # noqa: E731
    run = estimator.ahrs(cols("gyro"), cols("accel"), cols("mag"), flight["rate"],
                         flight["att0"], flight["m_n"],
                         g_n=flight["g_n"], variant=variant, time=s["t"])
    mx, rms = errors(run, s)
    ref_max, ref_rms = flight["experiment"][name]
    assert np.allclose(mx, ref_max, rtol=1e-9, atol=1e-9), (mx, ref_max)
    assert np.allclose(rms, ref_rms, rtol=1e-9, atol=1e-9), (rms, ref_rms)
    sig = run[[c for c in run.columns if c.startswith("sigma_")]].to_numpy()
    assert np.isfinite(sig).all() and (sig > 0).all()


def test_cs_maekf_beats_the_conventional_filter_on_the_flight():
    ex = estimator.ahrs_flight(seed=5)["experiment"]
    assert max(ex["cs-maekf"][1]) < max(ex["conventional"][1])


def test_ahrs_refuses_bad_shapes_and_names():
    g = np.zeros((10, 3))
    with pytest.raises(ValueError, match="N × 3"):
        estimator.ahrs(g, np.zeros((9, 3)), g, 100.0, [0, 0, 0], [1, 0, 0])
    with pytest.raises(ValueError, match="variant"):
        estimator.ahrs(g, g, g, 100.0, [0, 0, 0], [1, 0, 0], variant="kalman")
