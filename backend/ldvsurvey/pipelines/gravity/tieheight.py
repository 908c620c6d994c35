"""The height sanity check of the gravity network's base ties, and of the log's own GNSS heights.

A tie's δg is its absolute g less normal gravity at the height given, γ(φ, h): a height WRONG by δh
moves the tie, and with it the whole network's level, by 0.3086 mGal/m · δh (a real height difference
between the mark and the vehicle costs nothing: each one's γ is taken at its own height). The usual
field error is an orthometric height (above the geoid: a levelling benchmark's, or a GGA whose
geoid-separation field is empty) given for the ellipsoidal one; they differ by the geoid undulation,
tens of metres (−16 to −20 m in Hunan, +50 m in Ireland): 5 to 15 mGal.

So every tie's height is compared with the log's track height nearest the tie horizontally: the GNSS
fixes of the chosen qualities (``gnss_fixes``, brought from the antenna to the IMU with the lever arm's
up part) where there are any, else the navigated height of the chain (dead-reckoned on a SINS/LDV chain
without fixes: its own 1-σ, the filter's, is stated and allowed for). The allowance is
:data:`TIE_HEIGHT_WARN_M` (the IMU standing 1 to 2 m above the mark, a metre of height error) plus the
track's grade times the tie's horizontal distance from it, plus 3 σ of the reference. A warning says
which side looks orthometric: a difference near −ζ (EGM2008's height anomaly at the tie) the tie's,
near +ζ the log's.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.pipelines.stages.aids import GNSS_SIGMA, local_metres

#: the fixed part of the allowance (m): 3 m ≈ 0.93 mGal through the free-air gradient; it leaves room
#: for the sensor standing 1 to 2 m above the mark and for a metre of height error, and catches a
#: geoid-ellipsoid mix-up (tens of metres) everywhere the geoid is over 3 m plus the terms below
TIE_HEIGHT_WARN_M = 3.0
#: normal gravity's free-air gradient (mGal/m), to state what a wrong height does to the tie
FREE_AIR_MGAL_PER_M = 0.3086
#: the track's grade at the reference point is taken from the track points this far from it (m) ...
GRADE_RANGE_M = (15.0, 60.0)
#: ... and this close to it in time (s): the same pass
GRADE_WINDOW_S = 120.0
#: σ of the reference height allowed for (a multiple)
REFERENCE_SIGMAS = 3.0


def stop_heights(chain, log, t_s: float, fixes=(4,)) -> tuple[float | None, float | None]:
    """The navigated and the GNSS ellipsoidal height (m, IMU) of the stop holding ``t_s``.

    Parameters
    ----------
    chain : dict
        The SINS/LDV chain (``t_s`` in s, ``h`` in m, ``still``: the stops as (t0, t1) in s).
    log : DriveLog
        Its log (``gnss`` with ``t_s``, ``h_m``, ``fix``; the manifest's antenna lever arm in m).
    t_s : float
        A time inside the stop (s).
    fixes : sequence of int
        GGA fix qualities taken.

    Returns
    -------
    tuple
        (navigated mean height m or None, median GNSS height m or None without a fix there).
    """
    win = next(((a, b) for a, b in chain.get("still") or () if a <= t_s <= b), (t_s - 5.0, t_s + 5.0))
    t = np.asarray(chain["t_s"])
    k = np.flatnonzero((t >= win[0]) & (t <= win[1]))
    h_nav = float(np.mean(np.asarray(chain["h"][k], float))) if len(k) else None
    h_gnss = None
    g = getattr(log, "gnss", None)
    if g is not None:
        m = (g.t_s >= win[0]) & (g.t_s <= win[1]) & np.isin(g.fix, list(fixes)) & np.isfinite(g.h_m)
        if np.any(m):
            h_gnss = float(np.median(g.h_m[m])) - _lever_up_m(log)
    return h_nav, h_gnss


def _lever_up_m(log) -> float:
    """The antenna lever arm's up part (m, body RFU; the vehicle level)."""
    return float(np.asarray(log.manifest.gnss.lever_arm_m, float)[2])


def track_reference(lat_deg: float, lon_deg: float, chain, log, fixes=(4,)) -> dict | None:
    """The log's IMU height nearest a point horizontally, its 1-σ, and the track's grade there.

    Parameters
    ----------
    lat_deg, lon_deg : float
        The point (a tie's mark), deg.
    chain : dict
        The chain (``t_s`` s, ``lat``/``lon`` rad, ``h`` m; ``h_sigma_epochs`` the navigation's height σ).
    log : DriveLog
        Its log (``gnss`` fixes, the manifest's lever arm in m).
    fixes : sequence of int
        GGA fix qualities taken.

    Returns
    -------
    dict or None
        ``h_m`` (m, IMU), ``sigma_m`` (m, None when unknown), ``source`` ("GNSS" or "navigated"),
        ``distance_m`` (horizontal, m), ``grade`` (|dh/ds| of the track there, 0 when it cannot be
        formed) and ``t_s`` (s); None without a track.
    """
    g = getattr(log, "gnss", None)
    sig = None
    if g is not None:
        m = np.isin(g.fix, list(fixes)) & np.isfinite(g.h_m) & np.isfinite(g.lat_deg) & np.isfinite(g.lon_deg)
    if g is not None and np.any(m):
        t, lat, lon = g.t_s[m], np.radians(g.lat_deg[m]), np.radians(g.lon_deg[m])
        h = g.h_m[m] - _lever_up_m(log)
        sig = np.array([GNSS_SIGMA.get(int(f), (np.nan, np.nan))[1] for f in g.fix[m]])
        source = "GNSS"
    else:
        t = np.asarray(chain["t_s"], float)
        if not len(t):
            return None
        lat, lon, h = (np.asarray(chain[c], float) for c in ("lat", "lon", "h"))
        source = "navigated"
    e, n = local_metres(np.radians(lat_deg), np.radians(lon_deg), lat, lon)
    d = np.hypot(e, n)
    i = int(np.argmin(d))
    if sig is not None:
        sigma = float(sig[i]) if np.isfinite(sig[i]) else None
    else:
        ep = chain.get("h_sigma_epochs")
        sigma = float(np.interp(t[i], ep[0], ep[1])) if ep is not None and len(ep[0]) else None
    s = np.hypot(e - e[i], n - n[i])
    near = (np.abs(t - t[i]) < GRADE_WINDOW_S) & (s >= GRADE_RANGE_M[0]) & (s <= GRADE_RANGE_M[1])
    grade = float(np.median(np.abs(h[near] - h[i]) / s[near])) if np.any(near) else 0.0
    return {
        "h_m": float(h[i]),
        "sigma_m": sigma,
        "source": source,
        "distance_m": float(d[i]),
        "grade": grade,
        "t_s": float(t[i]),
    }


def _zeta_m(lat_deg: float, lon_deg: float, h_m: float) -> float | None:
    """EGM2008's height anomaly ζ (m) at the point; None where the model cannot be read."""
    from ldvsurvey.nav.gravmodel import height_anomaly_m

    try:
        return float(height_anomaly_m(lat_deg, lon_deg, h_m)[0])
    except (OSError, ValueError, ImportError):
        return None


def _which_side(diff: float, zeta: float | None, allow: float) -> str:
    """The sentence naming the side that looks orthometric (tie less log = −ζ: the tie's; +ζ: the log's)."""
    if zeta is None:
        return "is one of them an orthometric height (above the geoid)? base_ties takes ellipsoidal heights"
    tol = max(TIE_HEIGHT_WARN_M, 0.25 * abs(zeta))
    zs = f"EGM2008's height anomaly there ζ = {zeta:+.1f} m"
    if abs(zeta) > allow and abs(diff + zeta) < tol:
        return (
            f"the difference is about −ζ ({zs}): the tie's height looks orthometric (above the geoid); base_ties "
            "takes ellipsoidal heights, h = H + ζ"
        )
    if abs(zeta) > allow and abs(diff - zeta) < tol:
        return (
            f"the difference is about +ζ ({zs}): the log's heights look orthometric (a GGA with an empty "
            "geoid-separation field); give the receiver's ellipsoidal heights or state the separation"
        )
    return f"neither side differs by ±ζ ({zs}): check the tie's height"


def check_tie_heights(tie_rows, ties_given, chains, logs, fixes=(4,)) -> list[str]:
    """Add each tie row's heights, warn where a tie's height is further off the log's than allowed.

    Parameters
    ----------
    tie_rows : list of dict
        The network summary's ``ties`` (``tie`` "Tn", ``log`` "Bk", ``t_s`` in s); each gets ``h_tie_m``,
        ``h_nav_m`` and ``h_gnss_m`` (at the stop; None without a fix), ``h_reference_m`` (the track
        height nearest the tie, m), ``h_reference_source``, ``h_reference_sigma_m`` (m or None),
        ``reference_distance_m``, ``reference_grade``, ``height_allowance_m``, ``h_difference_m`` (tie
        less the reference, m) and ``height_warning`` (None or the warning).
    ties_given : list of tuple
        The parsed ``base_ties`` (lat deg, lon deg, h m, g mGal).
    chains, logs : list
        The chains and their logs, in bundle order.
    fixes : sequence of int
        GGA fix qualities whose heights count.

    Returns
    -------
    list of str
        The warnings, each naming the tie, its height, the reference with its σ, the allowance, what a
        wrong height would cost in mGal and which side looks orthometric.
    """
    warnings = []
    for row in tie_rows:
        k, ci = int(row["tie"][1:]) - 1, int(row["log"][1:]) - 1
        lat, lon, h_tie = ties_given[k][:3]
        h_nav, h_gnss = stop_heights(chains[ci], logs[ci], row["t_s"], fixes)
        ref = track_reference(lat, lon, chains[ci], logs[ci], fixes)
        diff = allow = None
        warn = None
        if ref is not None:
            diff = float(h_tie - ref["h_m"])
            allow = TIE_HEIGHT_WARN_M + ref["grade"] * ref["distance_m"] + REFERENCE_SIGMAS * (ref["sigma_m"] or 0.0)
        if diff is not None and abs(diff) > allow:
            sig = "σ unknown" if ref["sigma_m"] is None else f"σ {ref['sigma_m']:.2f} m"
            up = _lever_up_m(logs[ci])
            warn = (
                f"base tie {row['tie']} ({lat:.6f}, {lon:.6f}): its height {h_tie:.1f} m is {diff:+.1f} m off the "
                f"{ref['source']} height of {row['log']} nearest it, {ref['h_m']:.1f} m ({sig}; "
                f"{ref['distance_m']:.0f} m away on a {100 * ref['grade']:.1f} % grade: {allow:.1f} m allowed). "
                f"Were the tie's height wrong by that much, its γ and the network's level would be off by "
                f"{FREE_AIR_MGAL_PER_M * abs(diff):.1f} mGal ({FREE_AIR_MGAL_PER_M} mGal/m); "
                f"{_which_side(diff, _zeta_m(lat, lon, h_tie), allow)}. A GNSS lever arm given antenna-to-IMU or "
                f"z-down shifts the log's height by twice its up part ({2 * up:.2f} m)."
            )
            warnings.append(warn)
        row.update(
            h_tie_m=float(h_tie),
            h_nav_m=h_nav,
            h_gnss_m=h_gnss,
            h_reference_m=None if ref is None else ref["h_m"],
            h_reference_source=None if ref is None else ref["source"],
            h_reference_sigma_m=None if ref is None else ref["sigma_m"],
            reference_distance_m=None if ref is None else ref["distance_m"],
            reference_grade=None if ref is None else ref["grade"],
            height_allowance_m=allow,
            h_difference_m=diff,
            height_warning=warn,
        )
    return warnings


def separation_warnings(logs) -> list[str]:
    """A warning per log whose GGA fixes state no geoid separation (all NaN): its heights are orthometric.

    Parameters
    ----------
    logs : list of DriveLog
        The run's logs (``gnss.sep_m`` m, NaN where the GGA field is empty; None: not recorded).

    Returns
    -------
    list of str
        The warnings, naming the size of the error (EGM2008's ζ there, 0.3086 mGal/m) and the fix.
    """
    out = []
    for i, log in enumerate(logs):
        g = getattr(log, "gnss", None)
        if g is None or g.sep_m is None:
            continue
        m = (g.fix > 0) & np.isfinite(g.h_m) & np.isfinite(g.lat_deg)
        if not np.any(m) or np.any(np.isfinite(np.asarray(g.sep_m)[m])):
            continue
        lat, lon, h = (float(np.median(a[m])) for a in (g.lat_deg, g.lon_deg, g.h_m))
        zeta = _zeta_m(lat, lon, h)
        size = (
            "" if zeta is None else f" (N ≈ EGM2008's ζ there, {zeta:+.1f} m: {-FREE_AIR_MGAL_PER_M * zeta:+.1f} mGal)"
        )
        out.append(
            f"bundle {i + 1}: gnss.nmea: no GGA sentence states the geoid separation, so its heights are the "
            "altitude field as it stands, most likely orthometric (above the geoid), not ellipsoidal: normal "
            f"gravity is then taken at the wrong height and absolute δg comes out off by −0.3086 mGal/m × N{size}. "
            "Give the receiver's ellipsoidal heights (or GGA with the separation field filled)"
        )
    return out
