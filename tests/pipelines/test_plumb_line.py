"""Height levels to the ellipsoid normal when the deflection of the vertical is given (issue 13 §2).

Truth: a geoid N(x, y) = N₀ + a sin(2πx/λ) cos(2πy/λ) + regional tilt, from which ξ = −∂N/∂y,
η = −∂N/∂x (one potential); the simulator's IMU feels g^n = [−γη, −γξ, −γ]. Levelled to the plumb
line, an INS/LDV height follows H = h − N, so without the deflection the height error is the
geoid change along the track (≈ 0.3 m here); with the user's .gdf grids it is back at the noise.
The calibration's own error (a 2″ pitch error, well within its 1-σ of 1.4″ twice, costs 7 cm over
7 km) is taken out first, from the simulated mounting, so the comparison holds for any noise draw.
"""

import numpy as np
import pytest

from ldvsurvey.cli import main
from ldvsurvey.io.drivelog import parse_files
from ldvsurvey.io.gdf import write_gdf
from ldvsurvey.io.writers import write_bundle
from ldvsurvey.nav.earth import radii
from ldvsurvey.pipelines.base import run_pipeline
from ldvsurvey.pipelines.registry import get
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate

ARCSEC = np.pi / 180 / 3600
LAM_M = 9000.0
AMP_M = 0.12  # max slope 2π a/λ = 17″
TILT = (9 * ARCSEC, -6 * ARCSEC)  # regional ξ₀, η₀


class GeoidField:
    def __init__(self, lat0, lon0):
        self.lat0, self.lon0 = lat0, lon0
        self.rm, self.rn = radii(lat0)

    def _xy(self, lat, lon):
        return (lon - self.lon0) * self.rn * np.cos(self.lat0), (lat - self.lat0) * self.rm

    def __call__(self, lat_rad, lon_rad, h_m):
        x, y = self._xy(np.asarray(lat_rad, float), np.asarray(lon_rad, float))
        k = 2 * np.pi / LAM_M
        dndx = AMP_M * k * np.cos(k * x) * np.cos(k * y) - TILT[1]
        dndy = -AMP_M * k * np.sin(k * x) * np.sin(k * y) - TILT[0]
        return -dndy, -dndx, 0.0 * x


@pytest.fixture(scope="module")
def dov_case(tmp_path_factory):
    sc = catalog.height(minutes=14.0, length_m=3500.0, relief_m=12.0, fix_schedule=[])
    field = sc.gravity_field = GeoidField(sc.road.lat0_rad, sc.road.lon0_rad)
    sim = simulate(sc, seed=12)
    d = tmp_path_factory.mktemp("dov")
    lat = np.degrees(sim.imu.lat_rad)
    lon = np.degrees(sim.imu.lon_rad)
    st = 0.5 / 60
    la = np.arange(np.floor(lat.min() / st) - 3, np.ceil(lat.max() / st) + 4) * st
    lo = np.arange(np.floor(lon.min() / st) - 3, np.ceil(lon.max() / st) + 4) * st
    gl, go = np.meshgrid(np.radians(la), np.radians(lo), indexing="ij")
    xi, eta, _ = field(gl, go, 0.0)
    (d / "xi.gdf").write_bytes(write_gdf(la, lo, xi / ARCSEC, "xi", "arcsec"))
    (d / "eta.gdf").write_bytes(write_gdf(la, lo, eta / ARCSEC, "eta", "arcsec"))
    log = parse_files(bundle_files(sim))
    return sim, log, d, field


def _height_err(sim, r):
    h = r.tables["height"]
    return h["h_m"] - np.interp(h["t_s"], sim.imu.t_s, sim.imu.h_m)


def test_height_with_grid_dov_levels_to_the_normal(dov_case):
    sim, log, d, field = dov_case
    grids = f"{d / 'xi.gdf'},{d / 'eta.gdf'}"
    with_dov = run_pipeline(get("height"), [log], {"dov": "grid", "dov_grid": grids})
    without = run_pipeline(get("height"), [log], {"dov": "none"})
    e1, e0 = _height_err(sim, with_dov), _height_err(sim, without)
    xi_t, eta_t, _ = field(sim.imu.lat_rad, sim.imu.lon_rad, 0.0)
    dn = np.hypot(xi_t, eta_t).max() / ARCSEC
    assert dn > 10  # a deflection of the realistic size
    # the calibration's own error (its pitch error over the distance driven, its compliance times v²/2;
    # truth: the simulated mounting, no compliance) is common to both runs and within its 3-σ envelope
    # (above a 2-cm floor of LDV noise and GNSS); what is left of it is the plumb-line levelling
    t = with_dov.tables["height"]["t_s"]
    tr = sim.motion.truth(t)
    dist_m = np.concatenate([[0.0], np.cumsum(0.5 * (tr["speed_mps"][1:] + tr["speed_mps"][:-1]) * np.diff(t))])
    cal = with_dov.summary["calibration"]
    sig = cal["sigma"]
    envelope = 0.02 + 3 * (
        np.radians(sig["ldv_pitch_deg"]) * dist_m + sig["ldv_pitch_k_rad_per_mps2"] * tr["speed_mps"] ** 2 / 2
    )
    worst = int(np.argmax(np.abs(e1) / envelope))
    assert np.abs(e1[worst]) <= envelope[worst], (e1[worst], envelope[worst], t[worst])

    def levelling(r, e):
        c = r.summary["calibration"]
        d_pitch = np.radians(c["ldv_pitch_deg"]) - sim.scenario.ldv.pitch_rad
        return e - (d_pitch * dist_m + c["ldv_pitch_k_rad_per_mps2"] * tr["speed_mps"] ** 2 / 2)

    r1, r0 = levelling(with_dov, e1), levelling(without, e0)
    # without the deflection: the geoid change along the track; with it: back at the noise
    assert np.abs(r0).max() > 0.08 and np.std(r0) > 3 * np.std(r1), (np.abs(r0).max(), np.std(r0), np.std(r1))
    assert np.std(r1) <= 0.03 and np.abs(r1).max() <= 0.06, (np.std(r1), np.abs(r1).max())
    s = with_dov.summary["dov"]
    assert s["xi_arcsec_max"] == pytest.approx(np.abs(xi_t).max() / ARCSEC, rel=0.05)
    assert s["eta_arcsec_max"] == pytest.approx(np.abs(eta_t).max() / ARCSEC, rel=0.05)
    # the reported first-order effect matches the height difference the compensation made
    h1, h0 = with_dov.tables["height"]["h_m"], without.tables["height"]["h_m"]
    assert abs(s["height_effect_max_m"] - (h0 - h1)[np.argmax(np.abs(h0 - h1))]) < 0.1 * np.abs(h0 - h1).max()
    assert without.summary["dov"]["source"].startswith("none")


def test_calibration_heading_needs_the_deflection(dov_case):
    """Gyrocompassing and the LDV heading feel η tan L: 16″ off without the deflection, 3″ with it."""
    sim, log, d, _ = dov_case
    grids = f"{d / 'xi.gdf'},{d / 'eta.gdf'}"
    err = {}
    for mode, extra in (("grid", {"dov_grid": grids}), ("none", {})):
        s = run_pipeline(get("calibrate"), [log], {"dov": mode, **extra}).summary
        err[mode] = (
            np.radians(s["ldv_heading_deg"]) - sim.scenario.ldv.heading_rad,
            np.radians(s["ldv_heading_deg_sigma"]),
        )
    assert abs(err["grid"][0]) <= min(10 * ARCSEC, 3 * err["grid"][1])
    # without it the heading is off by about η tan L, beyond the acceptance; the residuals it leaves
    # are time-correlated, so the (innovation-inflated) 1-σ grows to cover it rather than hide it
    assert abs(err["none"][0]) > 10 * ARCSEC
    assert abs(err["none"][0]) <= 3 * err["none"][1]


def test_dov_grid_errors_name_file_and_field(dov_case, tmp_path, capsys):
    sim, log, d, _ = dov_case
    bad = tmp_path / "bad.gdf"
    text = (d / "xi.gdf").read_text().splitlines()
    text[-3] = text[-3].split()[0] + " x 1.0"
    bad.write_text("\n".join(text) + "\n")
    bundle = tmp_path / "b"
    write_bundle(bundle_files(sim), bundle)
    out = tmp_path / "o"
    rc = main(
        [
            "run",
            "height",
            str(bundle),
            "--out",
            str(out),
            "--set",
            "dov=grid",
            "--set",
            f"dov_grid={bad},{d / 'eta.gdf'}",
        ]
    )
    err = capsys.readouterr().err
    assert rc != 0 and "bad.gdf" in err and "line" in err
    assert not out.exists() or not any(out.iterdir())  # nothing written
    rc = main(["run", "height", str(bundle), "--out", str(out), "--set", "dov=grid"])
    assert rc != 0 and "dov_grid" in capsys.readouterr().err
