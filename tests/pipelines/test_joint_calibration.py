"""``navigate`` with ``aiding=ldv+gnss`` estimates the automatic LDV calibration together with the
navigation: one filter and smoother with the LDV states augmented, instead of a calibration run
followed by a second navigation with the estimate held fixed.

Truth: the simulator's trajectory, attitude and LDV mounting and scale. Beside it the two-run
method (the same pipeline with the joint path switched off) on the same log: the joint solution
must be as accurate, and its calibration must agree with the ``calibrate`` pipeline's, whose
1-σ speak for the same fixes (RTK fixed, float, differential: not the single-point ones the
navigation also takes).
"""

from types import SimpleNamespace

import numpy as np
import pytest

from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.nav import kfloop
from ldvsurvey.nav.attitude import euler_from_c_bn
from ldvsurvey.nav.earth import radii
from ldvsurvey.pipelines import navigate as NV
from ldvsurvey.pipelines.base import Progress, run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.pipelines.stages import ldv_mounting as CAL
from ldvsurvey.pipelines.stages.aids import NAV_FIXES
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate

ARCSEC = np.pi / 180 / 3600
PARAMS = {"aiding": "ldv+gnss", "output_rate_hz": 10.0}


@pytest.fixture(scope="module")
def drive():
    """12 min (2 min still, ~9 km at 15 m/s with turns and grades); GNSS lost for 2 min, then
    single-point fixes, then differential, else RTK fixed."""
    sc = catalog.drive(
        minutes=12.0, static_s=120.0, fix_schedule=[(300.0, 420.0, 0), (450.0, 550.0, 1), (600.0, 650.0, 2)]
    )
    sim = simulate(sc, seed=21)
    return sim, parse_files(bundle_files(sim))


def _count_forward(monkeypatch):
    calls = []
    real = kfloop.forward

    def counted(*a):
        calls.append(len(a[1].p0))  # the state count of each run
        return real(*a)

    monkeypatch.setattr(kfloop, "forward", counted)
    return calls


def _errors(sim, r) -> dict:
    """Horizontal and height error (m) and heading error (arcsec) of the trajectory against truth."""
    tb = r.tables["trajectory"]
    t = tb["t_s"]
    lat = np.interp(t, sim.imu.t_s, sim.imu.lat_rad)
    lon = np.interp(t, sim.imu.t_s, sim.imu.lon_rad)
    rm, rn = radii(lat)
    hor = np.hypot((np.radians(tb["lon_deg"]) - lon) * rn * np.cos(lat), (np.radians(tb["lat_deg"]) - lat) * rm)
    dh = tb["h_m"] - np.interp(t, sim.imu.t_s, sim.imu.h_m)
    k = np.clip(np.searchsorted(sim.imu.t_s, t), 0, len(sim.imu.t_s) - 1)
    _, _, hd = euler_from_c_bn(sim.imu.c_bn[k])
    dpsi = (np.degrees(hd) - tb["heading_deg"] + 180.0) % 360.0 - 180.0
    return {
        "hor_rms_m": float(np.sqrt(np.mean(hor**2))),
        "hor_max_m": float(hor.max()),
        "h_rms_m": float(np.sqrt(np.mean(dh**2))),
        "heading_rms_arcsec": float(np.sqrt(np.mean(dpsi**2)) * 3600.0),
    }


@pytest.fixture(scope="module")
def runs(drive):
    sim, log = drive
    joint = run_pipeline(get("navigate"), [log], PARAMS)
    mp = pytest.MonkeyPatch()
    real = NV.ldv_setup
    mp.setattr(NV, "ldv_setup", lambda inp, params, progress, joint=False, **kw: real(inp, params, progress, **kw))
    try:
        two = run_pipeline(get("navigate"), [log], PARAMS)
    finally:
        mp.undo()
    cal = run_pipeline(get("calibrate"), [log], {})
    return joint, two, cal


def test_ldv_gnss_navigation_runs_one_filter(drive, monkeypatch):
    _, log = drive
    calls = _count_forward(monkeypatch)
    run_pipeline(get("navigate"), [log], {"aiding": "gnss"})
    n_nav = calls.pop()  # the navigation's own states
    r = run_pipeline(get("navigate"), [log], PARAMS)
    assert len(calls) == 1 and calls[0] > n_nav  # the LDV states ride along in the one run
    assert r.summary["calibration"]["estimated_with_navigation"] is True
    # where the joint run does not apply, the calibration still runs first and alone
    t0 = float(log.gnss.t_s[0])
    for params in (
        {"aiding": "ldv"},  # the LDV-only navigation must not see GNSS
        {**PARAMS, "smooth": False},
        {**PARAMS, "calibration_window": [t0 + 130.0, t0 + 290.0]},
        {**PARAMS, "ldv_pitch_k_rad_per_mps2": 0.0},  # a given value is held fixed
    ):
        calls.clear()
        r = run_pipeline(get("navigate"), [log], params)
        assert len(calls) == 2, params
        assert calls[1] == n_nav < calls[0]
        assert "estimated_with_navigation" not in r.summary["calibration"]


def test_joint_navigation_as_accurate_as_two_runs(drive, runs):
    sim, _ = drive
    joint, two, _ = runs
    ej, e2 = _errors(sim, joint), _errors(sim, two)
    for key in ej:  # no loss of accuracy: within 10 % (+ 5 mm, 0.5″ of noise) of the two-run method
        slack = 0.5 if key.endswith("arcsec") else 0.005
        assert ej[key] <= 1.1 * e2[key] + slack, (key, ej, e2)
    # and against truth: RTK fixes (3 cm) bracket the 2-min outage, the LDV bridges it
    assert ej["hor_rms_m"] < 0.1 and ej["h_rms_m"] < 0.1, ej


def test_joint_calibration_against_truth_and_calibrate(drive, runs):
    sim, _ = drive
    joint, _, cal = runs
    cj = joint.summary["calibration"]
    cc = cal.summary
    ldv = sim.scenario.ldv
    truth = {"ldv_pitch_deg": np.degrees(ldv.pitch_rad), "ldv_heading_deg": np.degrees(ldv.heading_rad)}
    for key, true in truth.items():
        s = cj["sigma"][key]
        assert abs(cj[key] - true) < 3.0 * s, (key, cj[key], true, s)
    assert abs(cj["ldv_scale"] - ldv.scale) < 3.0 * cj["sigma"]["ldv_scale"]
    # the calibrate pipeline's own estimate, from its own run without the single-point fixes: the
    # same to within 2σ (seen: pitch 1.0σ apart, heading and scale 0.02σ)
    for key in ("ldv_pitch_deg", "ldv_heading_deg", "ldv_scale"):
        assert abs(cj[key] - cc[key]) < 2.0 * cj["sigma"][key], (key, cj[key], cc[key])
        ratio = cj["sigma"][key] / cc[key + "_sigma"]
        assert 0.8 < ratio < 1.25, (key, ratio)
    # the σ inflation counted only the calibration's own fix qualities
    n_good = np.count_nonzero(np.isin(joint_log_fixes(drive), CAL.CAL_FIXES))
    n_used = cj["sigma_inflation"]["gnss_innovations"]["e"]["n"]
    assert n_used <= n_good < n_used + 0.02 * n_good + 5


def _navigation(log, given: dict, **kw):
    """``run_navigation`` as the navigate pipeline calls it, with its parameters from ``given``."""
    params = NV.NavigateParams(**given)
    return NV.run_navigation(log, params, Progress(), aiding=params.aiding, smooth=params.smooth, dov=params, **kw)


def joint_log_fixes(drive):
    _, log = drive
    return log.gnss.fix[np.isfinite(log.gnss.lat_deg)]


def test_epochs_fixed_by():
    ep = np.array([0.0, 1.0, 2.0, 3.0])
    g = SimpleNamespace(
        t_s=np.array([0.5, 1.0, 1.7, 1.9, 2.2, 2.9, 3.5]),
        fix=np.array([4, 1, 4, 0, 1, 2, 4]),
        lat_deg=np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]),
    )
    # epoch 1 takes 0.5 (4) then 1.0 (1): the last; epoch 2 takes 1.7 (4), the fix-0 one is not aided;
    # epoch 3 ends with 2.9 (2); 3.5 is after the last epoch
    assert CAL._epochs_fixed_by(ep, g, CAL.CAL_FIXES).tolist() == [False, False, True, True]
    g.lat_deg[2] = np.nan  # a fix without a position is no update
    assert CAL._epochs_fixed_by(ep, g, CAL.CAL_FIXES).tolist() == [False, False, False, True]


def test_epochs_fixed_by_matches_the_filter(drive):
    """The epochs the compiled filter updated with GNSS (a normalized innovation, taken or gated)
    are exactly those the mapping gives for the fixes the navigation takes."""
    _, log = drive
    _, _, sol = _navigation(log, PARAMS)
    took = np.isfinite(sol.normalized_innovations[:, 6])
    assert took.sum() > 500
    assert np.array_equal(CAL._epochs_fixed_by(sol.epoch_t_s, log.gnss, NAV_FIXES), took)
    good = CAL._epochs_fixed_by(sol.epoch_t_s, log.gnss, CAL.CAL_FIXES)
    assert (good <= took).all() and 0 < good.sum() < took.sum()


@pytest.mark.parametrize("aiding", ["ldv+gnss", "ldv"])
def test_navigation_without_specific_force_is_the_same(drive, aiding):
    """navigate keeps no per-sample specific force (only gravity reads it): the same solution, bit
    for bit, as with it."""
    _, log = drive
    params = {**PARAMS, "aiding": aiding}
    _, _, with_f = _navigation(log, params)
    _, _, without = _navigation(log, params, specific_force=False)
    assert len(with_f.f_u_mps2) == len(with_f.t_s) and len(without.f_u_mps2) == 0 == len(without.f_u_bias_mps2)
    for name in ("q_sn", "v_n", "pos", "epoch_sigma"):
        assert np.array_equal(getattr(with_f, name), getattr(without, name)), name
    assert with_f.ldv_params == without.ldv_params
