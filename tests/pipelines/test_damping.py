"""damping on the damping paper's vessel scenario (moored start, 0.1°/s turn, 1 m/s², hours straight)."""

import json

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.writers import write_bundle
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate

SCHULER_S = 2 * np.pi * np.sqrt(6.371e6 / 9.8)


@pytest.fixture(scope="module")
def paper_run():
    sim = simulate(catalog.vessel(hours=3.0, current_mps=2.0), seed=5)
    return sim, run_pipeline(get("damping"), [parse_files(bundle_files(sim))], {})


@pytest.mark.slow
def test_delayed_state_beats_conventional_by_84_percent(paper_run):
    s = paper_run[1].summary
    assert s["position_improvement_pct"] >= 84.0 and s["velocity_improvement_pct"] >= 84.0
    # the conventional filter takes the 2 m/s current as a velocity error
    assert s["conventional"]["rms_velocity_error_mps"] > 1.0
    assert s["delayed_state"]["rms_position_error_m"] < s["undamped"]["rms_position_error_m"]


@pytest.mark.slow
def test_undamped_shows_the_schuler_oscillation(paper_run):
    tab = paper_run[1].tables["damping"]
    t = tab["t_s"] - tab["t_s"][0]
    ve = tab["undamped_north_velocity_error_mps"]
    k = t > 600  # after the manoeuvres
    t, ve = t[k], ve[k] - ve[k].mean()

    def explained(period):
        a = np.column_stack([np.sin(2 * np.pi * t / period), np.cos(2 * np.pi * t / period), np.ones_like(t)])
        res = ve - a @ np.linalg.lstsq(a, ve, rcond=None)[0]
        return 1 - np.var(res) / np.var(ve)

    assert explained(SCHULER_S) > 0.5
    assert explained(SCHULER_S) > 2 * max(explained(SCHULER_S / 3), explained(SCHULER_S * 3))
    # the delayed-state filter damps it
    dsv = tab["delayed_state_north_velocity_error_mps"]
    assert np.std(dsv[k]) < 0.3 * np.std(tab["undamped_north_velocity_error_mps"][k])


def test_zero_current_delayed_state_and_conventional_close():
    """Without a current the water velocity is the velocity over ground: the conventional
    measurement is unbiased, so both filters damp the Schuler oscillation and their velocity errors
    are of the same order. The conventional one keeps the lower position error because it also sees
    the absolute velocity, which velocity changes cannot give."""
    sim = simulate(catalog.vessel(hours=1.0, current_mps=0.0), seed=6)
    s = run_pipeline(get("damping"), [parse_files(bundle_files(sim))], {}).summary
    c, d, u = s["conventional"], s["delayed_state"], s["undamped"]
    assert d["rms_velocity_error_mps"] < 3 * c["rms_velocity_error_mps"] + 0.01
    assert c["rms_velocity_error_mps"] < 0.3 * u["rms_velocity_error_mps"]
    assert d["rms_velocity_error_mps"] < 0.3 * u["rms_velocity_error_mps"]
    assert (
        c["rms_position_error_m"] < u["rms_position_error_m"] and d["rms_position_error_m"] < u["rms_position_error_m"]
    )


def test_bad_input_exits_2(tmp_path, capsys):
    from tests.bundles import make_bundle

    path = write_bundle(make_bundle(seed=3), tmp_path / "land")
    assert main(["run", "damping", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "platform" in capsys.readouterr().err
    files = make_bundle(seed=3)
    m = json.loads(files["manifest.json"])
    m["platform"] = "vessel"
    files["manifest.json"] = json.dumps(m).encode()
    path = write_bundle(files, tmp_path / "notwater")
    assert main(["run", "damping", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "water" in capsys.readouterr().err
