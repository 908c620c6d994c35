"""Fuzzing the upload and import paths (issue 28): damaged archives and recordings (truncations, bit
flips in headers and data, wrong CRCs, bad sizes, unknown compression methods, random bytes) never
give a 500; every refusal is a 4xx whose error names the archive or file.

The corpus is derandomized (the same examples on every run); the seed-independent defects found
by hand have their own tests in ``tests/io/test_bad_input.py`` and ``tests/api/test_logs_api.py``.
"""

from __future__ import annotations

import datetime as dt
import io
import json
import struct
import zipfile

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ldvsurvey.api.app import create_app
from ldvsurvey.errors import InputError
from ldvsurvey.io.drivelog import load_bundle
from ldvsurvey.settings import Settings
from tests.badinput import member_data_offset
from tests.bundles import make_bundle
from tests.io.import_helpers import kfgins_gnss, kfgins_imu

FUZZ = settings(
    max_examples=120,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def _zip(files: dict[str, bytes], method: int) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", method) as zf:
        for n, d in files.items():
            zf.writestr(n, d)
    return buf.getvalue()


BUNDLE = make_bundle(seed=71, n_imu=300)
#: one archive with deflated members, one with stored ones (bit flips then reach the CSV parser)
BASES = {"deflated": _zip(BUNDLE, zipfile.ZIP_DEFLATED), "stored": _zip(BUNDLE, zipfile.ZIP_STORED)}


def _layout(z: bytes) -> list[tuple[str, int, int, int, int]]:
    """Per member: (name, local header offset, central header offset, data start, data end)."""
    infos = zipfile.ZipFile(io.BytesIO(z)).infolist()
    central, pos = [], z.find(b"PK\x01\x02")
    while pos >= 0:
        central.append(pos)
        pos = z.find(b"PK\x01\x02", pos + 4)
    out = []
    for info, c in zip(infos, central):
        start = member_data_offset(z, info.filename)
        out.append((info.filename, info.header_offset, c, start, start + info.compress_size))
    return out


@st.composite
def damaged_zips(draw) -> bytes:
    z = bytearray(BASES[draw(st.sampled_from(sorted(BASES)))])
    members = _layout(bytes(z))
    name, local, central, start, end = draw(st.sampled_from(members))
    kind = draw(st.sampled_from(["truncate", "flip-header", "flip-data", "crc", "size", "method", "flip-anywhere"]))
    if kind == "truncate":
        return bytes(z[: draw(st.integers(0, len(z) - 1))])
    if kind == "flip-header":  # the member's local header or its central-directory entry
        where = draw(st.sampled_from([(local, 30), (central, 46)]))
        for _ in range(draw(st.integers(1, 4))):
            z[where[0] + draw(st.integers(0, where[1] - 1))] ^= 1 << draw(st.integers(0, 7))
    elif kind == "flip-data" and end > start:
        for _ in range(draw(st.integers(1, 4))):
            z[draw(st.integers(start, end - 1))] ^= 1 << draw(st.integers(0, 7))
    elif kind == "crc":  # a wrong CRC in the local header, the central directory, or both
        crc = struct.pack("<I", draw(st.integers(0, 2**32 - 1)))
        for off in draw(st.sampled_from([(local + 14,), (central + 16,), (local + 14, central + 16)])):
            z[off : off + 4] = crc
    elif kind == "size":  # compressed or uncompressed size, local and/or central
        value = struct.pack("<I", draw(st.sampled_from([0, 1, 100, 2**16, 2**31, 2**32 - 1])))
        offs = draw(st.sampled_from([(local + 18,), (local + 22,), (central + 20,), (central + 24,)]))
        for off in offs:
            z[off : off + 4] = value
    elif kind == "method":
        value = struct.pack("<H", draw(st.sampled_from([0, 1, 8, 9, 12, 14, 99, 0xFFFF])))
        for off in draw(st.sampled_from([(local + 8,), (central + 10,), (local + 8, central + 10)])):
            z[off : off + 2] = value
    else:
        for _ in range(draw(st.integers(1, 8))):
            z[draw(st.integers(0, len(z) - 1))] ^= 1 << draw(st.integers(0, 7))
    return bytes(z)


@pytest.fixture(scope="module")
def fuzz_client(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fuzz")
    s = Settings(
        data_dir=tmp / "data",
        auth_enabled=False,
        run_consumer=False,
        max_upload_bytes=5 * 1024 * 1024,
        max_unzipped_bytes=50 * 1024 * 1024,
        uploads_per_minute=100_000,
        database_url=f"sqlite:///{tmp / 'fuzz.db'}",
    )
    with TestClient(create_app(s), raise_server_exceptions=False) as c:
        yield c


def _judge(r, names: set[str]) -> None:
    """A success, or a 4xx whose error names one of ``names`` (the archive or a file sent)."""
    assert r.status_code != 500, r.text
    if r.status_code in (200, 201):
        return
    assert 400 <= r.status_code < 500, r.text
    err = r.json()["error"]
    assert err["file"] in names, r.text


@FUZZ
@given(data=damaged_zips())
def test_damaged_zip_upload_is_stored_or_refused_naming_the_archive(fuzz_client, data):
    r = fuzz_client.post("/api/logs", files=[("files", ("fuzz.zip", data, "application/zip"))])
    _judge(r, {"fuzz.zip"} | set(BUNDLE))


@FUZZ
@given(data=damaged_zips())
def test_damaged_zip_from_the_command_line_is_an_input_error(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("cli") / "fuzz.zip"
    path.write_bytes(data)
    try:
        load_bundle(path)
    except InputError as exc:
        assert exc.file in {"fuzz.zip"} | set(BUNDLE), str(exc)


@pytest.fixture(scope="module")
def recordings():
    from ldvsurvey.sim import catalog
    from ldvsurvey.sim.scenario import bundle_files, manifest, simulate

    sim = simulate(catalog.drive(minutes=2.5, static_s=30.0), seed=8)
    day = dt.date.fromisoformat(sim.scenario.date)
    partial = manifest(sim)
    partial.pop("format")
    files = {
        "imu.txt": kfgins_imu(sim.imu.t_s, sim.dtheta_rad, sim.dvel_mps, day),
        "gnss.txt": kfgins_gnss(sim.gnss_t_s, sim.gnss_lat_deg, sim.gnss_lon_deg, sim.gnss_h_m, sim.gnss_fix, day),
        "ldv.csv": bundle_files(sim)["ldv.csv"],
    }
    return files, partial


#: besides the files sent, a refusal may name the form fields or the bundle files they became
CONVERTED = {"formats", "manifest", "manifest (partial)", "imu.csv", "ldv.csv", "gnss.nmea", "manifest.json"}


@st.composite
def damaged_recording(draw, names):
    """(file name, kind of damage, a seed for it, random bytes for the kind "random")."""
    name = draw(st.sampled_from(names))
    kind = draw(st.sampled_from(["truncate", "flip", "cut-line", "random"]))
    return name, kind, draw(st.integers(0, 2**31 - 1)), draw(st.binary(max_size=2048))


def _damage(data: bytes, kind: str, seed: int, junk: bytes) -> bytes:
    import random

    rnd = random.Random(seed)
    if kind == "truncate":
        return data[: rnd.randrange(len(data))]
    if kind == "flip":
        b = bytearray(data)
        for _ in range(rnd.randint(1, 8)):
            b[rnd.randrange(len(b))] ^= 1 << rnd.randrange(8)
        return bytes(b)
    if kind == "cut-line":  # a line cut in the middle and joined to the next
        lines = data.split(b"\n")
        k = rnd.randrange(len(lines))
        lines[k] = lines[k][: rnd.randrange(len(lines[k]) + 1)]
        return b"\n".join(lines[:k] + [lines[k] + (lines[k + 1] if k + 1 < len(lines) else b"")] + lines[k + 2 :])
    return junk


@FUZZ
@given(case=damaged_recording(["imu.txt", "gnss.txt", "ldv.csv"]))
def test_damaged_recordings_import_is_stored_or_refused_naming_the_file(fuzz_client, recordings, case):
    files, partial = recordings
    name, kind, seed, junk = case
    sent = {**files, name: _damage(files[name], kind, seed, junk)}
    r = fuzz_client.post(
        "/api/imports",
        files=[("files", (n, d, "application/octet-stream")) for n, d in sent.items()],
        data={"manifest": json.dumps(partial)},
    )
    _judge(r, set(sent) | CONVERTED)


@FUZZ
@given(
    fmt=st.sampled_from(["novatel:imu", "novatel:gnss", "ubx:imu", "ubx:gnss", "nmea:gnss", "csv:imu"]),
    junk=st.binary(max_size=4096),
)
def test_random_bytes_named_as_a_binary_recording_are_refused_naming_the_file(fuzz_client, recordings, fmt, junk):
    files, partial = recordings
    role = fmt.split(":")[1]
    sent = {k: v for k, v in files.items() if not k.startswith(role)} | {"rec.bin": junk}
    r = fuzz_client.post(
        "/api/imports/preview",
        files=[("files", (n, d, "application/octet-stream")) for n, d in sent.items()],
        data={"manifest": json.dumps(partial), "formats": json.dumps({"rec.bin": fmt})},
    )
    _judge(r, set(sent) | {"formats", "manifest", "manifest (partial)"})
