"""Coarse + fine alignment reach the gyrocompassing and levelling limits."""

import numpy as np

from ldvsurvey.nav.align import coarse_align
from ldvsurvey.nav.attitude import attitude_error_rad, q_from_c
from ldvsurvey.nav.earth import ARCSEC, OMEGA_IE
from ldvsurvey.nav.filter import FilterConfig, ImuData, ImuNoise, NavStart, run_filter
from ldvsurvey.sim.motion import Static
from ldvsurvey.sim.road import Ramps, Road
from ldvsurvey.sim.scenario import Scenario
from ldvsurvey.sim.sensors import ImuErrors
from tests.nav.helpers import truth_imu

RAD = np.pi / 180


def test_coarse_and_fine_alignment_limits():
    lat = 28.4861 * RAD
    road = Road(lat, 113.0 * RAD, 100.0, 10.0, Ramps(0.0))  # vehicle facing north: body axes on E, N, U
    sc = Scenario(name="static", road=road, segments=[Static(600.0)])
    _, imu = truth_imu(sc)
    eps_dph, nabla_ug = 0.003, 20.0
    for seed in (3, 4):
        rng = np.random.default_rng(seed)
        err = ImuErrors.draw(rng, eps_dph, nabla_ug, arw_dprh=0.0001, vrw_ug_rthz=2.0)
        dth, dv = err.apply(imu.dtheta_rad, imu.dvel_mps, 0.01, rng)
        c0 = coarse_align(dth, dv, lat)
        pos0 = np.array([lat, road.lon0_rad, road.h0_m])
        cfg = FilterConfig(att_sigma0_rad=(0.01 * RAD, 0.01 * RAD, 1 * RAD))
        sol = run_filter(
            ImuData(imu.t_s, dth, dv),
            NavStart(q_from_c(c0), np.zeros(3), pos0),
            ImuNoise(eps_dph, nabla_ug, 0.0001, 2.0),
            cfg,
            zupt_intervals=[(imu.t_s[0] - 1, imu.t_s[-1])],
            smooth=False,
        )
        phi = attitude_error_rad(sol.c_bn()[-1], imu.c_bn[-1])
        heading_limit = eps_dph * RAD / 3600 / (OMEGA_IE * np.cos(lat))
        level_limit = nabla_ug * 1e-6
        assert abs(phi[2]) <= 1.5 * heading_limit, (phi[2] / ARCSEC, heading_limit / ARCSEC)
        assert abs(phi[0]) <= 1.5 * level_limit and abs(phi[1]) <= 1.5 * level_limit, phi / ARCSEC
        # the reported σ is honest: the error lies within 3σ
        assert np.all(np.abs(phi) <= 3 * sol.sigma[-1, :3] + 1e-7)
        # coarse alone is already near the limit in level, farther in heading
        phi_c = attitude_error_rad(c0, imu.c_bn[0])
        assert np.all(np.abs(phi_c[:2]) < 3 * level_limit)
