"""Base-tilt estimation shared by pipelines: the tilt of a rotating IMU's turntable axis from still stretches."""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import ParameterError
from ldvsurvey.nav.turntable import TiltEstimate, estimate_tilt, find_stops
from ldvsurvey.pipelines.base import warn
from ldvsurvey.pipelines.stages.aids import NavInputs, c_bs_of, gnss_aid, ldv_aid, pipeline_cfg, run_navigation_filter
from ldvsurvey.units import G0_MPS2


def static_part(inp: NavInputs) -> NavInputs:
    """The inputs cut to the static period at the start."""
    k = inp.t_s <= inp.static_end_s
    return NavInputs(
        log=inp.log,
        t_s=inp.t_s[k],
        dtheta_rad=inp.dtheta_rad[k],
        dvel_mps=inp.dvel_mps[k],
        eta_rad=None if inp.eta_rad is None else inp.eta_rad[k],
        ldv_ok=inp.ldv_ok[k],
        nu_f_mps=inp.nu_f_mps[k],
        nu_u_mps=None if inp.nu_u_mps is None else inp.nu_u_mps[k],
        still=[(inp.t_s[0] - 1.0, inp.static_end_s)],
        static_end_s=inp.static_end_s,
        pos0=inp.pos0,
        noise=inp.noise,
    )


def _tilt_from(inp: NavInputs, sol, still, stops) -> TiltEstimate:
    from ldvsurvey.nav.attitude import c_from_q

    c_sn = c_from_q(sol.q_sn)
    bias_sig = 0.0
    if sol.epoch_sigma is not None and sol.epoch_sigma.shape[1] >= 15:
        bias_sig = float(np.median(sol.epoch_sigma[:, 12:14])) / G0_MPS2
    return estimate_tilt(inp.t_s, c_sn, inp.eta_rad, still, bias_sigma_rad=bias_sig, stops=stops)


def tilt_stage(inp: NavInputs) -> tuple[TiltEstimate, list]:
    """Estimate (α, β) from every still stretch in which the turntable turns (methods §2).

    First the static period at the start (smoothed zero-velocity filter, which also calibrates the
    horizontal accelerometer biases: the rotation makes them observable). When the turntable does
    not turn enough there, the whole log is navigated (zero-velocity updates where still, nominal
    LDV aiding) and every later still interval with turntable motion is used. When nothing makes
    the tilt observable, α = β = 0 is returned with ``observable`` False and a warning in
    ``warnings``: the caller goes on (the attitude then keeps an oscillation of the tilt's size).

    Parameters
    ----------
    inp : NavInputs
        The loaded log of a rotating IMU (the estimate is kept in ``inp.cache``).

    Returns
    -------
    est : TiltEstimate
        α, β (rad) with their 1-σ, whether they were observable, the pairs and intervals used.
    stops : list
        The turntable stops found (:func:`ldvsurvey.nav.turntable.find_stops`) in the span used.
    """
    if inp.eta_rad is None:
        raise ParameterError(
            "the IMU does not rotate (manifest imu.rotating is false, no turntable_deg)",
            file="imu.csv",
            field="turntable_deg",
        )
    key = ("tilt_stage",)
    if key in inp.cache:
        return inp.cache[key]
    st = static_part(inp)
    stops = find_stops(st.t_s, st.eta_rad)
    est = None
    if len(st.t_s) >= 100:
        sol = run_navigation_filter(st, cbs=c_bs_of(st), cfg=pipeline_cfg(), smooth=True, attitude_only=True)
        est = _tilt_from(st, sol, st.still, stops)
    later = [(a, b) for a, b in inp.still if a >= inp.static_end_s - 1e-6]
    if (est is None or not est.observable) and later:
        stops_all = find_stops(inp.t_s, inp.eta_rad)
        has_ldv = inp.has_ldv  # without a (usable) LDV: the GNSS fixes aid the whole-log navigation
        sol = run_navigation_filter(
            inp,
            cbs=c_bs_of(inp),
            ldv=ldv_aid(inp) if has_ldv else None,
            gnss=None if has_ldv else gnss_aid(inp.log),
            cfg=pipeline_cfg(),
            smooth=True,
            attitude_only=True,
        )  # the tilt needs the attitude and the bias σ only
        est2 = _tilt_from(inp, sol, inp.still, stops_all)
        if est2.observable or est is None:
            est, stops = est2, stops_all
    for w in est.warnings:
        warn(w)
    inp.cache[key] = (est, stops)
    return est, stops
