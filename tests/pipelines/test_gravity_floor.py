"""The drift term of the coincidence floor against closed forms of a first-order Gauss–Markov bias.

Two short repeated lines far apart in time, no stop tie: each line sees the bias of its own time
(lines short against τ, FIR passing the drift), the per-line coincidence of two lines is
|b₁ − b₂|/√2 at every point, so E[ε²] = σ²(1 − e^(−Δt/τ)) — independent of the pipeline's code.
With line leveling each line's mean is removed and only the drift within a line remains.
"""

from types import SimpleNamespace

import numpy as np

from ldvsurvey.nav.earth import MGAL
from ldvsurvey.nav.gravity import Lowpass
from ldvsurvey.pipelines.gravity.floor import combine, drift_floor
from ldvsurvey.pipelines.gravity.report import Evaluation, LineResult

G0 = 9.80665


def _setup(sigma_ug, tau_s, gap_s, line_s=120.0, speed=10.0):
    t = np.arange(0.0, 2 * line_s + gap_s + 1.0, 0.1)
    lines = [(0.0, line_s), (line_s + gap_s, 2 * line_s + gap_s)]
    per_line = []
    for i, (a, b) in enumerate(lines):
        k = (t >= a) & (t <= b)
        s = speed * (t[k] - a) if i == 0 else speed * (b - t[k])  # the second pass runs back
        empty = np.zeros(0)
        per_line.append(LineResult(f"L{i + 1}", 0, k, s, empty, empty, empty, 0.0, 0.0, 0.0, b - a, b - a))
    imu = SimpleNamespace(accel_bias_instability_ug=sigma_ug, bias_correlation_s=tau_s, accel_noise_ug_per_rthz=0.0)
    log = SimpleNamespace(manifest=SimpleNamespace(imu=imu))
    chain = {"t_s": t, "still": []}
    return log, chain, Evaluation([], [], per_line)


def test_two_lines_match_the_gauss_markov_correlation():
    sigma_ug, tau = 5.0, 2000.0
    for gap in (200.0, 2000.0, 20000.0):
        log, chain, res = _setup(sigma_ug, tau, gap)
        out = drift_floor(log, chain, res, Lowpass(20.0), spacing_m=10.0, tie_applied=False, n_real=400, seed=1)
        lag = gap + 120.0  # the lines' centres
        expect = sigma_ug * 1e-6 * G0 / MGAL * np.sqrt(1 - np.exp(-lag / tau))
        # lines of 120 s against τ = 2000 s: a few % of within-line wander; 400 realisations: ~4 %
        assert abs(out["drift_mgal"] / expect - 1) < 0.12, (gap, out["drift_mgal"], expect)


def test_leveling_leaves_only_the_drift_within_a_line():
    log, chain, res = _setup(5.0, 2000.0, 20000.0)
    raw = drift_floor(log, chain, res, Lowpass(20.0), 10.0, tie_applied=False, leveling="none", n_real=200)
    lev = drift_floor(log, chain, res, Lowpass(20.0), 10.0, tie_applied=False, leveling="bias", n_real=200)
    raw, lev = raw["drift_mgal"], lev["drift_mgal"]
    assert lev < 0.2 * raw


def test_no_instability_in_the_manifest_gives_no_drift_term():
    log, chain, res = _setup(None, None, 200.0)
    out = combine({"total_mgal": 0.4}, drift_floor(log, chain, res, Lowpass(20.0), 10.0, tie_applied=False))
    assert out["drift_mgal"] is None and out["combined_mgal"] == 0.4
    log, chain, res = _setup(5.0, 2000.0, 200.0)
    out = combine({"total_mgal": 0.3}, {"drift_mgal": 0.4})
    assert abs(out["combined_mgal"] - 0.5) < 1e-12


def test_linear_leveling_removes_the_lines_differing_drift_and_keeps_what_they_share():
    from ldvsurvey.pipelines.gravity.report import leveling_fit

    rng = np.random.default_rng(4)
    s = np.arange(0.0, 11000.0, 10.0)
    signal = 20 * np.sin(s / 1500.0) + 0.002 * s  # Δg with a regional trend all lines share
    a, b = rng.normal(0, 3, 5), rng.normal(0, 2e-4, 5)  # per-line drift: offset + slope (mGal, mGal/m)
    vals = signal + a[:, None] + b[:, None] * s
    adj = vals - leveling_fit(vals, s, "linear")
    shared = a.mean() + b.mean() * s  # the drift common to all lines stays (datum defect of the adjustment)
    assert np.max(np.abs(adj - (signal + shared))) < 1e-9
    bias_only = vals - leveling_fit(vals, s, "bias")
    assert np.max(np.abs(bias_only - (signal + shared))) > 0.5  # a bias cannot take out the slopes
