"""The label and unit of every pipeline parameter, as forms, job pages and reports show them.

One table for all pipelines (a parameter shared by several, such as ``ldv_pitch_deg``, means the
same in each); the pydantic models in the pipeline modules keep the full description (bounds,
defaults), shown beside the label. :func:`param_label` is what the API serves
(``GET /api/pipelines``, ``GET /api/jobs/{id}``); ``tests/pipelines/test_param_labels.py`` checks
that every parameter of every pipeline has its entry, and that the unit agrees with the unit the
name carries (``_deg`` → °, ``_s`` → s, …).
"""

from __future__ import annotations

#: parameter name → (label, unit); unit "" for dimensionless, choices and text
PARAM_LABELS: dict[str, tuple[str, str]] = {
    "aiding": ("Aiding of the navigation", ""),
    "base_ties": ("Base stations: latitude, longitude, ellipsoidal height, absolute g (and its 1-σ)", ""),
    "calibration": ("LDV calibration", ""),
    "calibration_window": ("Calibration stretch t0, t1 (time of day)", "s"),
    "compensation": ("Grid step × update interval study", ""),
    "compensation_steps_arcmin": ("Grid steps of the study", "′"),
    "compensation_updates_s": ("Update intervals of the study", "s"),
    "degree": ("Maximum degree of the EGM2008 synthesis", ""),
    "delayed_baseline_s": ("Delayed-state baseline", "s"),
    "delayed_gate_sigma": ("Gate on the delayed-state velocity change", "σ"),
    "dov": ("Deflection of the vertical in the mechanization", ""),
    "dov_grid": ("DOV grid files (server)", ""),
    "dov_grid_id": ("Uploaded DOV grid", ""),
    "drift_correction": ("Accelerometer drift tie at stops", ""),
    "external_grid": ("External δg grid files (server)", ""),
    "external_grid_id": ("Uploaded external δg grid", ""),
    "external_model": ("External check of the adjusted δg", ""),
    "fir_length_s": ("FIR filter length", "s"),
    "gnss_aided": ("Also on an LDV+GNSS navigation", ""),
    "gnss_comparison": ("SINS/GNSS comparison chain", ""),
    "gnss_fixes": ("GNSS fix qualities of the SINS/GNSS chain", ""),
    "grid_step_arcmin": ("EGM2008 grid step", "′"),
    "imu_nodov": ("IMU file without DOV (simulation)", ""),
    "initial_h_m": ("Initial height of the IMU centre", "m"),
    "interpolation": ("Grid interpolation along the track", ""),
    "ldv_heading_deg": ("LDV mounting heading φ_L", "°"),
    "ldv_pitch_deg": ("LDV mounting pitch η_L", "°"),
    "ldv_pitch_k_rad_per_mps2": ("LDV pitch compliance k_η", "rad/(m/s²)"),
    "ldv_scale": ("LDV scale factor K", ""),
    "ldv_sigma_mps": ("Water-LDV sample noise, 1σ", "m/s"),
    "line_end_trim_s": ("Trim at both line ends", "s"),
    "line_leveling": ("Repeat-line adjustment", ""),
    "lines": ("Survey lines t0-t1 (time of day)", "s"),
    "map_grid": ("Gridded map of the adjusted δg", ""),
    "network": ("Survey network adjustment", ""),
    "network_drift": ("Linear drift per log in the network", ""),
    "network_line_bias": ("A bias per line in the network", ""),
    "outlier_sigma": ("Outlier threshold of the network residuals", "σ"),
    "output_rate_hz": ("Output rate", "Hz"),
    "period_s": ("Filter update period", "s"),
    "propagation_model": ("DOV error propagation model", ""),
    "smooth": ("RTS smoother", ""),
    "spacing_m": ("Spacing of the common along-track points", "m"),
    "tie_radius_m": ("Radius within which a stop observes a base tie", "m"),
    "update_s": ("Error-update period", "s"),
}

#: the unit a name's suffix states (checked against the table by the tests)
SUFFIX_UNIT = {"s": "s", "m": "m", "deg": "°", "hz": "Hz", "arcmin": "′", "mps": "m/s", "mps2": "rad/(m/s²)"}


def param_label(name: str) -> tuple[str, str]:
    """(label, unit) of a parameter; an unknown name is shown as words (never snake_case)."""
    if name in PARAM_LABELS:
        return PARAM_LABELS[name]
    return name.replace("_", " ").capitalize(), ""
