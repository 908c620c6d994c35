"""The chains' block-wise per-sample work equals the whole-log formulas bit for bit.

The reference here is the previous implementation (every sample's C_s^n and C_b^n formed at once,
einsum products, cumulative sums over the whole log); the block size is made tiny and odd so that
every block boundary case (first block, a last block of one sample, the interval that joins two
blocks) is exercised many times.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import ldvsurvey.pipelines.gravity.chains as gc
from ldvsurvey.nav.attitude import c_bs, c_from_q
from ldvsurvey.nav.earth import OMEGA_IE, normal_gravity, radii
from ldvsurvey.nav.gravity import bridge_velocity
from ldvsurvey.pipelines.stages.ldv_mounting import ldv_body_velocity


def fake_run(n=1001, rotating=False, seed=3):
    """(inp, sol, setup) with random but smooth attitude, velocity, position and LDV speeds."""
    rng = np.random.default_rng(seed)
    t = 100.0 + np.arange(n) * 0.01 + rng.normal(0.0, 2e-5, n)  # jittered 100 Hz tags
    ang = np.cumsum(rng.normal(0.0, 0.01, (n, 3)), axis=0)
    q = np.column_stack([np.cos(np.linalg.norm(ang, axis=1) / 2), 0.5 * ang]) * rng.uniform(0.98, 1.02, (n, 1))
    v_n = np.column_stack(
        [10 + np.cumsum(rng.normal(0, 0.01, n)), np.cumsum(rng.normal(0, 0.01, n)), rng.normal(0, 0.1, n)]
    )
    pos = np.column_stack(
        [
            np.radians(48.0) + np.cumsum(rng.normal(0, 1e-8, n)),
            0.2 + np.cumsum(rng.normal(0, 1e-8, n)),
            300 + np.cumsum(rng.normal(0, 0.01, n)),
        ]
    )
    sol = SimpleNamespace(
        t_s=t,
        q_sn=q,
        v_n=v_n,
        pos=pos,
        c_bs=c_bs(np.cumsum(np.full(n, 0.01)), 1e-3, -2e-3) if rotating else None,
        f_u_mps2=9.81 + rng.normal(0.0, 0.05, n),
        f_u_bias_mps2=rng.normal(0.0, 1e-4, n),
        accel_bias_mps2=np.array([3e-4, -2e-4, 1e-4]),
    )
    ok = rng.uniform(size=n) > 0.05
    ok[300:340] = False  # a dropout
    nu_f = np.hypot(v_n[:, 0], v_n[:, 1]) + rng.normal(0.0, 0.01, n)
    nu_f[~ok] = rng.normal(0.0, 30.0, (~ok).sum())  # garbage where the LDV is unusable
    nu_u = rng.normal(0.0, 0.02, n)
    log = SimpleNamespace(manifest=SimpleNamespace(ldv=SimpleNamespace(lever_arm_m=(1.2, -0.4, -0.8))))
    inp = SimpleNamespace(t_s=t, log=log, ldv_ok=ok, nu_f_mps=nu_f, nu_u_mps=nu_u, still=[], cache={})
    setup = SimpleNamespace(
        scale=1.003,
        pitch_rad=0.01,
        heading_rad=-0.02,
        scale_up=0.998,
        pitch_k_rad_per_mps2=0.002,
        accel_fwd_mps2=rng.normal(0.0, 0.3, n),
    )
    # the navigation's vertical velocity: the LDV's, plus noise (what the screen compares against)
    sol.v_n[:, 2] = reference_velocity(inp, sol, setup)[1][:, 2] + rng.normal(0.0, 0.005, n)
    spikes = np.array([100, 500, 800])
    spikes = spikes[spikes < n]
    ok[spikes] = True
    nu_u[spikes] += 2.0  # values far off the navigation velocity among usable samples: screened
    return inp, sol, setup


def reference_velocity(inp, sol, setup):
    """The previous implementation: f_U (N,) and v_imu (N, 3) from every sample's C_s^n and C_b^n at once."""
    t = inp.t_s
    c_sn = c_from_q(sol.q_sn)
    c_bn = c_sn if sol.c_bs is None else c_sn @ sol.c_bs
    b = sol.accel_bias_mps2
    f_u = sol.f_u_mps2 + sol.f_u_bias_mps2 - (c_sn[:, 2, 0] * b[0] + c_sn[:, 2, 1] * b[1])
    dt = np.diff(t)
    v_b = ldv_body_velocity(
        inp.nu_f_mps,
        inp.nu_u_mps,
        setup.scale,
        setup.pitch_rad,
        setup.heading_rad,
        setup.scale_up,
        setup.pitch_k_rad_per_mps2,
        setup.accel_fwd_mps2,
    )
    v_head = np.einsum("kij,kj->ki", c_bn, v_b)
    rel = np.einsum("kji,kjl->kil", c_bn[:-1], c_bn[1:])
    w = np.column_stack([rel[:, 2, 1] - rel[:, 1, 2], rel[:, 0, 2] - rel[:, 2, 0], rel[:, 1, 0] - rel[:, 0, 1]])
    w = np.vstack([w[:1], w]) / (2 * np.r_[dt[:1], dt])[:, None]
    lever = np.asarray(inp.log.manifest.ldv.lever_arm_m, float)
    v_imu = v_head - np.einsum("kij,kj->ki", c_bn, np.cross(w, lever))
    return f_u, v_imu


def reference_chain(inp, sol, setup):
    """The previous implementation of the SINS/LDV chain and of the SINS/GNSS chain's double integral."""
    t = inp.t_s
    dt = np.diff(t)
    f_u, v_imu = reference_velocity(inp, sol, setup)
    ok = inp.ldv_ok & np.all(np.isfinite(v_imu), axis=1)
    bad = gc.screen_velocity(v_imu[:, 2], ok, sol.v_n[:, 2])
    use = ok & ~bad
    v_u = bridge_velocity(v_imu[:, 2], use, sol.v_n[:, 2], edge_n=gc.LDV_EDGE_N)
    dt0 = (t[-1] - t[0]) / (len(t) - 1)
    f_n = np.r_[f_u[:1], f_u[1:] * dt / dt0]
    vdot_u = np.diff(v_u) / dt0
    v_mid = 0.5 * (sol.v_n[1:] + sol.v_n[:-1])
    lat = 0.5 * (sol.pos[1:, 0] + sol.pos[:-1, 0])
    h = 0.5 * (sol.pos[1:, 2] + sol.pos[:-1, 2])
    rm, rn = radii(lat)
    dg = (
        f_n[1:]
        - vdot_u
        - normal_gravity(lat, h)
        + (v_mid[:, 0] / (rn + h) + 2 * OMEGA_IE * np.cos(lat)) * v_mid[:, 0]
        + v_mid[:, 1] ** 2 / (rm + h)
    )
    acc = (
        f_u[1:]
        - normal_gravity(lat, h)
        + (v_mid[:, 0] / (rn + h) + 2 * OMEGA_IE * np.cos(lat)) * v_mid[:, 0]
        + v_mid[:, 1] ** 2 / (rm + h)
    )
    w_int = np.concatenate([[0.0], np.cumsum(acc * dt)])
    s = np.concatenate([[0.0], np.cumsum(0.5 * (w_int[1:] + w_int[:-1]) * dt)])
    return {
        "f_u": f_u,
        "v_imu": v_imu,
        "t_s": 0.5 * (t[1:] + t[:-1]),
        "dg": dg,
        "dg_static": f_n[1:] - normal_gravity(lat, h),  # standing: no velocity terms (no Eötvös)
        "w_static": np.concatenate([[0.0], np.cumsum((f_u[1:] - normal_gravity(lat, h)) * dt)]),
        "lat": lat,
        "lon": 0.5 * (sol.pos[1:, 1] + sol.pos[:-1, 1]),
        "h": h,
        "speed": np.hypot(v_mid[:, 0], v_mid[:, 1]),
        "bridged": ~(use[1:] & use[:-1]),
        "screened": int(bad.sum()),
        "s": s,
    }


@pytest.mark.parametrize("block", [7, 64, 1000, 1 << 16])
@pytest.mark.parametrize("rotating", [False, True])
def test_block_wise_chain_equals_the_whole_log_formulas(monkeypatch, block, rotating):
    inp, sol, setup = fake_run(rotating=rotating)
    ref = reference_chain(inp, sol, setup)
    monkeypatch.setattr(gc, "BLOCK", block)
    np.testing.assert_array_equal(gc.vertical_force(inp, sol), ref["f_u"])
    np.testing.assert_array_equal(gc.ldv_velocity_imu(inp, sol, setup), ref["v_imu"])
    np.testing.assert_array_equal(gc._double_integral(inp.t_s, sol), ref["s"])
    w_static = np.empty(len(inp.t_s))
    gc._double_integral(inp.t_s, sol, first_static=w_static)
    np.testing.assert_allclose(w_static, ref["w_static"], rtol=0, atol=1e-12 * np.max(np.abs(ref["w_static"])))
    ch = gc.ldv_chain(inp, sol, setup)
    assert ch["screened"] == ref["screened"] >= 3  # the three spikes (and maybe garbage next to the dropout)
    for key in ("t_s", "dg", "dg_static", "lat", "lon", "h", "speed", "bridged"):
        np.testing.assert_array_equal(np.asarray(ch[key]), ref[key], err_msg=key)


def test_interval_column_indexes_like_the_materialized_column():
    inp, sol, setup = fake_run(n=50)
    ref = reference_chain(inp, sol, setup)
    ch = gc.ldv_chain(inp, sol, setup)
    col, full = ch["lat"], ref["lat"]
    assert len(col) == len(full) == 49 and col.shape == (49,)
    mask = np.arange(49) % 3 == 0
    for idx in (mask, np.flatnonzero(mask), slice(5, 40, 4), slice(None, None, -1), np.array([-1, 0, 48]), [2, 7]):
        np.testing.assert_array_equal(col[idx], full[idx])
    assert col[-1] == full[-1] and col[10] == full[10]
    np.testing.assert_array_equal(np.degrees(ch["lon"]), np.degrees(ref["lon"]))
    np.testing.assert_array_equal(np.nan_to_num(ch["speed"]), ref["speed"])
    with pytest.raises(IndexError):
        col[49]
    with pytest.raises(IndexError):
        col[np.ones(48, bool)]


def previous_bridge(v_mps, ok, v_ref_mps, edge_n=1, edge_fit="mean"):
    """bridge_velocity as it was: the offsets v − v_ref of every sample formed first, runs from int64 steps."""
    v = np.array(v_mps, float, copy=True)
    ok = np.asarray(ok, bool) & np.isfinite(v)
    off = v - v_ref_mps
    n = len(v)
    e = np.flatnonzero(np.diff(np.r_[0, np.asarray(~ok, int), 0]))
    segs = list(zip(e[::2], e[1::2]))

    def edge(lo, hi, at):
        seg = off[lo:hi]
        if edge_fit == "line" and len(seg) >= 3:
            return float(np.polyfit(np.arange(lo, hi, dtype=float) - at, seg, 1)[1])
        return float(np.mean(seg))

    for i, (a, b) in enumerate(segs):
        lo = segs[i - 1][1] if i > 0 else 0
        hi = segs[i + 1][0] if i + 1 < len(segs) else n
        oa = edge(max(lo, a - edge_n), a, a - 1) if a > 0 else None
        ob = edge(b, min(hi, b + edge_n), b) if b < n else None
        oa = ob if oa is None else oa
        ob = oa if ob is None else ob
        w = (np.arange(a, b) - (a - 1)) / (b - a + 1)
        v[a:b] = v_ref_mps[a:b] + (1 - w) * oa + w * ob
    return v


@pytest.mark.parametrize("edge_fit", ["mean", "line"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_bridge_equals_its_previous_implementation(edge_fit, seed):
    rng = np.random.default_rng(seed)
    n = 3000
    v_ref = np.cumsum(rng.normal(0.0, 0.01, n))
    v = v_ref + 0.3 + np.cumsum(rng.normal(0.0, 0.002, n))
    ok = rng.uniform(size=n) > 0.1  # single dropped samples ...
    ok[:7] = False  # ... a gap at the start, one at the end, long ones between gaps close together
    ok[-4:] = False
    ok[1000:1400] = False
    ok[1403:1405] = False
    v[~ok] = np.where(rng.uniform(size=(~ok).sum()) < 0.5, np.nan, 1e3)
    for edge_n in (1, 3, 50):
        got = gc.bridge_velocity(v, ok, v_ref, edge_n=edge_n, edge_fit=edge_fit)
        np.testing.assert_array_equal(got, previous_bridge(v, ok, v_ref, edge_n, edge_fit))
        assert np.all(np.isfinite(got)) and np.array_equal(got[ok & np.isfinite(v)], v[ok & np.isfinite(v)])


def test_shared_filtered_mask_and_line_bisection_equal_the_plain_computation():
    """Lowpass.apply with a den_cache equals it without; evaluate's lines (found by bisection of the
    chain times) hold exactly the samples the masks over the whole log select."""
    from ldvsurvey.nav.gravity import Lowpass, trim_line
    from ldvsurvey.pipelines.gravity.report import evaluate

    rng = np.random.default_rng(7)
    fs, n = 10.0, 20000
    t = 50.0 + np.arange(n) / fs
    x, y = rng.normal(0.0, 1e-5, n), rng.normal(0.0, 1e-5, n)
    cache = {}
    a1 = Lowpass(60.0, fs).apply(x, den_cache=cache)
    assert len(cache) == 1
    np.testing.assert_array_equal(Lowpass(60.0, fs).apply(y, den_cache=cache), Lowpass(60.0, fs).apply(y))
    np.testing.assert_array_equal(a1, Lowpass(60.0, fs).apply(x))
    x_gap = x.copy()
    x_gap[5000:5100] = np.nan  # with gaps the mask differs: not taken from (nor put into) the cache
    np.testing.assert_array_equal(Lowpass(60.0, fs).apply(x_gap, den_cache=cache), Lowpass(60.0, fs).apply(x_gap))
    assert len(cache) == 1
    # two passes over the same 10-km road, out (t 100..900 s) and back (1100..1900 s)
    s_m = np.interp(t, [50, 100, 900, 1100, 1900, 2100], [0, 0, 10000, 10000, 0, 0])
    bridged = rng.uniform(size=n - 1) < 0.02
    ch = {
        "t_s": t,
        "dg": 1e-5 * np.sin(s_m / 700.0) + x,
        "lat": np.radians(48.0) + s_m / 6.37e6,
        "lon": np.full(n, 0.2),
        "speed": np.full(n, 12.5),
        "fs": fs,
        "bridged": np.r_[bridged, False],
        "kind": "ldv",
    }
    lines = [("L1", 0, 100.0, 900.0), ("L2", 0, 1100.0, 1900.0)]
    before = {k: v.copy() for k, v in ch.items() if isinstance(v, np.ndarray)}
    res = evaluate([ch], lines, Lowpass(60.0), 10.0, 30.0, leveling="linear")
    for ln, (_, _, a, b) in zip(res.lines, lines):
        whole = (t >= a) & (t <= b)
        k, info = ln.samples, ln.info()
        np.testing.assert_array_equal(k, np.flatnonzero(trim_line(t, a, b, 30.0) & np.isfinite(res.filtered[0])))
        assert info["bridged_s"] == np.sum(ch["bridged"][whole]) / fs
        assert info["bridged_share"] == np.mean(ch["bridged"][whole]) > 0
        assert info["unsupported_s"] == np.sum(res.unsupported[0][whole]) / fs
    assert res.coincidence.total < 0.5
    assert res.line_offsets_mgal is not None  # the lines were levelled in the result's own series …
    for k, v in before.items():  # … and nothing passed in was changed
        np.testing.assert_array_equal(ch[k], v)
    assert set(ch) == set(before) | {"fs", "kind"}  # the same δg twice: the lines agree to their noise
