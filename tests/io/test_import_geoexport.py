"""GeoJSON and KML of result tables, parsed back with independent libraries."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.writers import table_geojson, table_kml
from ldvsurvey.pipelines.base import table_csv

SUMMARY = {
    "pipeline": "gravity",
    "software_version": "0.1.0",
    "format_version": "ldv-drive-log/1",
    "inputs": [{"bundle": "b", "file": "imu.csv", "sha256": "ab" * 32}],
    "parameters": {"fir_length_s": 150.0},
    "lines": [{"name": "L1", "rms_mgal": 0.4}, {"name": "L2", "rms_mgal": 0.5}],
}


def _gravity_table():
    n = 200
    t = 30000.0 + np.arange(n)
    lat = 28.4 + 1e-4 * np.arange(n)
    lon = 113.0 + 2e-4 * np.arange(n)
    return {
        "t_s": t,
        "line": ["L1"] * 100 + ["L2"] * 100,
        "distance_m": np.arange(n) * 15.0,
        "lat_deg": lat,
        "lon_deg": lon,
        "h_m": np.full(n, 150.0),
        "dg_raw_mgal": np.sin(t),
        "dg_mgal": np.cos(t),
    }


def test_geojson_lines_and_points_valid_and_lon_lat():
    geojson = pytest.importorskip("geojson")
    shapely_geometry = pytest.importorskip("shapely.geometry")
    cols = _gravity_table()
    data = table_geojson("gravity", table_csv(cols), SUMMARY)
    assert geojson.loads(data.decode()).is_valid
    fc = json.loads(data)
    lines = [f for f in fc["features"] if f["geometry"]["type"] == "LineString"]
    points = [f for f in fc["features"] if f["geometry"]["type"] == "Point"]
    assert [f["properties"]["name"] for f in lines] == ["L1", "L2"]
    assert lines[1]["properties"]["rms_mgal"] == 0.5
    assert len(points) == 200
    for f in fc["features"]:
        assert shapely_geometry.shape(f["geometry"]).is_valid
    p = points[7]
    assert p["geometry"]["coordinates"][:2] == pytest.approx([cols["lon_deg"][7], cols["lat_deg"][7]])
    assert p["properties"]["dg_mgal"] == pytest.approx(cols["dg_mgal"][7])
    assert fc["provenance"]["inputs"][0]["sha256"] == "ab" * 32
    assert fc["provenance"]["parameters"] == {"fir_length_s": 150.0}


def test_kml_parses_with_fastkml_and_carries_provenance():
    fastkml = pytest.importorskip("fastkml")
    from lxml import etree

    data = table_kml("gravity", table_csv(_gravity_table()), SUMMARY)
    root = etree.fromstring(data)
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    assert root.tag == "{http://www.opengis.net/kml/2.2}kml"
    marks = root.findall(".//k:Placemark", ns)
    assert len(marks) == 202
    first_line = marks[0].find(".//k:LineString/k:coordinates", ns).text.split()
    lon, lat = map(float, first_line[0].split(","))
    assert (lon, lat) == pytest.approx((113.0, 28.4))
    prov = {d.get("name"): d.find("k:value", ns).text for d in root.find("k:Document/k:ExtendedData", ns)}
    assert prov["pipeline"] == "gravity" and "ab" * 32 in prov["inputs"]
    import os

    xsd = os.path.join(os.path.dirname(fastkml.__file__), "schema", "ogckml22.xsd")  # the OGC schema fastkml ships
    schema = etree.XMLSchema(etree.parse(xsd))
    assert schema.validate(root), schema.error_log
    k = fastkml.KML.from_string(data)
    doc = list(k.features)[0]
    assert doc.name == "gravity"


def test_table_without_positions_is_placed_on_the_gnss_track():
    cols = {"t_s": np.array([10.0, 15.0, 20.0, 99.0]), "h_m": np.array([1.0, 2.0, 3.0, 4.0])}
    track = {"t_s": np.array([0.0, 20.0]), "lat_deg": np.array([10.0, 12.0]), "lon_deg": np.array([20.0, 24.0])}
    fc = json.loads(table_geojson("height", table_csv(cols), SUMMARY, track))
    pts = [f["geometry"]["coordinates"] for f in fc["features"]]
    assert len(pts) == 3  # the sample outside the track is left out, not extrapolated
    assert pts[1] == pytest.approx([23.0, 11.5, 2.0])


def test_cli_run_writes_geojson(tmp_path):
    """``ldv-survey run navigate ... --format geojson`` writes trajectory.geojson beside the CSV."""
    from ldvsurvey.io.writers import write_bundle
    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, simulate

    sim = simulate(catalog.drive(minutes=2.5, static_s=30.0), seed=8)
    write_bundle(bundle_files(sim), tmp_path / "b.zip")
    rc = main(
        [
            "run",
            "navigate",
            str(tmp_path / "b.zip"),
            "--out",
            str(tmp_path / "out"),
            "--format",
            "geojson",
            "--set",
            "aiding=ldv+gnss",
        ]
    )
    assert rc == 0
    fc = json.loads((tmp_path / "out" / "trajectory.geojson").read_text())
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert fc["provenance"]["inputs"] == summary["inputs"]
    assert fc["features"][0]["geometry"]["type"] == "LineString"
