"""The project map of a gravity network (api/views.py ``gravity_network_map``): shown only for jobs that
adjusted a network, the adjusted values and the ties where the tables put them."""

import numpy as np

from ldvsurvey.api import views
from tests.api.helpers import NETWORK


def view_input(tables, summary, n=1000):
    """The map view's input on in-memory tables (it may read only the files it declares)."""
    return views.ViewInput(views.DictTables(tables), summary, None, None, n, views.VIEWS["gravity_network_map"].files)


def test_the_map_view_applies_to_network_jobs_only():
    names = [v.name for v in views.views_of("gravity", {"total_mgal": 0.3})]
    assert "gravity_network_map" not in names and "gravity_lines" in names
    assert "gravity_network_map" in [v.name for v in views.views_of("gravity", {"network": {}})]


def test_the_map_shows_adjusted_values_and_ties():
    lat = 28.5 + np.linspace(0, 0.01, 50)
    lon = np.full(50, 113.0)
    g = {
        "lat_deg": lat,
        "lon_deg": lon,
        "dg_mgal": np.linspace(1, 5, 50),
        "sigma_mgal": np.full(50, 0.4),
        "line": np.array(["B1-L1"] * 50, dtype=object),
    }
    r = {
        "kind": np.array(["repeat", "tie"], dtype=object),
        "line": np.array(["B1-L1", "T1"], dtype=object),
        "lat_deg": np.array([28.505, 28.5]),
        "lon_deg": np.array([113.0, 113.0]),
        "residual_mgal": np.array([0.1, -0.2]),
    }
    summary = NETWORK  # ties datum ±0.10 mGal, resolution 1966 m
    fig = views.VIEWS["gravity_network_map"].build(
        view_input({"gravity_adjusted.csv": g, "network_residuals.csv": r}, summary, n=20)
    )
    pts, ties = fig["data"]
    assert len(pts["x"]) == 20  # thinned to the requested count
    north = np.array(pts["y"])
    assert north[-1] - north[0] > 1000.0  # 0.01° of latitude northwards
    assert ties["text"] == ["T1: -0.20 mGal"] and len(ties["x"]) == 1
    assert "1966" in fig["layout"]["title"]["text"] and "ties datum ±0.10" in fig["layout"]["title"]["text"]
