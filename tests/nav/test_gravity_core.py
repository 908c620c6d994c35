"""Gravity disturbance, FIR and internal coincidence: analytic identities and the paper's tables."""

import numpy as np
import pytest
from scipy.signal import filtfilt

from ldvsurvey.nav.coincidence import along_track, common_points, crossovers, internal_coincidence, total_from_lines
from ldvsurvey.nav.earth import MGAL, OMEGA_IE, normal_gravity, radii
from ldvsurvey.nav.gravity import Lowpass, disturbance_mps2


def test_paper_tables_2_and_3_add_up():
    assert round(total_from_lines([0.73, 0.47, 0.66, 1.05, 0.53, 0.59]), 2) == 0.70  # SINS/LDV, Tab. 2
    assert round(total_from_lines([1.03, 1.30, 1.75, 1.02, 2.46, 1.05]), 2) == 1.53  # SINS/GNSS, Tab. 3


def test_total_is_the_mean_of_the_per_line_squares():
    rng = np.random.default_rng(0)
    g = rng.normal(0, 1, (6, 500)) + np.linspace(0, 30, 500)
    c = internal_coincidence(g)
    assert c.total == pytest.approx(total_from_lines(c.per_line_rms), rel=1e-12)
    # galileoQC's checkRepeatLines: std about the mean with ddof 0 = ours · sqrt((n−1)/n)
    n = g.shape[0]
    galileo = np.sqrt(np.mean((g - g.mean(axis=0)) ** 2, axis=1))
    np.testing.assert_allclose(c.per_line_rms, galileo * np.sqrt(n / (n - 1)))


def test_identical_lines_and_known_offsets():
    base = np.sin(np.linspace(0, 6, 300)) * 10
    assert internal_coincidence(np.tile(base, (4, 1))).total == 0.0
    offs = np.array([0.3, -0.1, 0.5, -0.7])
    c = internal_coincidence(base + offs[:, None])
    dev = offs - offs.mean()
    np.testing.assert_allclose(c.per_line_rms, np.abs(dev) * np.sqrt(4 / 3))
    assert c.total == pytest.approx(np.std(offs, ddof=1))
    np.testing.assert_allclose(c.per_line_max, dev)
    np.testing.assert_allclose(c.per_line_min, dev)


def test_common_points_reverse_and_trim():
    s = np.linspace(0, 1000, 101)
    fwd = (s, 2 * s)
    back = (s[::-1] + 5.0, 2 * (s[::-1] + 5.0))  # driven the other way, starts 5 m further
    grid, vals = common_points([fwd, back], 10.0)
    assert grid[0] == 5.0 and grid[-1] <= 1000.0
    np.testing.assert_allclose(vals[0], vals[1])


def test_along_track_projection():
    e = np.linspace(0, 1000, 11)
    n = np.zeros(11)
    s, lat = along_track(e, n, np.array([250.0, 730.0]), np.array([3.0, -4.0]))
    np.testing.assert_allclose(s, [250.0, 730.0])
    np.testing.assert_allclose(lat, [3.0, 4.0])


def test_crossover_accuracy():
    x = np.linspace(-500, 500, 21)
    tracks = [(x, 0 * x, np.full(21, 1.0)), (0 * x + 10, x, np.full(21, 1.6))]
    found, eps = crossovers(tracks)
    assert len(found) == 1 and found[0][4] == pytest.approx(-0.6)
    assert eps == pytest.approx(np.sqrt(0.36 / 2))


def test_zero_phase_fir_equals_filtfilt_inside():
    rng = np.random.default_rng(1)
    fs, L = 10.0, 30.0
    x = rng.normal(0, 1, 5000).cumsum()
    h = Lowpass(L, fs).taps
    ref = filtfilt(h, [1.0], x)
    ours = Lowpass(L, fs).apply(x)
    k = slice(len(h) * 2, -len(h) * 2)
    np.testing.assert_allclose(ours[k], ref[k], rtol=1e-9, atol=1e-9)
    # gaps are bridged and the result stays where the data support it
    x2 = x.copy()
    x2[2000:2010] = np.nan
    y2 = Lowpass(L, fs).apply(x2)
    assert np.all(np.isfinite(y2[2000:2010]))
    assert np.abs(y2[1500:2500] - ours[1500:2500]).max() < 0.05 * np.std(x)


def test_disturbance_at_rest_is_minus_gravity_residual():
    lat, h = np.radians(30.0), 200.0
    gam = normal_gravity(lat, h)
    # at rest the accelerometer reads γ + Δg upwards
    assert disturbance_mps2(gam + 10 * MGAL, 0.0, 0.0, 0.0, lat, h) / MGAL == pytest.approx(10.0, abs=1e-9)


def test_eotvos_sign_eastward_motion():
    """Moving east, the centripetal terms lower the specific force needed: δg adds (v_E/(R_N+h)+2Ω cos L) v_E."""
    lat, h, ve = np.radians(45.0), 0.0, 20.0
    rm, rn = radii(lat)
    eot = (ve / (rn + h) + 2 * OMEGA_IE * np.cos(lat)) * ve
    gam = normal_gravity(lat, h)
    assert disturbance_mps2(gam - eot, 0.0, ve, 0.0, lat, h) == pytest.approx(0.0, abs=1e-12)


# --- f_U from the mechanization step, gaps, the noise floor -------------------------------------

from ldvsurvey.nav.gravity import bridge_velocity, noise_floor_mgal  # noqa: E402


def test_velocity_gaps_cost_only_their_own_samples():
    """A drop-out bridged through a reference telescopes; NaN-ing it (the former chain) leaks."""
    rng = np.random.default_rng(3)
    fs, L = 100.0, 150.0
    t = np.arange(0, 2000, 1 / fs)
    dg_true = 1e-4 * np.sin(2 * np.pi * t / 600)  # 10 mGal
    a_vehicle = 0.3 * np.sin(2 * np.pi * t / 37) + 0.2 * np.sin(2 * np.pi * t / 11)
    v_true = np.cumsum(a_vehicle) / fs
    v_meas = v_true + rng.normal(0, 0.01, len(t))
    v_ref = v_true + 0.02 + 0.01 * np.sin(t / 50)  # a navigation velocity: smooth, slowly off
    f_minus_g = a_vehicle + dg_true  # what the accelerometer adds beyond normal gravity
    ok = np.ones(len(t), bool)
    for a in rng.integers(20000, 180000, 40):  # 40 drop-outs of 0.2-3 s
        ok[a : a + rng.integers(20, 300)] = False
    v_meas_bad = np.where(ok, v_meas, rng.normal(0, 5, len(t)))  # garbage values inside

    def gravity(v):
        return Lowpass(L, fs).apply(f_minus_g[1:] - np.diff(v) * fs)

    clean = gravity(v_meas)
    bridged = gravity(bridge_velocity(v_meas_bad, ok, v_ref, edge_n=50))
    nan_way = gravity(np.where(ok, v_meas, np.nan))
    k = slice(int(2 * L * fs), -int(2 * L * fs))
    truth = Lowpass(L, fs).apply(dg_true[1:])
    rms = lambda x: np.sqrt(np.mean((x[k] - truth[k]) ** 2)) / MGAL  # noqa: E731
    assert rms(bridged) < 1.3 * rms(clean) + 0.02
    assert rms(nan_way) > 5 * rms(bridged)


def test_bridge_ties_both_edges_and_keeps_data():
    v = np.arange(10.0)
    ok = np.ones(10, bool)
    ok[4:7] = False
    ref = np.full(10, 100.0)
    out = bridge_velocity(v, ok, ref)
    np.testing.assert_array_equal(out[ok], v[ok])
    np.testing.assert_allclose(out[3:8], [3, 4, 5, 6, 7])  # offsets −97 … −93 interpolated
    with pytest.raises(ValueError):
        bridge_velocity(v, np.zeros(10, bool), ref)


@pytest.mark.parametrize("length_s", [60.0, 200.0])
def test_noise_floor_matches_monte_carlo(length_s):
    """σ of white sensor noise after the zero-phase FIR, against simulated noise through the same FIR."""
    rng = np.random.default_rng(7)
    lp = Lowpass(length_s)
    floor = noise_floor_mgal(
        lp, accel_noise_ug_rthz=5.0, ldv_noise_mps=0.01, ldv_rate_hz=20.0, height_noise_m=0.02, gnss_rate_hz=1.0
    )
    n_s = 400_000
    fs = 10.0  # accelerometer: per-sample σ = N·√fs (the simulator's and the filter's convention)
    acc = rng.normal(0, 5e-6 * 9.80665 * np.sqrt(fs), n_s)
    v = rng.normal(0, 0.01, n_s)  # LDV at 20 Hz, differenced once
    h = rng.normal(0, 0.02, n_s // 10)  # GNSS heights at 1 Hz, differenced twice
    k = slice(int(3 * length_s * fs), -int(3 * length_s * fs))
    got_acc = np.std(Lowpass(length_s, fs).apply(acc)[k]) / MGAL
    got_ldv = np.std(Lowpass(length_s, 20.0).apply(np.diff(v) * 20.0)[k]) / MGAL
    kg = slice(int(3 * length_s), -int(3 * length_s))
    got_h = np.std(Lowpass(length_s, 1.0).apply(np.diff(h, 2))[kg]) / MGAL
    assert got_acc == pytest.approx(floor["accel_mgal"], rel=0.08)
    assert got_ldv == pytest.approx(floor["ldv_mgal"], rel=0.08)
    assert got_h == pytest.approx(floor["gnss_height_mgal"], rel=0.15)
    assert floor["total_mgal"] == pytest.approx(
        np.sqrt(floor["accel_mgal"] ** 2 + floor["ldv_mgal"] ** 2 + floor["gnss_height_mgal"] ** 2)
    )


def test_noise_floor_of_the_issue_example():
    """5 µg/√Hz through a 200-s Blackman FIR: 'roughly 0.3 mGal'; shorter filters pass more noise."""
    f60, f200, f300 = (noise_floor_mgal(Lowpass(length_s), 5.0)["accel_mgal"] for length_s in (60.0, 200.0, 300.0))
    assert 0.3 <= f200 <= 0.45
    assert f60 > f200 > f300


def test_crossovers_ignore_repeated_passes_over_one_road():
    x = np.linspace(0, 2000, 401)
    weave1 = (x, 2.0 * np.sin(x / 150.0), np.zeros(401))  # two passes a few metres apart, weaving
    weave2 = (x, 2.0 * np.sin(x / 170.0 + 1.0), np.ones(401))
    found, eps = crossovers([weave1, weave2], min_angle_deg=20.0)
    assert found == [] and eps is None
    assert len(crossovers([weave1, weave2])[0]) >= 2  # without the angle test: spurious "crossings"
    cross = (np.full(21, 1000.0), np.linspace(-100, 100, 21), np.full(21, 0.4))
    found, eps = crossovers([weave1, cross], min_angle_deg=20.0)
    assert len(found) == 1 and found[0][4] == pytest.approx(-0.4)


def test_per_line_mean_and_std_about_the_mean_line():
    base = np.linspace(0, 5, 200)
    offs = np.array([0.2, -0.2, 0.0])
    wig = np.array([np.zeros(200), np.zeros(200), 0.1 * np.sin(np.arange(200))])
    c = internal_coincidence(base + offs[:, None] + wig)
    dev = c.residual
    np.testing.assert_allclose(c.per_line_mean, dev.mean(axis=1))
    np.testing.assert_allclose(c.per_line_mean, offs - offs.mean() + wig.mean(axis=1) - wig.mean(), atol=1e-12)
    np.testing.assert_allclose(c.per_line_std, dev.std(axis=1))
    assert c.per_line_std[2] == pytest.approx(np.std(wig[2] - wig.mean(axis=0)))


def test_second_difference_noise_gain_matches_monte_carlo():
    """The σ a break leaves in the filtered second difference of white noise, against the same
    noise through the same NaN-aware FIR (300 realisations): 1 in the interior, hundreds at a break."""
    from ldvsurvey.nav.gravity import Lowpass, second_difference_noise_gain

    rng = np.random.default_rng(1)
    n, length_s = 1800, 100.0
    valid = np.ones(n, bool)
    valid[700:900] = False
    out = []
    for _ in range(300):
        e = rng.normal(0.0, 1.0, n + 2)
        out.append(Lowpass(length_s, 1.0).apply(np.where(valid, e[2:] - 2 * e[1:-1] + e[:-2], np.nan)))
    emp = np.sqrt(np.mean(np.square(out), axis=0))
    gain = second_difference_noise_gain(valid, Lowpass(length_s, 1.0))
    inner = np.median(emp[200:500])
    for i in (300, 650, 690, 910, 950, 1000, 1300):
        assert gain[i] == pytest.approx(emp[i] / inner, rel=0.2)
    assert gain[910] > 100 and gain[300] == pytest.approx(1.0, abs=0.01)


def test_lowpass_response_and_noise_gain_against_scipy():
    """The filter value's response is that of its taps (scipy's freqz, squared for forward and back) and
    its noise gain the variance of filtered unit-density white noise (simulated, 3 %)."""
    from scipy.signal import freqz

    from ldvsurvey.nav.gravity import Lowpass

    lp = Lowpass(120.0).at(2.0)
    f = np.array([0.0, 0.002, 1.0 / 120.0, 0.012, 0.02])
    _, h = freqz(lp.taps, worN=f, fs=2.0)
    np.testing.assert_allclose(lp.response(f), np.abs(h) ** 2, atol=1e-9)
    assert lp.at(2.0) is lp and lp.at(4.0).length_s == 120.0
    x = np.random.default_rng(2).normal(0.0, np.sqrt(2.0), 400_000)  # density 1 /√Hz at 2 Hz
    assert np.var(lp.apply(x)[2000:-2000]) == pytest.approx(lp.noise_gain, rel=0.03)
    with pytest.raises(ValueError, match="not bound"):
        Lowpass(120.0).apply(x)


class _Boxcar(Lowpass):
    """Another design: a moving average over the same 2·L·f_s (+1, odd) taps."""

    def _taps_at(self, fs_hz):
        n = int(round(2 * self.length_s * fs_hz))
        n += 1 - n % 2
        return np.full(n, 1.0 / n)


def test_a_subclass_design_reaches_taps_response_and_noise_floors():
    """Overriding the one design method changes taps, kernel, response, noise gain, f½ and the noise floor
    together, against independent truth: the boxcar's n taps of 1/n, scipy's freqz of them, Parseval on
    its triangular kernel (Σ(h⋆h)² = (2n²+1)/(3n³)) and a sinc's half-amplitude point (T = 2L)."""
    from scipy.optimize import brentq
    from scipy.signal import freqz

    from ldvsurvey.units import G0_MPS2

    length_s, fs = 120.0, 2.0
    box, blackman = _Boxcar(length_s), Lowpass(length_s)
    lp = box.at(fs)
    assert type(lp) is _Boxcar and lp.rate_hz == fs and lp.at(fs) is lp
    n = 481  # 2·120 s·2 Hz + 1
    np.testing.assert_array_equal(lp.taps, np.full(n, 1.0 / n))
    # the applied kernel is the triangle h ⋆ h: an impulse comes out as it
    x = np.zeros(4001)
    x[2000] = 1.0
    tri = (n - np.abs(np.arange(-(n - 1), n))) / n**2
    np.testing.assert_allclose(lp.apply(x)[2000 - (n - 1) : 2000 + n], tri, atol=1e-15)
    # response: bound, of its taps; unbound, of the taps at 50 samples per length (101 taps at 50/120 Hz)
    f = np.array([0.0, 0.001, 1.0 / 240.0, 0.006, 0.02])
    _, h = freqz(np.full(n, 1.0 / n), worN=f, fs=fs)
    np.testing.assert_allclose(lp.response(f), np.abs(h) ** 2, atol=1e-12)
    _, h = freqz(np.full(101, 1.0 / 101), worN=f, fs=50.0 / length_s)
    np.testing.assert_allclose(box.response(f), np.abs(h) ** 2, atol=1e-12)
    assert abs(box.response(0.006)[0] - blackman.response(0.006)[0]) > 0.01
    # noise gain = ∫|H|⁴df = f_s Σ(h⋆h)² (Parseval) of the taps at the design rate (within the fine grid's
    # one bin at 0 Hz, 0.2 %), and near the continuous boxcar's 2/(3T) = 1/(3L)
    m, rate = 101, 50.0 / length_s
    assert box.noise_gain == pytest.approx(rate * (2 * m**2 + 1) / (3 * m**3), rel=3e-3)
    assert box.noise_gain == pytest.approx(1.0 / (3.0 * length_s), rel=1e-2)
    assert box.noise_gain < 0.8 * blackman.noise_gain
    # half amplitude after both passes: the m-tap moving average's Dirichlet kernel squared = 1/2
    dirichlet = lambda f: np.sin(np.pi * f * m / rate) / (m * np.sin(np.pi * f / rate))  # noqa: E731
    f_half = brentq(lambda f: dirichlet(f) ** 2 - 0.5, 1e-4, 1.0 / length_s)
    assert box.half_amplitude_hz == pytest.approx(f_half, rel=1e-3)
    assert box.half_wavelength_m(10.0) == pytest.approx(10.0 / (2 * f_half), rel=1e-3)
    # the noise floor goes through the same noise gain
    acc = noise_floor_mgal(box, 5.0)["accel_mgal"]
    assert acc == pytest.approx(5.0 * 1e-6 * G0_MPS2 * np.sqrt(box.noise_gain) / MGAL, rel=1e-12)
    assert acc < 0.9 * noise_floor_mgal(blackman, 5.0)["accel_mgal"]
    # one den_cache for both designs: each gets its own filtered mask (they differ at the ends)
    y = np.random.default_rng(4).normal(0.0, 1.0, 3000)
    cache = {}
    lb = blackman.at(fs)
    np.testing.assert_array_equal(lb.apply(y, den_cache=cache), lb.apply(y))
    np.testing.assert_array_equal(lp.apply(y, den_cache=cache), lp.apply(y))


def test_noise_floor_refuses_a_length_for_the_filter():
    with pytest.raises(TypeError, match="Lowpass"):
        noise_floor_mgal(200.0, 5.0)
