"""Repeated-line internal coincidence and crossover accuracy (methods §4a).

Common points: every line is placed on one along-track axis (lines driven the other way are
reversed), trimmed to the stretch all lines cover and interpolated onto the same m points.
Mean line ḡ_j = (1/n) Σ_i g_ij, residual δ_ij = g_ij − ḡ_j,
total ε = sqrt(Σ_i Σ_j δ_ij² / (m (n − 1))), per line ε_i = sqrt(n/(n − 1) · Σ_j δ_ij² / m).
Crossovers: ε = sqrt(Σ_k d_k² / (2N)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class Coincidence:
    """Internal coincidence of repeated lines on common points (values in the lines' unit, e.g. mGal)."""

    names: list[str]
    distance_m: np.ndarray  # (m,) common along-track points
    values: np.ndarray  # (n, m)
    mean: np.ndarray  # (m,)
    residual: np.ndarray  # (n, m)
    per_line_rms: np.ndarray  # (n,)
    per_line_max: np.ndarray
    per_line_min: np.ndarray
    total: float
    per_line_mean: np.ndarray = None  #: mean of δ_ij over the common points
    per_line_std: np.ndarray = None  #: std of δ_ij about that mean (ddof 0)


def internal_coincidence(values: np.ndarray, names=None, distance_m=None) -> Coincidence:
    """Internal coincidence of n ≥ 2 lines already on m common points ((n, m) array, any unit).

    NaN marks a point a line does not cover (a comparison chain with outages); then at each
    point the mean line and the n/(n−1) factor use the n_j lines present there (points with
    fewer than two are left out): ε² = Σ δ² / Σ_j (n_j − 1) and ε_i² = mean_j of n_j/(n_j − 1) δ_ij².
    Without NaN these are the formulas of methods §4a exactly.

    Parameters
    ----------
    values : (n, m) array
        Each line's values on the common points (any unit; NaN where a line has no value).
    names : list of str, optional
        Line names; default L1 … Ln.
    distance_m : (m,) array, optional
        Along-track distance of the common points (m); default their index.

    Returns
    -------
    Coincidence
        Mean line, residuals, per-line and total ε (the unit of ``values``), on the points covered by
        at least two lines.

    Raises
    ------
    ValueError
        Fewer than two lines, or fewer than two points covered by two lines.
    """
    g = np.asarray(values, dtype=float)
    n, m = g.shape
    if n < 2:
        raise ValueError("internal coincidence needs at least two lines")
    have = np.isfinite(g)
    nj = have.sum(axis=0)
    if (nj >= 2).sum() < 2:
        raise ValueError("fewer than two points are covered by two lines")
    col = nj >= 2
    if not col.all():
        g, have, nj = g[:, col], have[:, col], nj[col]
        distance_m = None if distance_m is None else np.asarray(distance_m)[col]
    mean = np.nanmean(g, axis=0)
    d = g - mean
    d0 = np.where(have, d, 0.0)
    per = np.sqrt(np.sum(nj / (nj - 1) * d0**2, axis=1) / np.maximum(have.sum(axis=1), 1))
    per[have.sum(axis=1) == 0] = np.nan
    total = float(np.sqrt(np.sum(d0**2) / np.sum(nj - 1)))
    with np.errstate(invalid="ignore"):
        return Coincidence(
            list(names or [f"L{i + 1}" for i in range(n)]),
            np.arange(g.shape[1], dtype=float) if distance_m is None else np.asarray(distance_m),
            g,
            mean,
            d,
            per,
            np.nanmax(d, axis=1),
            np.nanmin(d, axis=1),
            total,
            np.nanmean(d, axis=1),
            np.nanstd(d, axis=1),
        )


def along_track(ref_e, ref_n, e, n):
    """Along-track distance of points projected on a reference polyline, and their distance off it.

    Parameters
    ----------
    ref_e, ref_n : (K,) arrays
        The reference polyline, east and north (m).
    e, n : (N,) arrays
        The points, east and north (m).

    Returns
    -------
    s_m : (N,) array
        Along-track distance of each point's projection on the segment after its nearest vertex (m).
    off_m : (N,) array
        Distance of each point from that segment's line (m).
    """
    seg = np.hypot(np.diff(ref_e), np.diff(ref_n))
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    tree = cKDTree(np.column_stack([ref_e, ref_n]))
    _, j = tree.query(np.column_stack([e, n]))
    j = np.clip(j, 0, len(ref_e) - 2)
    de, dn = ref_e[j + 1] - ref_e[j], ref_n[j + 1] - ref_n[j]
    ln = np.hypot(de, dn)
    ln[ln == 0] = 1.0
    s = ((e - ref_e[j]) * de + (n - ref_n[j]) * dn) / ln
    return cum[j] + s, np.abs(((e - ref_e[j]) * dn - (n - ref_n[j]) * de) / ln)


def common_points(
    lines: list[tuple[np.ndarray, np.ndarray]],
    spacing_m: float,
    max_hole_m: float | None = None,
    allow_holes: bool = False,
):
    """Interpolate lines given as (along-track distance, value) onto common points.

    Returns (distance (m,), values (n, m)). Each line's distances are sorted (reversed lines)
    and NaN values dropped; the common stretch is where all lines have data. A point farther
    than ``max_hole_m`` (default 3 spacings) from a line's nearest valid sample is a hole in
    that line, never bridged by interpolation: it is left out for all lines, or, with
    ``allow_holes``, set NaN in that line (points with fewer than two lines are left out).

    Parameters
    ----------
    lines : list of (array, array)
        Per line its along-track distance (m) and value (any unit).
    spacing_m : float
        Spacing of the common points (m).
    max_hole_m : float, optional
        Largest distance (m) of a point from a line's nearest valid sample; default 3 spacings.
    allow_holes : bool
        Keep the union of the lines' extents with NaN holes instead of the stretch all lines cover.

    Returns
    -------
    distance_m : (m,) array
        The common points (m).
    values : (n, m) array
        Each line's values there (the unit of the input).

    Raises
    ------
    ValueError
        A line with fewer than two valid points, or no common stretch.
    """
    hole = 3.0 * spacing_m if max_hole_m is None else max_hole_m
    prepared = []
    for s, v in lines:
        ok = np.isfinite(v) & np.isfinite(s)
        s, v = s[ok], v[ok]
        order = np.argsort(s)
        s, v = s[order], v[order]
        keep = np.concatenate([[True], np.diff(s) > 0])
        if keep.sum() < 2:
            raise ValueError("a line holds fewer than two valid points")
        prepared.append((s[keep], v[keep]))
    if allow_holes:
        lo, hi = min(s[0] for s, _ in prepared), max(s[-1] for s, _ in prepared)
    else:
        lo, hi = max(s[0] for s, _ in prepared), min(s[-1] for s, _ in prepared)
    if not hi > lo + spacing_m:
        raise ValueError("the lines share no common stretch")
    grid = np.arange(lo, hi + 1e-9, spacing_m)
    vals = np.empty((len(prepared), len(grid)))
    for i, (s, v) in enumerate(prepared):
        j = np.clip(np.searchsorted(s, grid), 1, len(s) - 1)
        near = np.minimum(np.abs(grid - s[j - 1]), np.abs(s[j] - grid)) <= hole
        near &= (grid >= s[0]) & (grid <= s[-1])
        vals[i] = np.where(near, np.interp(grid, s, v), np.nan)
    keep = np.isfinite(vals).sum(axis=0) >= 2 if allow_holes else np.all(np.isfinite(vals), axis=0)
    if keep.sum() < 2:
        raise ValueError("the lines share no common stretch")
    return grid[keep], vals[:, keep]


def crossovers(tracks: list[tuple[np.ndarray, np.ndarray, np.ndarray]], min_angle_deg: float = 0.0):
    """Differences at the crossings of distinct lines.

    Crossings at an angle below ``min_angle_deg`` (repeated passes weaving over the same road) are
    not crossovers and are skipped.

    Parameters
    ----------
    tracks : list of (array, array, array)
        Per line east (m), north (m) and value (any unit) along it.
    min_angle_deg : float
        Smallest crossing angle that counts (deg).

    Returns
    -------
    found : list of (int, int, float, float, float)
        Per crossover the two lines' indices, its east and north (m) and the difference of their
        values (line i minus line j, the unit of the values).
    eps : float or None
        Crossover accuracy sqrt(Σ d² / (2N)) (the unit of the values); None without crossovers.
    """
    sin_min = np.sin(np.radians(min_angle_deg))
    found = []
    for i in range(len(tracks)):
        for j in range(i + 1, len(tracks)):
            e1, n1, v1 = tracks[i]
            e2, n2, v2 = tracks[j]
            a0 = np.column_stack([e1[:-1], n1[:-1]])[:, None, :]
            a1 = np.column_stack([e1[1:], n1[1:]])[:, None, :]
            b0 = np.column_stack([e2[:-1], n2[:-1]])[None, :, :]
            b1 = np.column_stack([e2[1:], n2[1:]])[None, :, :]
            r, s = a1 - a0, b1 - b0
            den = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
            qp = b0 - a0
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]) / den
                u = (qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]) / den
            norm = np.hypot(r[..., 0], r[..., 1]) * np.hypot(s[..., 0], s[..., 1])
            hit = (den != 0) & (t >= 0) & (t < 1) & (u >= 0) & (u < 1) & (np.abs(den) >= sin_min * norm)
            for a, b in zip(*np.nonzero(hit)):
                ta, ub = t[a, b], u[a, b]
                va = v1[a] + ta * (v1[a + 1] - v1[a])
                vb = v2[b] + ub * (v2[b + 1] - v2[b])
                if np.isfinite(va) and np.isfinite(vb):
                    found.append((i, j, float(e1[a] + ta * r[a, 0, 0]), float(n1[a] + ta * r[a, 0, 1]), float(va - vb)))
    if not found:
        return found, None
    d = np.array([f[4] for f in found])
    return found, float(np.sqrt(np.sum(d**2) / (2 * len(d))))


def total_from_lines(per_line_rms) -> float:
    """Total internal coincidence from the per-line values ε_i (any unit): ε² is the mean of the ε_i²."""
    e = np.asarray(per_line_rms, dtype=float)
    return float(np.sqrt(np.mean(e**2)))
