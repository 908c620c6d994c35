"""``ldv-survey import`` as a process of its own (issue 34: import + navigate of a short drive in no
more CPU than KF-GINS): a KF-GINS IMU + GNSS pair imported without numba, scipy or pandas (none of
them is needed to read, check, write and validate a bundle; together they were 0.4 s of its CPU),
and the bundle it writes is the one ``main(argv)`` writes in a test's process, where all are loaded."""

from __future__ import annotations

import datetime as dt
import json
import zipfile

from ldvsurvey.cli import main
from ldvsurvey.sim import catalog
from ldvsurvey.sim.scenario import bundle_files, simulate
from tests.cli.own_process import run_own_process
from tests.io.import_helpers import kfgins_gnss, kfgins_imu


def test_import_process_loads_nothing_heavy_and_writes_what_main_writes(tmp_path):
    sim = simulate(catalog.drive(minutes=6.0, with_ldv=False), seed=4)
    day = dt.date.fromisoformat(sim.scenario.date)
    (tmp_path / "imu.txt").write_bytes(kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day))
    (tmp_path / "gnss.txt").write_bytes(
        kfgins_gnss(sim.gnss_t_s, sim.gnss_lat_deg, sim.gnss_lon_deg, sim.gnss_h_m, sim.gnss_fix, day)
    )
    partial = json.loads(bundle_files(sim)["manifest.json"])
    partial.pop("format")
    partial["imu"].pop("rate_hz")
    (tmp_path / "partial.json").write_text(json.dumps(partial))

    def argv(out):
        return ["import", "--imu", f"kf-gins:{tmp_path / 'imu.txt'}", "--gnss", f"kf-gins:{tmp_path / 'gnss.txt'}"] + [
            "--manifest",
            str(tmp_path / "partial.json"),
            "--out",
            str(out),
        ]

    rc, mods = run_own_process(argv(tmp_path / "own.zip"))
    assert rc == 0
    heavy = {m for m in mods if m.split(".")[0] in ("numba", "scipy", "pandas", "llvmlite", "sqlalchemy")}
    heavy |= {m for m in mods if m.startswith(("ldvsurvey.pipelines", "ldvsurvey.api", "ldvsurvey.store"))}
    assert heavy == set()
    assert "ldvsurvey.io.importers.checks" in mods  # the import's cross-checks ran

    assert main(argv(tmp_path / "called.zip")) == 0
    with zipfile.ZipFile(tmp_path / "own.zip") as a, zipfile.ZipFile(tmp_path / "called.zip") as b:
        assert a.namelist() == b.namelist() == ["manifest.json", "imu.csv", "gnss.nmea"]
        for name in a.namelist():
            assert a.read(name) == b.read(name), name
