"""The network's line weights: each log's combined floor (white noise and accelerometer drift).

The single-log summary states the floor of the coincidence as the root-sum-square of the sensors'
white noise and the drift the manifest's bias instability leaves after the processing
(:func:`gravity_floor.drift_floor`, :func:`gravity_floor.combine`). The network weights every line
by 1/σ² of its log's floor: with the white part alone, a log whose accelerometer wanders gets the
weight of a steady one, its residuals come out several σ, and it pulls the steady logs towards it
at the crossings and repeats. Here each log's floor is its own combined one.
"""

from __future__ import annotations

from ldvsurvey.pipelines.gravity_floor import combine, drift_floor
from ldvsurvey.pipelines.gravity_report import floor_of


def network_floors(logs, chains, res, params, drift_reports, first_drift=None) -> tuple[list[float], list[dict]]:
    """Per log, the 1-σ (mGal) of one filtered line value the network weights its lines by.

    Parameters
    ----------
    logs, chains : list
        The run's logs and their primary chains, in bundle order.
    res : dict
        :func:`gravity_report.evaluate`'s result (the lines of every bundle).
    params : dict
        The gravity parameters (``fir_length_s`` s, ``spacing_m`` m, ``line_leveling``).
    drift_reports : list of dict
        Per log, the stop-tie drift correction's report (``method`` "repeated stops" when applied).
    first_drift : dict, optional
        The first log's :func:`drift_floor` result when already computed (the summary's).

    Returns
    -------
    tuple
        (combined floor per log in mGal, per log ``{"log", "white_mgal", "drift_mgal", "combined_mgal"}``).
    """
    fir_s = params["fir_length_s"]
    floors, rows = [], []
    for i, (log, ch) in enumerate(zip(logs, chains)):
        if i == 0 and first_drift is not None:
            drift = first_drift
        else:
            tied = drift_reports[i].get("method") == "repeated stops"
            drift = drift_floor(log, ch, res, fir_s, params["spacing_m"], tied, params["line_leveling"], bundle=i)
        c = combine(floor_of(log, ch, fir_s), drift)
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
