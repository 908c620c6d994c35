"""INS/GNSS logs without an LDV (issue 25), end to end on the product's simulator: a bundle with an
IMU and GNSS only validates, imports from KF-GINS text without ``--ldv``, and runs ``navigate``
(GNSS aiding by default), ``gravity`` (the SINS/GNSS chain as the result), ``dov`` and ``tilt``;
every figure is checked against the simulator's truth."""

from __future__ import annotations

import datetime as dt
import json

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.drivelog import load_bundle, parse_files
from ldvsurvey.io.writers import write_bundle
from ldvsurvey.nav.earth import MGAL, enu_offset_m
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.io.import_helpers import kfgins_gnss, kfgins_imu
from tests.pipelines.helpers import files_from, truth_dg_error_mgal


@pytest.fixture(scope="module")
def rtk_drive(tmp_path_factory):
    """Three repeated 4-km gravity lines, RTK fixed throughout, no LDV (~24 min at 100 Hz)."""
    sc = catalog.gravity(n_lines=3, line_km=4.0, fix_schedule=[], with_ldv=False)
    sim = simulate(sc, seed=5)
    files = bundle_files(sim)
    d = tmp_path_factory.mktemp("noldv")
    write_bundle(files, d / "bundle")
    return sim, files, parse_files(files), d


def _truth_at(sim, t):
    im = sim.imu
    return (
        np.interp(t, im.t_s, im.lat_rad),
        np.interp(t, im.t_s, im.lon_rad),
        np.interp(t, im.t_s, im.h_m),
    )


def test_bundle_without_ldv_validates(rtk_drive, capsys):
    _, files, log, d = rtk_drive
    assert "ldv.csv" not in files and "ldv" not in json.loads(files["manifest.json"])
    assert log.ldv is None and log.manifest.ldv is None and log.gnss is not None
    assert main(["validate", str(d / "bundle")]) == 0
    assert "no LDV" in capsys.readouterr().out


def test_navigate_defaults_to_gnss_aiding_and_follows_the_truth(rtk_drive, tmp_path):
    """``ldv-survey run navigate`` on the bundle: GNSS aiding (auto), forward filter and RTS
    smoother; the trajectory against the simulator's truth, within the RTK fixes' own error."""
    sim, _, _, d = rtk_drive
    assert main(["run", "navigate", str(d / "bundle"), "--out", str(tmp_path)]) == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["aiding"] == "gnss" and s["parameters"]["aiding"] == "auto" and s["smoothed"] is True
    from ldvsurvey.io.csvtable import read_numeric_csv

    tab = read_numeric_csv(tmp_path / "trajectory.csv", "trajectory.csv", ["t_s", "lat_deg", "lon_deg", "h_m"]).columns
    lat, lon, h = _truth_at(sim, tab["t_s"])
    e = enu_offset_m(lat, lon, h, np.radians(tab["lat_deg"]), np.radians(tab["lon_deg"]), tab["h_m"])
    horiz, vert = np.hypot(e[:, 0], e[:, 1]), e[:, 2]
    rms_h, rms_v = float(np.sqrt(np.mean(horiz**2))), float(np.sqrt(np.mean(vert**2)))
    print(f"navigate aiding=gnss vs truth: horizontal RMS {rms_h:.4f} m, vertical RMS {rms_v:.4f} m")
    # the simulated RTK fixes: 2 cm horizontal, 3 cm vertical per axis (mostly slowly wandering)
    assert rms_h < 0.05 and rms_v < 0.05


def test_gravity_from_the_sins_gnss_chain_within_its_noise_floor(rtk_drive):
    """The SINS/GNSS chain is the result; its repeated-line coincidence within 1.2× the noise floor it
    prints (accelerometer and GNSS height noise through the FIR), and the filtered δg follows the
    simulator's disturbance, filtered the same way."""
    sim, _, log, _ = rtk_drive
    r = run_pipeline(get("gravity"), [log], {"fir_length_s": 150.0})
    s = r.summary
    assert s["aiding"] == "gnss" and "SINS/GNSS" in s["chain"] and "gnss_comparison" not in s
    assert len(s["lines"]) == 3
    floor = s["noise_floor"]["total_mgal"]
    print(f"gravity without LDV: coincidence {s['total_mgal']:.3f} mGal, printed floor {floor:.3f} mGal")
    assert floor > 0 and s["total_mgal"] <= 1.2 * floor
    g = r.tables["gravity"]
    e = truth_dg_error_mgal(sim, g, "dg_mgal")
    assert len(e) > 300  # 3 lines × (267 − 150) s after trimming, at 1 Hz
    # one constant offset: the vertical accelerometer bias (unobservable), nothing else
    assert np.mean(e) == pytest.approx(sim.errors.accel_bias_mps2[2] / MGAL, abs=1.5)
    assert np.std(e) <= 3.0 * floor


def test_floor_from_the_data_when_the_manifest_states_no_noise(rtk_drive):
    """A bundle as an independent producer writes it (no ``gnss.height_noise``, no IMU noise keys): the
    floor's figures come from the log (accelerometer density from the static start, GNSS white σ and
    wander fitted to the chain's raw δg), are the simulator's own within their scatter, and the
    coincidence is within 1.2× the floor printed (before the fit: a white σ from the fix quality and no
    accelerometer term: floor 0.235 mGal, coincidence/floor 1.8)."""
    from ldvsurvey.nav.gravity import Lowpass, noise_floor_mgal
    from ldvsurvey.sim.sensors import FIX_SIGMA, FIX_WHITE, GNSS_CORR_S

    sim, files, log, _ = rtk_drive
    m = json.loads(files["manifest.json"])
    m["gnss"].pop("height_noise")
    m["imu"].pop("accel_noise_ug_per_rthz")
    m["imu"].pop("gyro_arw_deg_per_rth")
    bare = parse_files({**files, "manifest.json": json.dumps(m).encode()})
    s = run_pipeline(get("gravity"), [bare], {"fir_length_s": 150.0}).summary
    fl = s["noise_floor"]
    print(f"no noise keys: coincidence {s['total_mgal']:.3f} mGal, floor {fl['total_mgal']:.3f} mGal; {fl}")
    assert fl["accel_noise_source"].startswith("estimated from the static start")
    assert fl["gnss_height_sigma_source"].startswith("fitted to the chain's raw δg")
    # the simulator's truth, used only here
    white, sigma = FIX_WHITE[4][1], FIX_SIGMA[4][1]
    q = 2 * (sigma**2 - white**2) / GNSS_CORR_S
    assert fl["accel_noise_ug_rthz"] == pytest.approx(sim.scenario.accel_vrw_ug_rthz, rel=0.1)
    assert fl["gnss_height_sigma_m"] == pytest.approx(white, rel=0.1)
    # q's own scatter on a 24-min log is ±30 % (1 σ over simulated realizations); this seed gives +20 %
    assert fl["gnss_height_random_walk_m2_per_s"] == pytest.approx(q, rel=0.4)
    true_floor = noise_floor_mgal(
        Lowpass(150.0),
        sim.scenario.accel_vrw_ug_rthz,
        height_noise_m=white,
        gnss_rate_hz=1.0,
        height_correlated_m=float(np.sqrt(sigma**2 - white**2)),
        height_correlation_s=GNSS_CORR_S,
    )["total_mgal"]
    assert fl["total_mgal"] == pytest.approx(true_floor, rel=0.2)
    assert s["total_mgal"] <= 1.2 * fl["total_mgal"]


def test_import_from_kfgins_without_ldv(rtk_drive, tmp_path):
    """KF-GINS IMU and GNSS text and a partial manifest without an ldv section: a bundle without
    ldv.csv, with the simulation's increments, that navigates as the native bundle does."""
    sim, files, log, _ = rtk_drive
    day = dt.date.fromisoformat(sim.scenario.date)
    (tmp_path / "imu.txt").write_bytes(kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day))
    (tmp_path / "gnss.txt").write_bytes(
        kfgins_gnss(sim.gnss_t_s, sim.gnss_lat_deg, sim.gnss_lon_deg, sim.gnss_h_m, sim.gnss_fix, day)
    )
    partial = json.loads(files["manifest.json"])
    partial.pop("format")
    partial["imu"].pop("rate_hz")
    (tmp_path / "partial.json").write_text(json.dumps(partial))
    out = tmp_path / "b.zip"
    args = ["import", "--imu", f"kf-gins:{tmp_path / 'imu.txt'}", "--gnss", f"kf-gins:{tmp_path / 'gnss.txt'}"]
    assert main(args + ["--manifest", str(tmp_path / "partial.json"), "--out", str(out)]) == 0
    imported = load_bundle(out)
    assert imported.ldv is None and "ldv.csv" not in imported.files
    np.testing.assert_allclose(imported.imu.dtheta_rad, sim.dtheta_rad, rtol=0, atol=1e-15)
    assert main(["validate", str(out)]) == 0
    # an IMU alone makes no bundle: named, exit 2
    assert (
        main(
            [
                "import",
                "--imu",
                f"kf-gins:{tmp_path / 'imu.txt'}",
                "--manifest",
                str(tmp_path / "partial.json"),
                "--out",
                str(tmp_path / "c.zip"),
            ]
        )
        == 2
    )
    assert not (tmp_path / "c.zip").exists()


def test_tilt_of_a_rotating_imu_without_ldv(tmp_path):
    """``ldv-survey run tilt`` on a rotating IMU without an LDV: the base tilt from the turntable's still
    rotations, the attitude (GNSS-aided) compensated; against the simulator's α, β and pitch."""
    from ldvsurvey.io.csvtable import read_numeric_csv

    sc = catalog.height(minutes=12.0, length_m=3000.0, fix_schedule=[], with_ldv=False)
    sim = simulate(sc, seed=2)
    files = bundle_files(sim)
    log = parse_files(files)
    assert log.ldv is None and log.imu.turntable_deg is not None
    write_bundle(files, tmp_path / "bundle")
    assert main(["run", "tilt", str(tmp_path / "bundle"), "--out", str(tmp_path / "out")]) == 0  # the CLI
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["aiding"] == "gnss"
    assert abs(s["alpha_rad"] - sc.alpha_rad) < 2e-5 and abs(s["beta_rad"] - sc.beta_rad) < 2e-5
    assert s["pitch_oscillation_after_rad"] <= 0.2 * s["pitch_oscillation_before_rad"]
    att = read_numeric_csv(
        tmp_path / "out" / "attitude.csv", "attitude.csv", ["t_s", "pitch_deg", "pitch_raw_deg"]
    ).columns
    truth_p = np.degrees(np.interp(att["t_s"], sim.imu.t_s, np.arcsin(sim.imu.c_bn[:, 2, 1])))
    assert np.abs(att["pitch_deg"] - truth_p).max() < np.abs(att["pitch_raw_deg"] - truth_p).max() / 5


def test_dov_without_ldv(tmp_path):
    """``dov`` from the INS alone (GNSS only for the reference trajectory): the deflections along the
    track are the simulator's field, and the propagated error follows the two-mechanization truth."""
    from ldvsurvey.io.writers import imu_csv
    from ldvsurvey.sim import truth as TR
    from ldvsurvey.sim.effects import Effects

    sc = catalog.realistic_drive(
        seed=3, effects=Effects.only("gravity_field", 3), minutes=9.0, static_s=120.0, speed_mps=25.0
    )
    sc.with_ldv = False
    sim = simulate(sc, with_nodov=True)
    grids = TR.grid_files(sim)
    for n in ("xi.gdf", "eta.gdf"):
        (tmp_path / n).write_bytes(grids[n])
    (tmp_path / "imu_nodov.csv").write_bytes(imu_csv(sim.imu.t_s, *sim.imu_nodov))
    log = parse_files(bundle_files(sim))
    assert log.ldv is None
    res = run_pipeline(
        get("dov"),
        [log],
        {
            "dov_grid": f"{tmp_path / 'xi.gdf'},{tmp_path / 'eta.gdf'}",
            "imu_nodov": str(tmp_path / "imu_nodov.csv"),
            "compensation": False,
        },
    )
    tab = res.tables["dov"]
    t = tab["t_s"]
    xi, eta, _ = sim.extras["gravity_field"](
        np.interp(t, sim.imu.t_s, sim.imu.lat_rad),
        np.interp(t, sim.imu.t_s, sim.imu.lon_rad),
        np.full(len(t), float(np.mean(sim.imu.h_m))),
    )
    arcsec = np.pi / 180 / 3600
    assert np.abs(tab["xi_arcsec"] - xi / arcsec).max() < 0.5 and np.abs(tab["eta_arcsec"] - eta / arcsec).max() < 0.5
    scale = np.hypot(tab["dn_theoretical_m"], tab["de_theoretical_m"]).max()
    assert scale > 0.5
    for c in ("n", "e"):
        assert np.abs(tab[f"d{c}_rk4_m"] - tab[f"d{c}_theoretical_m"]).max() < 0.1 * scale, c


def test_moving_start_without_ldv():
    """A log without an LDV that begins on the move (cut 50 s after moving off, no static period,
    no manifest start): aligned from the GNSS course and speed, then the GNSS-aided filter."""
    from ldvsurvey.nav.attitude import euler_from_c_bn
    from ldvsurvey.pipelines.stages.aids import nav_inputs

    sim = simulate(catalog.drive(minutes=6.0, static_s=60.0, with_ldv=False), seed=8)
    f, j = files_from(sim, sim.scenario.t0_s + 110.0)
    inp = nav_inputs(parse_files(f))
    p, r, h = euler_from_c_bn(inp.c_bn0)
    pt, rt, ht = euler_from_c_bn(sim.imu.c_bn[j])
    deg = np.pi / 180
    assert abs(p - pt) < 0.1 * deg and abs(r - rt) < 0.1 * deg
    assert abs((h - ht + np.pi) % (2 * np.pi) - np.pi) < 0.3 * deg
    res = run_pipeline(get("navigate"), [parse_files(f)], {})
    assert res.summary["aiding"] == "gnss"
    assert any("coarse alignment on the move" in w for w in res.summary["warnings"])
    tab = res.tables["trajectory"]
    k = np.searchsorted(sim.imu.t_s, tab["t_s"])
    late = tab["t_s"] > tab["t_s"][0] + 60.0
    _, _, hh = euler_from_c_bn(sim.imu.c_bn[k])
    assert np.abs((np.radians(tab["heading_deg"]) - hh + np.pi) % (2 * np.pi) - np.pi)[late].max() < 0.1 * deg
    d = enu_offset_m(
        sim.imu.lat_rad[k],
        sim.imu.lon_rad[k],
        sim.imu.h_m[k],
        np.radians(tab["lat_deg"]),
        np.radians(tab["lon_deg"]),
        tab["h_m"],
    )
    assert np.abs(d).max() < 0.15


def test_cli_refuses_what_needs_an_ldv(rtk_drive, tmp_path, capsys):
    """``ldv-survey run`` says the same as the REST submit: exit 2 naming the missing LDV, nothing written."""
    _, _, _, d = rtk_drive
    for pipe in ("calibrate", "height"):
        out = tmp_path / pipe
        assert main(["run", pipe, str(d / "bundle"), "--out", str(out)]) == 2
        assert "has no LDV" in capsys.readouterr().err
        assert not out.exists() or not any(out.iterdir())
    assert main(["run", "navigate", str(d / "bundle"), "--set", "aiding=ldv+gnss", "--out", str(tmp_path / "n")]) == 2
    assert "aiding" in capsys.readouterr().err


def test_a_day_the_ldv_failed_navigates_with_gnss():
    """ldv.csv present but no sample above min_quality (the issue's 'survey day on which the LDV
    failed'): navigate with GNSS aiding (asked, or auto) runs and says why; LDV aiding is refused
    naming ldv.csv."""
    from ldvsurvey.errors import ParameterError
    from ldvsurvey.io.writers import ldv_csv

    sim = simulate(catalog.drive(minutes=8.0, fix_schedule=[]), seed=4)
    f = bundle_files(sim)
    n = len(sim.ldv_t_s)
    f["ldv.csv"] = ldv_csv(sim.ldv_t_s, v_fwd_mps=sim.ldv_v_fwd, v_up_mps=sim.ldv_v_up, quality=np.zeros(n))
    log = parse_files(f)
    for params in ({"aiding": "gnss"}, {}):
        r = run_pipeline(get("navigate"), [log], params)
        assert r.summary["aiding"] == "gnss"
        assert any("no usable sample" in w for w in r.summary["warnings"]), params
        tab = r.tables["trajectory"]
        lat, lon, h = _truth_at(sim, tab["t_s"])
        e = enu_offset_m(lat, lon, h, np.radians(tab["lat_deg"]), np.radians(tab["lon_deg"]), tab["h_m"])
        assert np.sqrt(np.mean(e**2)) < 0.05
    with pytest.raises(ParameterError) as ei:
        run_pipeline(get("navigate"), [log], {"aiding": "ldv+gnss"})
    assert ei.value.field == "ldv.csv"
