"""The network's line weights: each log's combined floor (white noise and accelerometer drift).

The single-log summary states the floor of the coincidence as the root-sum-square of the sensors'
white noise and the drift the manifest's bias instability leaves after the processing
(:func:`floor.drift_floor`, :func:`floor.combine`). The network weights every line by 1/σ² of its
log's floor: with the white part alone, a log whose accelerometer wanders gets the weight of a
steady one, its residuals come out several σ, and it pulls the steady logs towards it at the
crossings and repeats. Here each log's floor is its own combined one.
"""

from __future__ import annotations

from ldvsurvey.pipelines.gravity.floor import combine, drift_floor
from ldvsurvey.pipelines.gravity.report import floor_of


def network_floors(rs, cs, res) -> tuple[list[float], list[dict]]:
    """Per log, the 1-σ (mGal) of one filtered line value the network weights its lines by.

    Parameters
    ----------
    rs : pipeline.RunSetup
        The run's logs, parameters (``spacing_m`` m, ``line_leveling``) and low-pass filter.
    cs : pipeline.ChainSet
        Per log, the main chain (drift removed), the stop-tie drift correction's report
        (``drift_reports``: ``method`` "repeated stops" when applied) and the first log's
        :func:`floor.drift_floor` result when the summary already computed it (``first_drift``).
    res : report.Evaluation
        :func:`report.evaluate`'s result (the lines of every log).

    Returns
    -------
    tuple
        (combined floor per log in mGal, per log ``{"log", "white_mgal", "drift_mgal", "combined_mgal"}``).
    """
    params, lowpass = rs.params, rs.lowpass
    floors, rows = [], []
    for i, (log, ch) in enumerate(zip(rs.logs, cs.main)):
        if i == 0 and cs.first_drift is not None:
            drift = cs.first_drift
        else:
            tied = cs.drift_reports[i].get("method") == "repeated stops"
            kw = {"tie_applied": tied, "leveling": params.line_leveling, "bundle": i}
            drift = drift_floor(log, ch, res, lowpass, params.spacing_m, **kw)
        c = combine(floor_of(log, ch, lowpass), drift)
        floors.append(float(c["combined_mgal"]))
        rows.append(
            {
                "log": f"B{i + 1}",
                "white_mgal": c["white_mgal"],
                "drift_mgal": c.get("drift_mgal"),
                "combined_mgal": c["combined_mgal"],
            }
        )
    return floors, rows
