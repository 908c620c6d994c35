"""``/api/compare``: gravity lines of several gravity jobs compared on the server.

The first job is the reference. For each line present in the reference and another job, the
common points are the reference's along-track distances inside the other job's distance range
on that line; the other job's δg is linearly interpolated there. Differences are other − reference.
"""

from __future__ import annotations

import io

import numpy as np
from fastapi import APIRouter, HTTPException, Query, Response
from sqlalchemy.orm import Session

from ldvsurvey.api import models as m
from ldvsurvey.api.auth import CurrentUser, Principal, visible_job
from ldvsurvey.api.deps import ID_MAX, SessionDep
from ldvsurvey.api.views import fit_title, title_layout, title_margin

router = APIRouter(tags=["compare"])
JOBS_Q = Query(
    ..., description="gravity job ids, comma-separated; the first is the reference", examples=["3,5"], max_length=400
)


def _ids(jobs: str) -> list[int]:
    try:
        ids = [int(x) for x in jobs.split(",") if x.strip()]
    except ValueError:
        raise HTTPException(422, "jobs: give job ids separated by commas, e.g. 3,5") from None
    ids = list(dict.fromkeys(ids))
    if not 1 <= len(ids) <= 20 or not all(1 <= i <= ID_MAX for i in ids):
        raise HTTPException(422, "jobs: give 1 to 20 distinct job ids (the first is the reference)")
    return ids


def _lines(session, job) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    from ldvsurvey.api.tables import JobTables
    from ldvsurvey.api.views import MissingResult

    try:
        c = JobTables(session, job).csv("coincidence.csv")
    except MissingResult as e:
        raise HTTPException(404, str(e)) from None
    out = {}
    for name in sorted(set(c["line"].tolist())):
        k = c["line"] == name
        d, g = c["distance_m"][k], c["dg_mgal"][k]
        order = np.argsort(d, kind="stable")
        out[str(name)] = (d[order], g[order])
    return out


def _stats(x: np.ndarray) -> dict:
    if len(x) == 0:
        return {"n_common": 0, "mean_mgal": None, "std_mgal": None, "rms_mgal": None, "max_abs_mgal": None}
    return {
        "n_common": int(len(x)),
        "mean_mgal": float(np.mean(x)),
        "std_mgal": float(np.std(x)),
        "rms_mgal": float(np.sqrt(np.mean(x * x))),
        "max_abs_mgal": float(np.max(np.abs(x))),
    }


def compare_jobs(session: Session, who: Principal, ids: list[int]) -> dict:
    """The gravity lines of jobs compared with the first job's at their common points.

    Parameters
    ----------
    session : Session
        The request's session.
    who : Principal
        The caller (every job must be visible to them).
    ids : list of int
        The jobs, the first the reference.

    Returns
    -------
    dict
        ``reference_job``, ``jobs``, ``statistics`` of the differences (mGal) per job and line and
        over all lines, and ``points``: (job, line, distance along the line in m, δg of the
        reference and of the job and their difference in mGal).

    Raises
    ------
    HTTPException
        404 for a job the caller cannot see or without line results, 409 for a job not succeeded,
        422 for a job other than a gravity job.
    """
    jobs = []
    for i in ids:
        j = visible_job(session, who, i)
        if j.pipeline != "gravity":
            raise HTTPException(422, f"job {i} is a {j.pipeline} job: only gravity jobs have lines to compare")
        if j.status != "succeeded":
            raise HTTPException(409, f"job {i} is {j.status}: it has no lines to compare yet")
        jobs.append(j)
    ref = _lines(session, jobs[0])
    points, stats = [], []
    for j in jobs[1:]:
        other = _lines(session, j)
        all_diff = []
        for name, (d_ref, g_ref) in ref.items():
            if name not in other:
                continue
            d_o, g_o = other[name]
            k = (d_ref >= d_o[0]) & (d_ref <= d_o[-1])
            g_at = np.interp(d_ref[k], d_o, g_o)
            diff = g_at - g_ref[k]
            all_diff.append(diff)
            stats.append(
                {
                    "job": j.id,
                    "line": name,
                    **_stats(diff),
                    "distance_range_m": [float(d_ref[k][0]), float(d_ref[k][-1])] if k.any() else None,
                }
            )
            points += [
                (j.id, name, float(a), float(b), float(c), float(e))
                for a, b, c, e in zip(d_ref[k], g_ref[k], g_at, diff)
            ]
        stats.append({"job": j.id, "line": "all", **_stats(np.concatenate(all_diff) if all_diff else np.array([]))})
    return {"reference_job": ids[0], "jobs": ids, "statistics": stats, "points": points}


@router.get(
    "/api/compare",
    summary="Compare gravity lines of jobs: statistics of the differences",
    response_model_exclude_unset=True,
)
def compare(session: SessionDep, who: CurrentUser, jobs: str = JOBS_Q) -> m.Comparison:
    """Statistics (mGal) of the differences of the gravity disturbance δg of jobs to the first job's,
    at common points along the lines, per line and over all. 404 for a job the caller cannot see or
    without line results; 409 for a job not succeeded; 422 for malformed ids (1 to 20 distinct ones)
    or a job other than a gravity job.
    """
    out = compare_jobs(session, who, _ids(jobs))
    out.pop("points")
    return out


@router.get(
    "/api/compare/csv",
    summary="The common points and their differences as CSV",
    response_class=Response,
    responses={200: {"content": {"text/csv": {}}, "description": "CSV table"}},
)
def compare_csv(session: SessionDep, who: CurrentUser, jobs: str = JOBS_Q) -> Response:
    """The common points of the compared jobs as a CSV attachment: job, line, distance along the line (m), δg of the
    reference and of the job and their difference (mGal). Errors as ``GET /api/compare``."""
    out = compare_jobs(session, who, _ids(jobs))
    buf = io.StringIO()
    buf.write("job,line,distance_m,dg_reference_mgal,dg_job_mgal,diff_mgal\n")
    for j, line, d, a, b, c in out["points"]:
        buf.write(f"{j},{line},{d:.3f},{a:.6f},{b:.6f},{c:.6f}\n")
    name = "compare_" + "_".join(map(str, out["jobs"])) + ".csv"
    return Response(
        buf.getvalue(), media_type="text/csv", headers={"Content-Disposition": f'attachment; filename="{name}"'}
    )


@router.get("/api/compare/view", summary="Plotly figure: δg of every job and the differences to the reference")
def compare_view(session: SessionDep, who: CurrentUser, jobs: str = JOBS_Q) -> m.Figure:
    """A Plotly figure of the compared jobs: every job's δg along the lines above, the differences to the reference
    below (mGal against distance, m). Errors as ``GET /api/compare``."""
    ids = _ids(jobs)
    out = compare_jobs(session, who, ids)
    return compare_figure(ids, out, {i: _lines(session, visible_job(session, who, i)) for i in ids})


def compare_figure(ids: list[int], out: dict, lines: dict[int, dict]) -> dict:
    """Two panels on one along-track axis: every job's δg above (x axis ``x2``, tick labels shown) and
    the differences to the reference below (x axis ``x``, its title under the lower panel)."""
    traces = []
    for i in ids:
        for name, (d, g) in lines[i].items():
            traces.append(
                {
                    "type": "scatter",
                    "mode": "lines",
                    "name": f"job {i} {name}",
                    "x": d.tolist(),
                    "y": g.tolist(),
                    "legendgroup": f"job {i}",
                    "xaxis": "x2",
                }
            )
    pts = out["points"]
    for j in ids[1:]:
        for name in dict.fromkeys(p[1] for p in pts if p[0] == j):
            sel = [p for p in pts if p[0] == j and p[1] == name]
            traces.append(
                {
                    "type": "scatter",
                    "mode": "lines",
                    "name": f"job {j} − job {ids[0]}, {name}",
                    "x": [p[2] for p in sel],
                    "y": [p[5] for p in sel],
                    "yaxis": "y2",
                    "line": {"dash": "dot"},
                }
            )
    allrows = [s for s in out["statistics"] if s["line"] == "all" and s["n_common"]]
    sub = "; ".join(
        f"job {s['job']} − job {ids[0]}: mean {s['mean_mgal']:.2f}, std {s['std_mgal']:.2f} mGal" for s in allrows
    )
    if len(ids) < 2:
        sub = f"job {ids[0]} alone: tick a second gravity job to compare against it"
    elif not sub:
        sub = "the jobs have no line in common"
    title = fit_title(f"Gravity lines compared<br>{sub}")
    return {
        "data": traces,
        "layout": {
            "title": title_layout(title),
            "xaxis": {"title": {"text": "along-track distance (m)"}, "anchor": "y2"},
            "xaxis2": {"matches": "x", "anchor": "y", "showticklabels": True},
            "yaxis": {"title": {"text": "δg (mGal)"}, "domain": [0.45, 1.0], "anchor": "x2"},
            "yaxis2": {"title": {"text": "difference (mGal)"}, "domain": [0.0, 0.33], "anchor": "x"},
            "margin": {"t": title_margin(title), "r": 20, "b": 110},
            "legend": {"orientation": "h", "y": -0.25},
        },
    }
