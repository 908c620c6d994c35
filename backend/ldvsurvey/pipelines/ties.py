"""A project's base stations (absolute gravity ties): checking one, and the ``base_ties`` text of a list.

A tie is checked by the very parser of the gravity pipeline's ``base_ties`` parameter
(:func:`ldvsurvey.pipelines.gravity.network.parse_ties`), so a station the project keeps is one the
pipeline takes; its refusals are turned to name the station's own field (``lat_deg``, ``g_mgal``, …).
"""

from __future__ import annotations

import math
import unicodedata

from ldvsurvey.errors import ParameterError
from ldvsurvey.pipelines.gravity.network import TIE_SIGMA_MAX_MGAL, parse_ties, tie_sigmas_mgal

#: the 1-σ of a station's absolute g must lie in (0, SIGMA_MAX_MGAL] mGal (as ``base_ties``' fifth value)
SIGMA_MAX_MGAL = TIE_SIGMA_MAX_MGAL
#: longest station name and note (characters)
NAME_MAX, NOTE_MAX = 100, 500


def check_tie(
    name: str, lat_deg: float, lon_deg: float, h_m: float, g_mgal: float, sigma_mgal: float, note: str = ""
) -> dict:
    """One base station, checked as ``base_ties`` checks it; a ParameterError names the field.

    Parameters
    ----------
    name : str
        The station's name (1 to 100 characters, no control characters, no ``;`` or ``,``).
    lat_deg, lon_deg : float
        Geodetic latitude and longitude (deg); a longitude east of 180° is kept as negative.
    h_m : float
        Ellipsoidal height (m, WGS-84), not the orthometric height of a levelling benchmark.
    g_mgal : float
        Absolute gravity at the station (mGal).
    sigma_mgal : float
        1-σ of ``g_mgal`` (mGal), in (0, 100].
    note : str
        Where the value comes from (free text, at most 500 characters).

    Returns
    -------
    dict
        The same fields, stripped and normalized (``lon_deg`` in [-180, 180]).
    """
    name = str(name).strip()
    if not name or len(name) > NAME_MAX:
        raise ParameterError(f"a station name of 1 to {NAME_MAX} characters", field="name")
    if any(c in ";," or unicodedata.category(c).startswith("C") for c in name):
        raise ParameterError(f"{name!r}: no control characters, ';' or ',' in a station name", field="name")
    note = str(note or "").strip()
    if len(note) > NOTE_MAX or any(unicodedata.category(c) == "Cc" and c not in "\n\t" for c in note):
        raise ParameterError(f"at most {NOTE_MAX} characters, no control characters", field="note")
    values = {"lat_deg": lat_deg, "lon_deg": lon_deg, "h_m": h_m, "g_mgal": g_mgal, "sigma_mgal": sigma_mgal}
    for k, v in values.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ParameterError(f"{v!r} is not a finite number", field=k)
    text = f"{lat_deg!r},{lon_deg!r},{h_m!r},{g_mgal!r},{sigma_mgal!r}"
    try:
        ((lat, lon, h, g),), (sigma_mgal,) = parse_ties(text), tie_sigmas_mgal(text)
    except ParameterError as exc:
        raise ParameterError(_own_words(exc.message), field=_field_of(exc.message, lat_deg)) from None
    return {
        "name": name,
        "lat_deg": lat,
        "lon_deg": lon,
        "h_m": h,
        "g_mgal": g,
        "sigma_mgal": float(sigma_mgal),
        "note": note,
    }


def _field_of(message: str, lat_deg: float) -> str:
    """The station field a ``parse_ties`` refusal is about."""
    if "SIGMA_MGAL" in message:
        return "sigma_mgal"
    if "latitude" in message:
        return "lat_deg" if not -90.0 <= lat_deg <= 90.0 else "lon_deg"
    if "height" in message:
        return "h_m"
    return "g_mgal"


def _own_words(message: str) -> str:
    """A ``parse_ties`` message without its "tie 1: " (the station is the request's one)."""
    return message.split(": ", 1)[1] if message.startswith("tie 1: ") else message


def base_ties_text(ties) -> str | None:
    """The ``base_ties`` parameter of a list of stations (in their order: the n-th is the results' Tn).

    Parameters
    ----------
    ties : iterable
        Objects or dicts with ``lat_deg``, ``lon_deg`` (deg), ``h_m`` (m), ``g_mgal`` (mGal) and
        ``sigma_mgal`` (mGal, the 1-σ of g; a station without one gives four values: g taken as exact).

    Returns
    -------
    str or None
        ``LAT,LON,H_M,G_MGAL,SIGMA_MGAL;...`` with every digit kept (``repr``), None for no station.
    """

    def get(t, k):
        return t.get(k) if isinstance(t, dict) else getattr(t, k, None)

    keys = ("lat_deg", "lon_deg", "h_m", "g_mgal", "sigma_mgal")
    items = [",".join(repr(float(get(t, k))) for k in keys if get(t, k) is not None) for t in ties]
    return ";".join(items) or None
