"""Time tags of ``imu.csv``: rows out of order, missing rows (gaps) and time-tag jitter.

An IMU row holds the increments over (t_prev, t]. A recorder can lose rows, write a few rows
out of order, or stamp them with a jittery clock. The strapdown integration must never run
silently across a gap, so :func:`regularize_imu` is applied where the IMU is parsed:

- **Out of order**: rows displaced by at most :data:`MAX_REORDER_ROWS` are put back in time
  order (a warning names how many and the first line); a larger jump backwards is refused.
- **Nominal interval**: the median interval of the time tags (the manifest's ``imu.rate_hz`` is
  cross-checked, a disagreement of more than 5 % is warned about).
- **Jitter**: an interval counts as a gap only when it exceeds 1.5 nominal intervals and is not
  made up by a short neighbour (one tag displaced by jitter), so time-tag jitter of microseconds
  to milliseconds is never flagged.
- **Short gaps** (at most :data:`MAX_BRIDGE_ROWS` missing rows) are bridged with rows on an even
  grid over the gap. Which of the two recorder behaviours happened is told by the size of the
  velocity increment of the row after the gap: its norm is dominated by gravity (g·Δt), so a row
  that *accumulated* the whole gap is k+1 times longer than its neighbours, while a row after
  *lost* rows has the normal length.

  * accumulated: the row's increments are split evenly over the k+1 intervals (the integrated
    increments are kept exactly);
  * lost: the k missing intervals get increments interpolated linearly between the rows before
    and after the gap (rate and specific force interpolated over the gap). Each bridged row spans
    one interval of the IMU's own sampling clock, never the tagged gap length over k + 1: the
    tags are the logger's and jitter about the sampling instants (the increments are those of
    the true intervals), so a rescaling would put the two edge tags' jitter into the gap's
    velocity (g·δt, 3 mm/s for 0.3 ms: an impulse no later step telescopes away, several mGal
    through a 200-s gravity filter and tens of mGal in a stop's mean; issue 29);
  * the turntable angle is interpolated linearly.

  A warning names the number of gaps, the missing rows and their times.
- **Long gaps** (more missing rows) are left in place and listed; the bundle stays readable (its
  quality report shows them), and every navigation refuses it through :func:`check_no_long_gaps`
  with a :class:`BundleError` naming ``imu.csv``, the line after the gap and its times.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ldvsurvey.errors import BundleError

#: rows displaced by at most this many places are put back in order
MAX_REORDER_ROWS = 10
#: gaps of at most this many missing rows (0.1 s at 100 Hz) are bridged; longer ones are refused.
#: Interpolating the rates over 0.1 s errs by ~1e-4 of a 1.5-Hz body bounce: negligible.
MAX_BRIDGE_ROWS = 10
#: an interval longer than this many nominal intervals is a gap
GAP_FACTOR = 1.5

INCREMENT_COLUMNS = ("dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z")


@dataclass
class LongGap:
    """A gap in the IMU time tags too long to bridge: the line after it, the times around it (s)."""

    line: int
    t_before_s: float
    t_after_s: float
    missing_rows: int

    def describe(self) -> str:
        """The gap in words: its length and times (s), the line after it and the missing rows."""
        return (
            f"{self.t_after_s - self.t_before_s:.3f} s between t={self.t_before_s:.3f} s and "
            f"t={self.t_after_s:.3f} s (line {self.line}, about {self.missing_rows} missing rows)"
        )


@dataclass
class BridgedGap:
    """A short gap bridged on an even grid: ``row`` the index (in the regular columns) of its first
    inserted row, ``rows`` how many were inserted; ``lost`` when their increments were interpolated
    (unknown: the gravity chains carry their uncertainty), False when the next row had accumulated
    the gap (split evenly, the sum kept exactly)."""

    row: int
    rows: int
    t_before_s: float
    t_after_s: float
    lost: bool


class RegularImu(NamedTuple):
    """``imu.csv`` in time order with its short gaps bridged (what :func:`regularize_imu` returns)."""

    cols: dict  #: column name -> (N,) array (``t`` s, increments rad and m/s, ``turntable_deg``)
    lines: np.ndarray  #: (N,) 1-based file line of each row (inserted rows: the line of the row after their gap)
    warnings: list[str]
    n_bridged_rows: int  #: rows inserted
    #: gaps too long to bridge, left as they are: :func:`check_no_long_gaps` refuses them before any
    #: integration, while the bundle itself stays readable for its quality report
    long_gaps: list[LongGap]
    bridged: list[BridgedGap]  #: the bridged gaps, in time order


def check_no_long_gaps(long_gaps, file: str = "imu.csv") -> None:
    """Raise a :class:`BundleError` naming the first gap too long to bridge (before integrating)."""
    if long_gaps:
        g = long_gaps[0]
        raise BundleError(
            f"gap of {g.describe()} in the IMU time tags; at most {MAX_BRIDGE_ROWS} missing rows are "
            "bridged: the strapdown integration cannot cross it (cut the log at the gap)",
            file=file,
            line=g.line,
            field="t",
        )


def _reorder(cols: dict, lines: np.ndarray, file: str):
    t = cols["t"]
    if not np.any(np.diff(t) < 0):
        return cols, lines, None
    order = np.argsort(t, kind="stable")
    disp = np.abs(order - np.arange(len(t)))
    i = int(np.flatnonzero(np.diff(t) < 0)[0]) + 1
    if disp.max() > MAX_REORDER_ROWS:
        raise BundleError(
            f"time goes backwards: {float(t[i])!r} s after {float(t[i - 1])!r} s on line "
            f"{int(lines[i - 1])} (more than {MAX_REORDER_ROWS} rows out of order: not a "
            "buffering slip)",
            file=file,
            line=int(lines[i]),
            field="t",
        )
    n = int(np.count_nonzero(disp))
    msg = (
        f"{file}: {n} row(s) out of time order (first at line {int(lines[i])}, t={float(t[i]):.3f} s) "
        "were put back in time order"
    )
    return {k: v[order] for k, v in cols.items()}, lines[order], msg


def nominal_interval(t_s: np.ndarray, rate_hz: float | None):
    """Nominal sampling interval (s): the median interval; and a warning when the manifest disagrees.

    Parameters
    ----------
    t_s : (N,) array
        Time tags, s.
    rate_hz : float or None
        The manifest's IMU rate, Hz.

    Returns
    -------
    (float, str or None)
        The median interval (s), and a warning when it differs from 1 / ``rate_hz`` by more than 5 %.
    """
    dt = float(np.median(np.diff(t_s)))
    warn = None
    if rate_hz and abs(dt * rate_hz - 1.0) > 0.05:
        warn = (
            f"imu.csv: the median time-tag interval {dt:.6f} s disagrees with manifest imu.rate_hz "
            f"{rate_hz} Hz; the median interval is used"
        )
    return dt, warn


def regularize_imu(cols: dict, lines: np.ndarray, rate_hz: float | None, file: str = "imu.csv") -> RegularImu:
    """Put rows in time order, bridge short gaps, refuse long ones (see the module docstring).

    Parameters
    ----------
    cols : dict
        Column name -> (N,) float array of ``imu.csv`` (``t`` in s, increments in rad and m/s, optional
        ``turntable_deg`` in deg).
    lines : (N,) array
        1-based file line of each row.
    rate_hz : float or None
        The manifest's nominal IMU rate, Hz.
    file : str
        The file named in messages.

    Returns
    -------
    RegularImu
        The regular columns and their lines, the warnings, how many rows were inserted, the gaps too long
        to bridge and the bridged gaps.
    """
    from ldvsurvey.io.csvtable import check_time

    warnings = []
    cols, lines, msg = _reorder(cols, lines, file)
    if msg:
        warnings.append(msg)
    t = cols["t"]
    check_time(t, lines, file)
    if len(t) < 3:
        return RegularImu(cols, lines, warnings, 0, [], [])
    dt_nom, msg = nominal_interval(t, rate_hz)
    if msg:
        warnings.append(msg)
    gaps = _gaps(t, dt_nom)
    if len(gaps) == 0:
        return RegularImu(cols, lines, warnings, 0, [], [])
    k_missing = np.rint(np.diff(t)[gaps] / dt_nom).astype(int) - 1
    k_missing = np.maximum(k_missing, 1)
    long_ = k_missing > MAX_BRIDGE_ROWS
    long_gaps = [
        LongGap(int(lines[g + 1]), float(t[g]), float(t[g + 1]), int(k)) for g, k in zip(gaps[long_], k_missing[long_])
    ]
    if long_gaps:
        warnings.append(
            f"{file}: {len(long_gaps)} gap(s) in the IMU time tags too long to bridge (more than "
            f"{MAX_BRIDGE_ROWS} missing rows), the first {long_gaps[0].describe()}: navigation "
            "pipelines refuse this log"
        )
    gaps, k_missing = gaps[~long_], k_missing[~long_]
    if len(gaps) == 0:
        return RegularImu(cols, lines, warnings, 0, long_gaps, [])
    out, new_lines, times = _bridge(cols, lines, gaps, k_missing)
    bridged = _keep_accumulated_shares(out, t, gaps, k_missing, times)
    warnings.append(_bridged_warning(file, times, int(k_missing.sum())))
    return RegularImu(out, new_lines, warnings, int(k_missing.sum()), long_gaps, bridged)


def _gaps(t: np.ndarray, dt_nom: float) -> np.ndarray:
    """Indices ``g`` of the intervals (t[g], t[g+1]] longer than :data:`GAP_FACTOR` nominal intervals (s) that
    no short neighbour makes up (a tag displaced by jitter lengthens one interval and shortens its neighbour)."""
    dt = np.diff(t)
    gaps = np.flatnonzero(dt > GAP_FACTOR * dt_nom)
    if len(gaps):
        pair_next = np.rint((dt[gaps] + dt[np.minimum(gaps + 1, len(dt) - 1)]) / dt_nom)
        pair_prev = np.rint((dt[gaps] + dt[np.maximum(gaps - 1, 0)]) / dt_nom)
        jitter = ((pair_next <= 2) & (gaps + 1 < len(dt))) | ((pair_prev <= 2) & (gaps > 0))
        gaps = gaps[~jitter]
    return gaps


def _accumulated(dv_norm: np.ndarray, gaps: np.ndarray, g: int, k: int) -> bool:
    """Whether the row after gap ``g`` (``k`` rows missing) accumulated the gap: its velocity increment (m/s)
    is nearer k + 1 times its neighbours' than once."""
    nb = np.r_[np.arange(max(0, g - 3), g + 1), np.arange(g + 2, min(len(dv_norm), g + 5))]
    nb = nb[~np.isin(nb, gaps + 1)]  # neighbours that follow no gap themselves
    ref = float(np.median(dv_norm[nb])) if len(nb) else float(np.median(dv_norm))
    ratio = dv_norm[g + 1] / ref if ref > 0 else 1.0
    return abs(ratio - (k + 1)) < abs(ratio - 1.0)


def _gap_rows(name: str, col: np.ndarray, g: int, k: int, t_new: np.ndarray, accumulated: bool) -> np.ndarray:
    """The ``k`` rows of column ``name`` inserted into gap ``g`` (time s, turntable deg, increments rad or m/s)."""
    if name == "t":
        return t_new
    if name == "turntable_deg":
        a = col[g]
        b = a + (np.mod(col[g + 1] - a + 180.0, 360.0) - 180.0)
        return np.mod(a + (b - a) * np.arange(1, k + 1) / (k + 1), 360.0)
    if accumulated:  # the row after the gap keeps its share too (_keep_accumulated_shares)
        return np.full(k, col[g + 1] / (k + 1))
    w = np.arange(1, k + 1) / (k + 1)  # each lost row spans one interval of the IMU's own clock, whatever the tags say
    return (1 - w) * col[g] + w * col[g + 1]


def _bridge(cols: dict, lines: np.ndarray, gaps: np.ndarray, k_missing: np.ndarray):
    """The columns and lines with ``k`` rows on an even grid in every short gap; and (t before s, k, accumulated)
    of each gap."""
    t = cols["t"]
    dv = np.column_stack([cols[c] for c in ("dvel_x", "dvel_y", "dvel_z")])
    dv_norm = np.linalg.norm(dv, axis=1)
    pieces = {k: [] for k in cols}
    line_pieces = []
    start = 0
    times = []
    for g, k in zip(gaps, k_missing):
        g = int(g)
        accumulated = _accumulated(dv_norm, gaps, g, k)
        h = (t[g + 1] - t[g]) / (k + 1)
        t_new = t[g] + h * np.arange(1, k + 1)
        for name in cols:
            pieces[name].append(cols[name][start : g + 1])
            pieces[name].append(_gap_rows(name, cols[name], g, k, t_new, accumulated))
        line_pieces += [lines[start : g + 1], np.full(k, lines[g + 1])]
        start = g + 1
        times.append((float(t[g]), int(k), accumulated))
    for name in cols:
        pieces[name].append(cols[name][start:])
    line_pieces.append(lines[start:])
    return {name: np.concatenate(p) for name, p in pieces.items()}, np.concatenate(line_pieces), times


def _keep_accumulated_shares(out: dict, t: np.ndarray, gaps, k_missing, times: list) -> list[BridgedGap]:
    """Give the row after each accumulated gap its 1/(k+1) share (in place); the :class:`BridgedGap` s."""
    offset = 0
    bridged = []
    for (g, k), (_, _, acc) in zip(zip(gaps, k_missing), times):
        row = int(g) + 1 + offset + int(k)
        bridged.append(BridgedGap(row - int(k), int(k), float(t[g]), float(t[g + 1]), not acc))
        if acc:
            for name in INCREMENT_COLUMNS:
                if name in out:
                    out[name][row] = out[name][row] / (k + 1)
        offset += int(k)
    return bridged


def _bridged_warning(file: str, times: list, total: int) -> str:
    """The warning naming the bridged gaps (the first ten by time), the missing rows and how each was bridged."""
    lost = sum(not acc for _, _, acc in times)
    listed = ", ".join(f"t={a:.3f} s ({k} row{'s' if k > 1 else ''})" for a, k, _ in times[:10])
    more = f" and {len(times) - 10} more" if len(times) > 10 else ""
    how = []
    if lost:
        how.append(f"{lost} with lost increments interpolated linearly between the neighbouring rows")
    if len(times) - lost:
        how.append(f"{len(times) - lost} whose next row accumulated the gap, split evenly over it")
    return (
        f"{file}: {len(times)} gap(s) in the IMU time tags bridged, {total} missing row(s) in all, "
        f"after {listed}{more}; {'; '.join(how)}"
    )
