"""The height sanity check of the gravity network's base ties.

A tie's δg is its absolute g less normal gravity at the height given, γ(φ, h): a height off by δh
moves the tie, and with it the whole network's level, by 0.3086 mGal/m · δh. The usual field error
is an orthometric height (above the geoid: a levelling benchmark's) given for the ellipsoidal one;
they differ by the geoid undulation, tens of metres (−20 m in Hunan, +50 m in Ireland): 6 to 15 mGal.
So at every stop that observes a tie, the tie's height is compared with the height the log itself
measured there: the GNSS fixes of the stop (the qualities of ``gnss_fixes``, brought from the antenna
to the IMU; the vehicle stands level) where there are any, else the navigated height of the stop.
"""

from __future__ import annotations

import numpy as np

#: a tie height this far (m) from the measured one is reported: 3 m ≈ 0.93 mGal through the free-air
#: gradient; it leaves room for the sensor standing 1 to 2 m above the mark and for a navigated height
#: of a metre, and catches a geoid-ellipsoid mix-up (tens of metres) everywhere the geoid is over 3 m
TIE_HEIGHT_WARN_M = 3.0
#: normal gravity's free-air gradient (mGal/m), to state what a height error does to the tie
FREE_AIR_MGAL_PER_M = 0.3086


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
            up = float(np.asarray(log.manifest.gnss.lever_arm_m, float)[2])  # level at a stop: RFU's up
            h_gnss = float(np.median(g.h_m[m])) - up
    return h_nav, h_gnss


def check_tie_heights(tie_rows, ties_given, chains, logs, fixes=(4,)) -> list[str]:
    """Add each tie row's heights, warn where a tie's height is over TIE_HEIGHT_WARN_M off the log's.

    Parameters
    ----------
    tie_rows : list of dict
        The network summary's ``ties`` (``tie`` "Tn", ``log`` "Bk", ``t_s`` in s); each gets ``h_tie_m``,
        ``h_nav_m``, ``h_gnss_m`` (None without a fix), ``h_difference_m`` (tie less the measured height,
        GNSS where there is one) and ``height_warning`` (None or the warning).
    ties_given : list of tuple
        The parsed ``base_ties`` (lat deg, lon deg, h m, g mGal).
    chains, logs : list
        The SINS/LDV chains and their logs, in bundle order.
    fixes : sequence of int
        GGA fix qualities whose heights count.

    Returns
    -------
    list of str
        The warnings, each naming the tie, its height and the measured ones.
    """
    warnings = []
    for row in tie_rows:
        k, ci = int(row["tie"][1:]) - 1, int(row["log"][1:]) - 1
        lat, lon, h_tie = ties_given[k][:3]
        h_nav, h_gnss = stop_heights(chains[ci], logs[ci], row["t_s"], fixes)
        ref, src = (h_gnss, "GNSS") if h_gnss is not None else (h_nav, "navigated")
        diff = None if ref is None else float(h_tie - ref)
        warn = None
        if diff is not None and abs(diff) > TIE_HEIGHT_WARN_M:
            nav = f", navigated {h_nav:.1f} m" if src == "GNSS" and h_nav is not None else ""
            warn = (
                f"base tie {row['tie']} ({lat:.6f}, {lon:.6f}): its height {h_tie:.1f} m is {diff:+.1f} m off the "
                f"{src} height of {row['log']} standing there, {ref:.1f} m{nav} (over {TIE_HEIGHT_WARN_M:g} m; "
                f"{FREE_AIR_MGAL_PER_M} mGal/m moves the tie by {FREE_AIR_MGAL_PER_M * abs(diff):.1f} mGal): "
                "base_ties takes ellipsoidal heights; is it an orthometric height (above the geoid)?"
            )
            warnings.append(warn)
        row.update(h_tie_m=float(h_tie), h_nav_m=h_nav, h_gnss_m=h_gnss, h_difference_m=diff, height_warning=warn)
    return warnings
