"""Server-side comparison of gravity lines against known differences."""

import numpy as np
import pytest

from ldvsurvey.store.db import session_scope
from ldvsurvey.store.models import Job, JobFile
from tests.bundles import make_bundle


def _coincidence(lines: dict) -> bytes:
    rows = ["line,distance_m,dg_mgal,mean_mgal,residual_mgal"]
    for name, (d, g) in lines.items():
        rows += [f"{name},{a:.3f},{b:.6f},0,0" for a, b in zip(d, g)]
    return ("\n".join(rows) + "\n").encode()


@pytest.fixture
def jobs(client):
    log_id = client.post(
        "/api/logs", files=[("files", (n, d, "x")) for n, d in make_bundle(seed=70, n_imu=300).items()]
    ).json()["id"]
    d = np.arange(0.0, 1000.0 + 1e-9, 10.0)
    ref = {"L1": (d, 5 * np.sin(d / 100)), "L2": (d, np.cos(d / 80))}
    # job b: L1 offset by +0.5 mGal on a shorter stretch; L2 on a grid 5 m off, linear in d
    d2 = np.arange(200.0, 800.0 + 1e-9, 10.0)
    db = np.arange(5.0, 995.0 + 1e-9, 10.0)
    other = {"L1": (d2, 5 * np.sin(d2 / 100) + 0.5), "L2": (db, 0.001 * db)}
    ids = []
    with session_scope(client.app_state.database_url) as s:
        for lines in (ref, other):
            j = Job(
                pipeline="gravity",
                log_ids=[log_id],
                parameters={},
                status="succeeded",
                stage="done",
                progress=100,
                summary={},
            )
            s.add(j)
            s.flush()
            s.add(JobFile(job_id=j.id, name="coincidence.csv", size_bytes=1, content=_coincidence(lines)))
            ids.append(j.id)
    return ids, d


def test_compare_statistics_and_csv(client, jobs):
    (a, b), d = jobs
    r = client.get(f"/api/compare?jobs={a},{b}")
    assert r.status_code == 200, r.text
    st = {s["line"]: s for s in r.json()["statistics"]}
    assert st["L1"]["n_common"] == 61 and st["L1"]["distance_range_m"] == [200.0, 800.0]
    assert st["L1"]["mean_mgal"] == pytest.approx(0.5, abs=1e-6) and st["L1"]["std_mgal"] < 1e-6
    # L2: b is linear, so interpolation is exact; common points are the reference's inside [5, 995]
    k = (d >= 5) & (d <= 995)
    truth = 0.001 * d[k] - np.cos(d[k] / 80)
    assert st["L2"]["n_common"] == k.sum()
    assert st["L2"]["mean_mgal"] == pytest.approx(truth.mean(), abs=1e-5)
    assert st["L2"]["rms_mgal"] == pytest.approx(np.sqrt(np.mean(truth**2)), abs=1e-5)
    assert st["all"]["n_common"] == 61 + k.sum()
    csv = client.get(f"/api/compare/csv?jobs={a},{b}")
    assert csv.status_code == 200 and csv.headers["content-type"].startswith("text/csv")
    lines = csv.text.strip().split("\n")
    assert lines[0] == "job,line,distance_m,dg_reference_mgal,dg_job_mgal,diff_mgal"
    assert len(lines) - 1 == 61 + k.sum()
    view = client.get(f"/api/compare/view?jobs={a},{b}").json()
    assert view["layout"]["xaxis"]["title"]["text"] and view["layout"]["yaxis2"]["title"]["text"]
    assert any(t.get("yaxis") == "y2" for t in view["data"])


def test_compare_refuses_bad_requests(client, jobs):
    (a, b), _ = jobs
    assert client.get("/api/compare?jobs=").status_code == 422
    assert client.get(f"/api/compare?jobs={a}").json()["statistics"] == []  # one job: nothing to difference
    assert client.get(f"/api/compare?jobs={a},x").status_code == 422
    assert client.get(f"/api/compare?jobs={a},999999").status_code == 404


def test_compare_panels_have_their_own_axes_and_one_job_asks_for_another(client, jobs):
    """Issue 26: the x title sat over the lower panel's curves and that panel had no tick labels (the
    one x axis was anchored to the upper panel); one job said 'no common points'."""
    (a, b), _ = jobs
    lay = client.get(f"/api/compare/view?jobs={a},{b}").json()["layout"]
    low, up = lay["yaxis2"]["domain"], lay["yaxis"]["domain"]
    assert low[1] < up[0]  # the differences below, the lines above
    # the titled x axis sits under the lower panel (its tick labels there), the upper panel has its own
    # tick labels on an axis matched to it
    assert lay["xaxis"]["anchor"] == "y2" and lay["yaxis2"]["anchor"] == "x"
    assert lay["xaxis"]["title"]["text"] == "along-track distance (m)"
    assert lay["xaxis2"]["anchor"] == "y" and lay["xaxis2"]["matches"] == "x" and lay["xaxis2"]["showticklabels"]
    assert lay["yaxis"]["anchor"] == "x2"
    fig = client.get(f"/api/compare/view?jobs={a},{b}").json()
    for t in fig["data"]:  # the lines on the upper panel, the differences on the lower one
        assert (t.get("xaxis"), t.get("yaxis")) in (("x2", None), (None, "y2"))
    one = client.get(f"/api/compare/view?jobs={a}").json()["layout"]["title"]["text"]
    assert "no common points" not in one and "second" in one and f"job {a}" in one
