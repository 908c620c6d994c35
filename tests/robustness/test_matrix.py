"""Robustness matrix (issue 13 §3): the rotating-IMU, 1-D LDV drive with no effect, each simulator
effect alone, and every effect together, through tilt, calibrate, height, navigate and dov.

Every figure is compared with the simulator's truth (``tests/robustness/matrix.py``: effective
tilt and travel direction from ``sim/truth.py``, the true trajectory, the point-mass field)
and bounded by a physical floor derived from the sensor specifications (see that module), never
by a number read off the output. No pipeline may fail with anything but a typed refusal that
names its field, and a degraded input must leave a warning in summary.json.

Scenario: 2 min static, ~1.2 km out and back (6 min in all), seed 5; ~10 s per configuration.
"""

import functools

import pytest

from ldvsurvey.errors import ParameterError
from tests.robustness.matrix import CONFIGS, HEIGHT_PIPELINES, figures, run_height_case

K = 3.0  #: floors are 1-σ: a figure beyond 3 floors is a failure, not bad luck


@functools.lru_cache(maxsize=1)
def _case(config):
    return run_height_case(config)


def _refusals(config):
    """Typed refusals the methods need: free-inertial DOV mechanizations start from a static
    alignment, so a log that starts on the move is refused naming ``initial.static_s``."""
    return {"dov": "initial.static_s"} if config in ("moving_start",) else {}


@pytest.mark.parametrize("config", CONFIGS)
def test_matrix(config):
    case = _case(config)
    sim = case["sim"]
    refused = _refusals(config)
    for name in HEIGHT_PIPELINES:
        r = case[name]
        if name in refused:
            assert isinstance(r, ParameterError) and r.field == refused[name], (name, r)
            continue
        assert not isinstance(r, Exception), f"{name} failed on '{config}': {r!r}"
        warned = r.summary["warnings"]  # what summary.json carries (the log's and the pipeline's)
        assert all(w in warned for w in r.warnings)
        # degraded inputs are said so in summary.json
        if "imu_keep" in sim.extras and not sim.extras["imu_keep"].all():
            assert any("imu.csv" in w and "gap" in w for w in warned), (name, warned)
        if sim.scenario.static_s == 0 and name in ("tilt", "height", "navigate", "calibrate"):
            assert any("no static period" in w for w in warned), (name, warned)
    f = figures(case)

    t = f["tilt"]
    if sim.scenario.static_s > 0:  # a still dwell: the tilt is observable to the acceptance
        assert t["observable"]
        assert abs(t["alpha_err_rad"]) <= t["bound_rad"] and abs(t["beta_err_rad"]) <= t["bound_rad"], t
    if t["observable"]:  # its 1-σ covers the error (2e-6 rad: the residual of the sensor's own model)
        assert abs(t["alpha_err_rad"]) <= K * t["alpha_sigma_rad"] + 2e-6, t
        assert abs(t["beta_err_rad"]) <= K * t["beta_sigma_rad"] + 2e-6, t

    c = f["calibrate"]
    for q, floor in (("pitch", "pitch_floor_rad"), ("heading", "heading_floor_rad"), ("scale", "scale_floor")):
        err = c[f"{q}_err" + ("_rad" if q != "scale" else "")]
        assert abs(err) <= K * c[floor], (q, c)

    h = f["height"]
    assert h["max_m"] <= K * h["floor_m"], h
    n = f["navigate"]
    assert n["max_horizontal_m"] <= K * n["floor_m"], n
    if sim.scenario.effects.gravity_field is not None:  # the user's grid reaches the mechanization
        assert case["height"].summary["dov"]["dg_used"]
        d = f["dov"]
        assert d["xi_max_err_arcsec"] <= d["floor_arcsec"] and d["eta_max_err_arcsec"] <= d["floor_arcsec"], d
        assert d["dov_max_arcsec"] >= 5.0  # the field is there to be missed
