"""The shared stages' typed interfaces: the LDV height integration through an ``LdvAid``, the
calibration group's view of the given mounting, and the grid cache the CLI hands to a pipeline."""

import json

import numpy as np
import pytest

from ldvsurvey.io.writers import write_bundle
from ldvsurvey.nav.attitude import c_bn_from_euler
from ldvsurvey.nav.filter import LdvAid
from ldvsurvey.pipelines.height import integrate_height
from ldvsurvey.pipelines.registry import get, run_pipeline_cli
from ldvsurvey.pipelines.stages.grid_cache import GRID_CACHE
from ldvsurvey.pipelines.stages.ldv_mounting import CalibrationParams
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate


def _level(n: int, pitch_rad=0.0) -> np.ndarray:
    return np.repeat(c_bn_from_euler(pitch_rad, 0.0, 0.0)[None], n, axis=0)


def test_height_of_a_steady_climb_seen_through_a_pitched_mounting():
    """Level body, heading north, LDV pitched by η with scale K: V_U = sin(η) ν/K, so h grows
    linearly by that rate (with a constant attitude the lever arm adds nothing)."""
    t = np.arange(0.0, 60.0, 0.01)
    n = len(t)
    eta, scale, nu = np.radians(2.0), 1.02, 12.0
    aid = LdvAid(
        np.ones(n, bool),
        np.full(n, nu),
        scale=scale,
        pitch_rad=eta,
        heading_rad=0.0,
        lever_arm_m=(0.3, 1.5, -0.4),
    )
    h = integrate_height(t, _level(n), aid, 100.0)
    np.testing.assert_allclose(h, 100.0 + np.sin(eta) * nu / scale * (t - t[0]), rtol=0, atol=1e-9)


def test_height_bridges_unusable_samples_with_the_ins_and_removes_the_lever_arm():
    """Unusable LDV samples take the INS's vertical velocity; a pitching body with the LDV at rest
    moves the LDV lever arm up and down, which the height of the IMU centre must not follow."""
    t = np.arange(0.0, 10.0, 0.01)
    n = len(t)
    ok = np.ones(n, bool)
    ok[300:500] = False
    aid = LdvAid(ok, np.where(ok, 0.0, 50.0), scale=1.0, pitch_rad=0.0, heading_rad=0.0)
    h = integrate_height(t, _level(n), aid, 5.0, v_u_bridge_mps=np.full(n, 0.5))
    # 0.5 m/s over the 200 bridged samples (trapezoid: the half intervals at the two edges make one)
    assert h[-1] - 5.0 == pytest.approx(0.5 * (t[500] - t[300]), abs=1e-12)
    assert np.all(h[:300] == 5.0)
    # the IMU centre at rest, the body pitching about it: the LDV head at the lever arm moves, and its
    # velocity seen in the head's frame (mounting 0: forward and up of the body) is what the LDV reads
    amp, w = np.radians(3.0), 2 * np.pi / 4.0
    lever = np.array([0.0, 2.0, -0.5])
    c_bn = np.stack([c_bn_from_euler(p, 0.0, 0.0) for p in amp * np.sin(w * t)])
    dp = 1e-6
    dc_dp = np.stack(
        [
            (c_bn_from_euler(p + dp, 0.0, 0.0) - c_bn_from_euler(p - dp, 0.0, 0.0)) / (2 * dp)
            for p in amp * np.sin(w * t)
        ]
    )
    v_head_n = (dc_dp @ lever) * (amp * w * np.cos(w * t))[:, None]
    v_b = np.einsum("kji,kj->ki", c_bn, v_head_n)
    assert np.max(np.abs(v_b[:, 0])) < 1e-9  # no sideways motion in a pitch
    head = LdvAid(np.ones(n, bool), v_b[:, 1], v_b[:, 2], lever_arm_m=tuple(lever))
    lev_u = c_bn[:, 2, :] @ lever
    assert np.ptp(lev_u) > 0.1  # the head does move up and down
    np.testing.assert_allclose(integrate_height(t, c_bn, head, 5.0), 5.0, atol=1e-4)  # trapezoid error only


def test_calibration_group_says_what_is_given():
    p = CalibrationParams(ldv_pitch_deg=1.5, ldv_scale=1.01)
    assert p.given_ldv == {"ldv_pitch_deg": 1.5, "ldv_scale": 1.01}
    assert not p.mounting_given
    full = CalibrationParams(ldv_pitch_deg=1.5, ldv_heading_deg=-0.2, ldv_scale=1.01)
    assert full.mounting_given and list(full.given_ldv) == ["ldv_pitch_deg", "ldv_heading_deg", "ldv_scale"]
    assert CalibrationParams().given_ldv == {} and not CalibrationParams().mounting_given


class _Cache:
    def __init__(self):
        self.grids, self.hits = {}, 0

    def get(self, key):
        grid = self.grids.get(key)
        self.hits += grid is not None
        return grid

    def put(self, key, grid):
        self.grids[key] = grid


def test_cli_hands_the_grid_cache_it_opens_to_the_dov_pipeline(tmp_path):
    """``ldv-survey run dov`` keeps the synthesized grid in the cache the CLI opened (the database's
    in the real CLI) and finds it there the second time; a pipeline without ``uses_grid_cache``
    never opens one, and the variable is left as it was."""
    assert get("dov").uses_grid_cache and not get("height").uses_grid_cache
    sim = simulate(catalog.dov(km=2.0, degree=360, step_arcmin=2.5), seed=1)
    bundle = tmp_path / "b"
    write_bundle(bundle_files(sim), bundle)
    cache, opened = _Cache(), []

    def open_cache():
        opened.append(True)
        return cache

    sets = ["degree=36", "grid_step_arcmin=5", "compensation=false"]
    for i in range(2):
        assert run_pipeline_cli("dov", [str(bundle)], str(tmp_path / f"out{i}"), sets, open_grid_cache=open_cache) == 0
    assert len(opened) == 2 and GRID_CACHE.get() is None
    (key,) = cache.grids
    assert key.startswith("egm2008:deg36:step5.0:") and cache.hits == 1
    a, b = (json.loads((tmp_path / f"out{i}" / "summary.json").read_text()) for i in range(2))
    assert a["max_north_error_m"] == b["max_north_error_m"]  # the cached grid is the synthesized one
