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

#: the unit a name's unit word states: the one table for parameters (checked against
#: :data:`PARAM_LABELS` by the tests) and summary keys (:func:`label_unit`, the job page and the report);
#: ``<a>_per_<b>`` reads as a/b (``ldv_pitch_k_rad_per_mps2`` → rad/(m/s²))
SUFFIX_UNIT = {
    "s": "s",
    "m": "m",
    "km": "km",
    "rad": "rad",
    "deg": "°",
    "deg_per_g": "°/g",
    "arcmin": "′",
    "arcsec": "″",
    "hz": "Hz",
    "mps": "m/s",
    "mps2": "m/s²",
    "mgal": "mGal",
    "ug": "µg",
    "ug_rthz": "µg/√Hz",
    "deg_rth": "°/√h",
    "dph": "°/h",
    "ppm": "ppm",
    "pct": "%",
}


def param_label(name: str) -> tuple[str, str]:
    """(label, unit) of a parameter; an unknown name is shown as words (never snake_case)."""
    if name in PARAM_LABELS:
        return PARAM_LABELS[name]
    return name.replace("_", " ").capitalize(), ""


def _unit_at(parts: list[str], i: int) -> tuple[int, str] | None:
    """The unit whose last word is ``parts[i]``: (index of its first word, unit), longest first."""
    for j in range(max(0, i - 2), i + 1):  # a unit of three words ("deg_per_g") or two ("ug_rthz") before one
        word = "_".join(parts[j : i + 1])
        if j > 0 and word in SUFFIX_UNIT:
            if j >= 3 and parts[j - 1] == "per" and parts[j - 2] in SUFFIX_UNIT:  # "rad_per_mps2"
                num, den = SUFFIX_UNIT[parts[j - 2]], SUFFIX_UNIT[word]
                return j - 2, f"{num}/({den})" if "/" in den or "²" in den else f"{num}/{den}"
            return j, SUFFIX_UNIT[word]
    return None


def label_unit(key: str) -> tuple[str, str]:
    """A name's words and the unit its last unit word states (:data:`SUFFIX_UNIT`); words after the unit
    are a qualifier in parentheses: 'total_mgal' → ('total', 'mGal'); 'max_error_m_fix4' →
    ('max error (fix4)', 'm'); 'ldv_pitch_k_rad_per_mps2_sigma' → ('ldv pitch k (sigma)', 'rad/(m/s²)')."""
    parts = key.split("_")
    for i in range(len(parts) - 1, 0, -1):
        found = _unit_at(parts, i)
        if found:
            j, unit = found
            rest = parts[i + 1 :]
            return " ".join(parts[:j]) + (f" ({' '.join(rest)})" if rest else ""), unit
    return key.replace("_", " "), ""
