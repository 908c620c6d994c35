"""The ``novatel`` importer on real receivers' logs and on every message definition in EDIE's database.

Real logs (``tests/fixtures/real/novatel``, see its README): NovAtel's own test logs from novatel_edie
(BESTPOS in two definition versions, RAWIMUSXA of an Epson G320, INSPVAA/INSPVASA) and two SPAN
captures of SwRI's novatel_gps_driver (BESTPOS, INSPVAX, CORRIMUDATA of an OEM6 SPAN receiver); two
OEM7 SPAN captures of NovAtel's ROS driver tests (IMURATECORRIMUS, CORRIMUS, INSCONFIG, INSPVAS/INSPVAX
of an Epson G320 on a desk). Each value is compared with EDIE's own decode of the same message, field by
field, or with physics.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import novatel

ne = pytest.importorskip("novatel_edie")
from novatel_edie import oem  # noqa: E402

from tests.io.test_import_novatel import crc32  # noqa: E402 - the OEM7 CRC-32 written from the documentation

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real" / "novatel"
EDIE_LOGS = REAL / "edie-test-logs.asc"
SPAN = REAL / "swri-span-corrimudata.gps"
SPAN_BESTPOS = REAL / "swri-bestpos-bestvel-psrdop2.gps"
OEM7_IMURATE = REAL / "oem7-driver-ins2-imuratecorrimus.gps"
OEM7_CORRIMUS = REAL / "oem7-driver-ins1-corrimus.gps"
G_MIN = 9.78  # normal gravity is at least this anywhere on the ellipsoid (9.7803 at the equator), m/s²


def _database() -> dict:
    with ne.default_json_db_path() as p:
        return json.loads(Path(p).read_text())


def _edie(data: bytes, name: str) -> list[dict]:
    """EDIE's own decode of every ``name`` message (to_dict), in file order."""
    p = oem.Parser()
    p.write(data)
    return [m.to_dict() for m in p if type(m).__name__.split("_")[0] == name]


def _ascii(body: str, sync: str = "#") -> str:
    """``#<body>*<crc>`` with NovAtel's CRC-32."""
    return f"{sync}{body}*{crc32(body.encode()):08x}"


def _forms(ascii_log: bytes) -> dict[str, bytes]:
    """The ASCII log and EDIE's own binary encoding of it (same definition CRC in the header)."""
    p = oem.Parser()
    p.write(ascii_log)
    msg = next(iter(p))
    return {"ascii": ascii_log, "binary": bytes(msg.to_binary().message)}


# --- every definition version in EDIE's database -------------------------------------------------


def test_every_definition_of_every_message_read_has_every_quantity_by_name():
    db = _database()
    by_name = {m["name"]: m for m in db["messages"]}
    checked = 0
    for msg, needs in novatel.NEEDS.items():
        assert msg in by_name, f"{msg} not in EDIE's database"
        for crc, fields in by_name[msg]["fields"].items():
            names = {f["name"] for f in fields}
            for meaning in needs:
                assert names & set(novatel.MEANINGS[meaning]), f"{msg} definition {crc}: no field for {meaning}"
            checked += 1
    assert checked >= 15  # BESTPOS 3, BESTGNSSPOS 3, RAWIMU 2, RAWIMUX 2, RAWIMUS, RAWIMUSX, INSPVA 3, ...


def test_every_solution_type_is_mapped_or_left_out_on_purpose():
    db = _database()
    sol = next(e for e in db["enums"] if e["name"] == "SolType")
    names = {e["name"] for e in sol["enumerators"]}
    assert names <= set(novatel.FIX_OF_TYPE) | set(novatel.NOT_MEASURED), names - set(novatel.FIX_OF_TYPE)
    assert {"INS_PPP", "INS_PPP_BASIC", "PPP_PLUS", "L1L2_INT"} <= set(novatel.FIX_OF_TYPE)


BESTPOS_BODY = (
    'SOL_COMPUTED,NARROW_INT,51.15043699323,-114.03067932462,1096.9772,-17.0000,WGS84,0.6074,0.5792,0.9564,"131",'
    "7.000,0.000,42,34,34,28,00,0b,1f,37"
)


@pytest.mark.parametrize("msg", ["BESTPOS", "BESTGNSSPOS"])
def test_positions_of_every_definition_version_decode(msg):
    by_name = {m["name"]: m for m in _database()["messages"]}
    for crc in by_name[msg]["fields"]:
        head = f"{msg}A,COM1,0,60.5,FINESTEERING,2166,327153.000,02000000,{int(crc):04x},16248"
        data = (_ascii(f"{head};{BESTPOS_BODY}") + "\r\n").encode()
        assert _edie(data, msg), f"EDIE does not decode {msg} definition {crc}"
        for form, log in _forms(data).items():
            g = novatel.read(log, f"rx.{form}", "gnss", {})
            assert g.lat_deg[0] == 51.15043699323 and g.lon_deg[0] == -114.03067932462
            assert g.h_ell_m[0] == pytest.approx(1096.9772 - 17.0, abs=1e-4)  # height above MSL + undulation
            assert g.sep_m[0] == -17.0 and g.fix[0] == 4 and g.n_sat[0] == 34
            assert g.stamps.week[0] == 2166 and g.stamps.values[0] == 327153.0


@pytest.mark.parametrize("msg", ["RAWIMU", "RAWIMUX", "RAWIMUS", "RAWIMUSX"])
def test_raw_imu_of_every_definition_version_decodes(msg):
    by_name = {m["name"]: m for m in _database()["messages"]}
    z, ny, x, gz, gny, gx = -1234567, 2345678, -345678, 9876, -8765, 7654
    ext = "00,11," if msg.endswith("X") else ""
    for crc in by_name[msg]["fields"]:
        if msg.startswith("RAWIMUS"):  # short header: no definition CRC (one version)
            head, sync = f"{msg}A,2038,117867.800", "%"
        else:
            head, sync = f"{msg}A,COM1,0,68.5,FINESTEERING,2038,117867.800,1a008000,{int(crc):04x},14968", "#"
        body = f"{ext}2038,117867.792005000,f7f7fe00,{z},{ny},{x},{gz},{gny},{gx}"
        data = (_ascii(f"{head};{body}", sync) + "\r\n").encode()
        assert _edie(data, msg), f"EDIE does not decode {msg} definition {crc}"
        for form, log in _forms(data).items():
            part = novatel.read(log, f"rx.{form}", "imu", {"imu_type": "HG1700_AG58"})
            sg, sa = 2.0**-33, 0.3048 * 2.0**-27  # HG1700 AG58, OEM7 "Raw IMU scale factors"
            np.testing.assert_array_equal(part.dvel_mps[0], np.array([x, -ny, z]) * sa)
            np.testing.assert_array_equal(part.dtheta_rad[0], np.array([gx, -gny, gz]) * sg)
            assert part.stamps.values[0] == 117867.792005
            body_named = "del_vel_body_y" in {f["name"] for f in by_name[msg]["fields"][crc]}
            assert any("del_vel_body" in n for n in part.notes) == body_named


def test_rawimu_without_an_imu_type_names_the_field():
    body = "RAWIMUA,COM1,0,68.5,FINESTEERING,2038,117867.800,1a008000,0000,14968;2038,117867.79,0,1,2,3,4,5,6"
    with pytest.raises(BundleError) as e:
        novatel.read((_ascii(body) + "\r\n").encode(), "rx.asc", "imu", {})
    assert "imu_type" in e.value.field and "import.imu.imu_type" in e.value.message


# --- NovAtel's own test logs --------------------------------------------------------------------


def test_bestpos_of_both_real_definition_versions_against_edies_decode():
    # the CDBA lines name the height 'orthometric_height': KeyError 'height' and exit 1 before
    data = EDIE_LOGS.read_bytes()
    ref = _edie(data, "BESTPOS")
    assert {d["header"]["message_definition_crc"] for d in ref} == {0xB1F6, 0xCDBA}
    g = novatel.read(data, EDIE_LOGS.name, "gnss", {})
    assert len(g.lat_deg) == len(ref) == 4
    for j, d in enumerate(ref):
        h_msl = d.get("height", d.get("orthometric_height"))
        assert (g.lat_deg[j], g.lon_deg[j]) == (d["latitude"], d["longitude"])
        assert g.h_ell_m[j] == pytest.approx(h_msl + d["undulation"], abs=1e-9)
        assert g.stamps.values[j] == d["header"]["milliseconds"] / 1000.0


def test_lf_only_ascii_decodes_the_same():
    data = EDIE_LOGS.read_bytes()
    lf = data.replace(b"\r\n", b"\n")
    assert not _edie(lf, "BESTPOS")  # EDIE's framer alone finds nothing without CR LF
    a, b = novatel.read(data, "a", "gnss", {}), novatel.read(lf, "b", "gnss", {})
    np.testing.assert_array_equal(a.lat_deg, b.lat_deg)
    np.testing.assert_array_equal(a.h_ell_m, b.h_ell_m)


def test_inspva_is_a_reference_trajectory_with_edies_values():
    data = EDIE_LOGS.read_bytes()
    g = novatel.read(data, EDIE_LOGS.name, "gnss", {})
    ref = g.reference
    edie = _edie(data, "INSPVA")[0]
    assert len(ref.lat_deg) == 1  # INSPVASA and INSPVAA of the same epoch: kept once
    assert (ref.lat_deg[0], ref.lon_deg[0], ref.h_ell_m[0]) == (edie["latitude"], edie["longitude"], edie["height"])
    np.testing.assert_array_equal(ref.v_enu_mps[0], [edie["east_vel"], edie["north_vel"], edie["up_vel"]])
    np.testing.assert_array_equal(ref.rpy_deg[0], [edie["roll"], edie["pitch"], edie["azimuth"]])
    assert ref.status[0] == "WAITING_AZIMUTH"


def test_real_rawimusx_of_an_epson_g320_reads_gravity():
    """The Epson G320's counts are rates: one count is 0.2/2^16 mg over the data rate. The unit stood
    still: |f| must be normal gravity (9.81 m/s² at 51° N) within 1 %, on the z axis."""
    line = next(ln for ln in EDIE_LOGS.read_bytes().split(b"\r\n") if ln.startswith(b"%RAWIMUSXA"))
    data = line + b"\r\n"
    part = novatel.read(data, "imu.asc", "imu", {"rate_hz": 100})
    edie = _edie(data, "RAWIMUSX")[0]
    assert edie["imu_type"] == 41
    f = part.dvel_mps[0] * 100.0
    assert f[2] == pytest.approx(edie["accel_z"] * 0.2 / 2**16 * 9.80665e-3, rel=1e-12)
    assert f[1] == pytest.approx(-edie["accel_y"] * 0.2 / 2**16 * 9.80665e-3, rel=1e-12)
    g_51 = 9.780327 * (1 + 0.0053024 * math.sin(math.radians(51.15)) ** 2)  # normal gravity, 1980 formula
    assert np.linalg.norm(f) == pytest.approx(g_51, rel=0.01)
    assert abs(f[2]) / np.linalg.norm(f) > 0.99


# --- SwRI's SPAN captures -----------------------------------------------------------------------


def test_span_capture_bestpos_insapvax_and_prompts():
    data = SPAN.read_bytes()
    g = novatel.read(data, SPAN.name, "gnss", {})
    ref = _edie(data, "BESTPOS")
    assert len(g.lat_deg) == len(ref) == 28
    for j, d in enumerate(ref):
        assert (g.lat_deg[j], g.lon_deg[j]) == (d["latitude"], d["longitude"])
        assert g.h_ell_m[j] == pytest.approx(d["height"] + d["undulation"], abs=1e-9)
    assert all("prompt" not in n and "undecodable" not in n for n in g.notes), g.notes  # "[ICOM1]", "<OK"
    assert any("circular" in n for n in g.notes)  # BESTPOS of a SPAN receiver
    # the receiver's INS solution and its GNSS agree on a standing vehicle: physical plausibility
    r = g.reference
    assert len(r.lat_deg) == 28
    assert np.max(np.abs(np.interp(g.stamps.values, r.stamps.values, r.h_ell_m) - g.h_ell_m)) < 1.0


def test_span_capture_corrimudata_is_refused_as_imu_input_because_gravity_is_removed():
    data = SPAN.read_bytes()
    corr = _edie(data, "CORRIMUDATA")
    assert len(corr) == 29
    # independent evidence: the vertical velocity increment of the standing vehicle is ~0, not g·dt
    dt = np.median(np.diff([d["seconds"] for d in corr]))
    assert max(abs(d["vertical"]) / dt for d in corr) < 0.5
    with pytest.raises(BundleError) as e:
        novatel.read(data, SPAN.name, "imu", {})
    assert "gravity" in e.value.message and e.value.file == SPAN.name
    assert "only corrected ones: 29 CORRIMUDATA." in e.value.message


# --- NovAtel's OEM7 ROS driver test captures (SPAN with an Epson G320) -----------------------------


def _figure(message: str) -> float:
    """The mean specific force a refusal of corrected IMU messages prints, m/s²."""
    return float(re.search(r"mean specific force here is ([0-9.]+) m/s²", message).group(1))


def test_an_imuratecorrimus_log_is_refused_naming_imuratecorrimus_and_its_gravity_free_specific_force():
    """766 IMURATECORRIMUS of a receiver standing on a desk (its own INSPVAS: below 1 cm/s): the refusal names
    them (not "CORRIMUDATA/CORRIMUS"), the IMU its INSCONFIG states and the raw logs to ask for, and prints their
    mean specific force, which EDIE's decode of the same messages gives too: about 0, where raw increments of a
    unit standing on Earth give normal gravity (at least 9.78 m/s²)."""
    data = OEM7_IMURATE.read_bytes()
    corr = _edie(data, "IMURATECORRIMUS")
    assert len(corr) == 766
    assert max(math.hypot(d["north_vel"], d["east_vel"], d["up_vel"]) for d in _edie(data, "INSPVAS")) < 0.01
    config = _edie(data, "INSCONFIG")
    assert {d["imu_type"].name for d in config} == {"EPSON_G320"}
    with pytest.raises(BundleError) as e:
        novatel.read(data, OEM7_IMURATE.name, "imu", {})
    msg = e.value.message
    assert "only corrected ones: 766 IMURATECORRIMUS." in msg and "CORRIMUDATA/CORRIMUS" not in msg
    assert "gravity" in msg and "Earth's rotation" in msg and "RAWIMUSXB ONNEW" in msg and "EPSON_G320" in msg
    assert e.value.field == "message IMURATECORRIMUS" and e.value.file == OEM7_IMURATE.name
    # EDIE's decode: velocity increments per IMU sample (OEM7 manual: m/s/sample), one sample per message
    dt = np.median(np.diff([d["seconds"] for d in corr]))
    assert dt == pytest.approx(1 / 125, abs=1e-5)  # the G320's 125 Hz
    dv = np.array([[d["lateral"], d["longitudinal"], d["vertical"]] for d in corr])
    f_mps2 = np.linalg.norm(dv.mean(axis=0)) / dt
    assert _figure(msg) == pytest.approx(f_mps2, abs=0.0005)  # printed to 1 mm/s²
    assert _figure(msg) < 0.01 * G_MIN  # gravity removed: a raw unit at rest reads >= 9.78 m/s²


def test_a_corrimus_log_is_refused_naming_corrimus():
    """10 CORRIMUS (1 Hz) and INSPVAS of the same desk receiver: refused, naming CORRIMUS and the IMU; no figure
    (CORRIMUS counts its accumulated samples, its scaling is not the per-interval one of CORRIMUDATA)."""
    data = OEM7_CORRIMUS.read_bytes()
    assert len(_edie(data, "CORRIMUS")) == 10
    with pytest.raises(BundleError) as e:
        novatel.read(data, OEM7_CORRIMUS.name, "imu", {})
    msg = e.value.message
    assert "only corrected ones: 10 CORRIMUS." in msg and "EPSON_G320" in msg and "RAWIMUSXB" in msg
    assert "mean specific force" not in msg


def test_oem6_bestpos_definition_7145_from_a_real_capture():
    data = SPAN_BESTPOS.read_bytes()
    ref = _edie(data, "BESTPOS")
    assert {d["header"]["message_definition_crc"] for d in ref} == {0x7145}
    g = novatel.read(data, SPAN_BESTPOS.name, "gnss", {})
    assert len(g.lat_deg) == len(ref) == 33
    np.testing.assert_array_equal(g.lat_deg, [d["latitude"] for d in ref])


# --- streams ------------------------------------------------------------------------------------


def test_the_same_message_on_two_ports_is_kept_once_and_nmea_is_counted_as_nmea():
    first = EDIE_LOGS.read_bytes().split(b"\r\n")[0].decode()
    body = first[1:].rpartition("*")[0]
    com2 = _ascii(body.replace("COM1", "COM2", 1))
    gga = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47"
    data = "\r\n".join([first, gga, com2, ""]).encode()
    g = novatel.read(data, "rx.asc", "gnss", {})
    assert len(g.lat_deg) == 1
    assert any("another port" in n for n in g.notes)
    assert any("1 NMEA sentence" in n for n in g.notes) and not any("undecodable" in n for n in g.notes)


def test_bestgnsspos_is_preferred_over_bestpos():
    head = "A,COM1,0,60.5,FINESTEERING,2166,327153.000,02000000,b1f6,16248;"
    ins_body = BESTPOS_BODY.replace("NARROW_INT", "INS_RTKFIXED").replace("51.15043699323", "51.15043700000")
    data = (
        _ascii("BESTPOS" + head + ins_body) + "\r\n" + _ascii("BESTGNSSPOS" + head + BESTPOS_BODY) + "\r\n"
    ).encode()
    g = novatel.read(data, "rx.asc", "gnss", {})
    assert g.lat_deg.tolist() == [51.15043699323]
    assert any("BESTGNSSPOS used" in n for n in g.notes)
    only_bestpos = (_ascii("BESTPOS" + head + ins_body) + "\r\n").encode()
    assert any("circular" in n for n in novatel.read(only_bestpos, "rx.asc", "gnss", {}).notes)


def test_propagated_and_operator_positions_are_left_out():
    head = "BESTPOSA,COM1,0,60.5,FINESTEERING,2166,{s}.000,02000000,b1f6,16248;"
    lines = [
        _ascii(head.format(s=327153 + k) + BESTPOS_BODY.replace("NARROW_INT", t))
        for k, t in enumerate(["PROPAGATED", "FIXEDPOS", "INS_PPP", "NONE"])
    ]
    g = novatel.read(("\r\n".join(lines) + "\r\n").encode(), "rx.asc", "gnss", {})
    assert g.stamps.values.tolist() == [327155.0] and g.fix.tolist() == [4]
    assert any("PROPAGATED" in n for n in g.notes)


def test_the_reference_trajectory_is_written_beside_the_bundle(tmp_path):
    import datetime as dt

    from ldvsurvey.cli import main

    docs = Path(__file__).resolve().parents[2] / "docs" / "examples"
    inspva = next(ln for ln in EDIE_LOGS.read_bytes().split(b"\r\n") if ln.startswith(b"#INSPVAA"))
    span = tmp_path / "span.log"
    span.write_bytes((docs / "novatel" / "span.log").read_bytes() + inspva + b"\r\n")
    out = tmp_path / "drive.zip"
    args = ["import", "--imu", f"novatel:{span}", "--gnss", f"novatel:{span}", "--ldv", f"native:{docs / 'ldv.csv'}"]
    assert main([*args, "--manifest", str(docs / "partial.json"), "--out", str(out)]) == 0
    text = (tmp_path / "drive.reference.csv").read_text().splitlines()
    assert text[1].startswith("t,lat_deg,lon_deg,h_ell_m,")
    row = text[2].split(",")
    # GPS week 2174, 397710 s, 18 s GPS-UTC, on the clock of the manifest's date (2023-03-20)
    utc = dt.datetime(1980, 1, 6) + dt.timedelta(weeks=2174, seconds=397710 - 18)
    assert float(row[0]) == (utc - dt.datetime(2023, 3, 20)).total_seconds()
    assert float(row[1]) == 51.15044562951 and row[-1] == "WAITING_AZIMUTH"


def test_real_novatel_logs_are_recognised_from_their_content():
    from ldvsurvey.io.importers import detect

    for path in (SPAN, SPAN_BESTPOS, EDIE_LOGS, OEM7_IMURATE, OEM7_CORRIMUS):
        assert detect(path.read_bytes(), path.name)[0] == "novatel", path.name


def test_the_same_samples_in_two_raw_imu_logs_are_kept_once():
    lines = []
    for k in range(4):
        sow = 1000.0 + 0.01 * k
        body = f"00,11,2038,{sow:.9f},00000000,{k},{-k},{2 * k},3,4,5"
        lines.append(_ascii(f"RAWIMUXA,COM1,0,68.5,FINESTEERING,2038,{sow:.3f},1a008000,0000,14968;{body}"))
        lines.append(_ascii(f"RAWIMUSXA,2038,{sow:.3f};{body}", "%"))
    part = novatel.read(("\r\n".join(lines) + "\r\n").encode(), "rx.asc", "imu", {})
    assert len(part.dvel_mps) == 4 and np.all(np.diff(part.stamps.values) > 0)
    assert any("kept once" in n for n in part.notes)
