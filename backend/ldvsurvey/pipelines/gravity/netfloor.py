"""The network's line weights: each log's combined floor (white noise and accelerometer drift).

The single-log summary states the floor of the coincidence as the root-sum-square of the sensors'
white noise and the drift the manifest's bias instability leaves after the processing
(:func:`floor.drift_floor`, :func:`floor.combine`). The network weights every line by 1/σ² of its
log's floor: with the white part alone, a log whose accelerometer wanders gets the weight of a
steady one, its residuals come out several σ, and it pulls the steady logs towards it at the
crossings and repeats. Here each log's floor is its own combined one.

The drift's Monte Carlo runs through the processing the network applies: with a bias per line
(``network_line_bias``, the default) each line's mean is the adjustment's, so the slow drift a line's
bias absorbs is no error of the line (the Monte Carlo's ``leveling="bias"``, which removes each line's
mean); without it, the line levelling given (the network forces ``line_leveling=none``).
"""

from __future__ import annotations

from ldvsurvey.pipelines.gravity.floor import combine, drift_floor
from ldvsurvey.pipelines.gravity.report import floor_of


def network_leveling(params) -> str:
    """The line levelling the drift Monte Carlo applies for the network: "bias" where the network fits a
    bias per line (it absorbs each line's mean, as the Monte Carlo's "bias" levelling removes it), else the
    given ``line_leveling``."""
    return "bias" if params.network_line_bias else params.line_leveling


def network_floors(rs, cs, res) -> tuple[list[float], list[dict]]:
    """Per log, the 1-σ (mGal) of one filtered line value the network weights its lines by.

    Parameters
    ----------
    rs : pipeline.RunSetup
        The run's logs, parameters (``spacing_m`` m, ``network_line_bias``, ``line_leveling``) and low-pass
        filter.
    cs : pipeline.ChainSet
        Per log, the main chain (drift removed), the stop-tie drift correction's report
        (``drift_reports``: ``method`` "repeated stops" when applied) and the first log's
        :func:`floor.drift_floor` result when the summary already computed it (``first_drift``).
    res : report.Evaluation
        :func:`report.evaluate`'s result (the lines of every log).

    Returns
    -------
    tuple
        (combined floor per log in mGal, per log ``{"log", "white_mgal", "drift_mgal", "drift_mgal_spread",
        "combined_mgal", "drift_source"}`` (the spread: of the drift's coincidence over the Monte Carlo's
        realisations, mGal) and ``drift_warning`` where the drift term is missing or not the manifest's).
    """
    params, lowpass = rs.params, rs.lowpass
    leveling = network_leveling(params)
    floors, rows = [], []
    for i, (log, ch) in enumerate(zip(rs.logs, cs.main)):
        if i == 0 and cs.first_drift is not None and leveling == params.line_leveling:
            drift = cs.first_drift  # the summary's, through the same processing
        else:
            tied = cs.drift_reports[i].get("method") == "repeated stops"
            kw = {"tie_applied": tied, "leveling": leveling, "bundle": i}
            drift = drift_floor(log, ch, res, lowpass, params.spacing_m, **kw)
        c = combine(floor_of(log, ch, lowpass), drift)
        floors.append(float(c["combined_mgal"]))
        rows.append(
            {
                "log": f"B{i + 1}",
                "white_mgal": c["white_mgal"],
                "drift_mgal": c.get("drift_mgal"),
                "drift_mgal_spread": c.get("drift_mgal_spread"),
                "combined_mgal": c["combined_mgal"],
                "drift_source": c.get("drift_source"),
                **({"drift_warning": c["drift_warning"]} if c.get("drift_warning") else {}),
            }
        )
    return floors, rows
