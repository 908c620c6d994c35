"""The bad-input matrix: each case is a defect a real file can have, with where it is."""

from __future__ import annotations

import io
import json
import struct
import zipfile

from tests.bundles import make_bundle, zip_bytes
from tests.helpers.nmea import sentence


def _lines(b: bytes) -> list[str]:
    return b.decode().split("\n")


def _join(lines: list[str]) -> bytes:
    return "\n".join(lines).encode()


def _set_cell(files, name, data_row, column, value):
    """Replace one cell; returns the 1-based file line of that row."""
    lines = _lines(files[name])
    hdr = next(i for i, ln in enumerate(lines) if ln and not ln.startswith("#"))
    cols = lines[hdr].split(",")
    li = hdr + 1 + data_row
    cells = lines[li].split(",")
    cells[cols.index(column)] = value
    lines[li] = ",".join(cells)
    files[name] = _join(lines)
    return li + 1


def _rename_column(files, name, old, new):
    lines = _lines(files[name])
    hdr = next(i for i, ln in enumerate(lines) if ln and not ln.startswith("#"))
    lines[hdr] = ",".join(new if c == old else c for c in lines[hdr].split(","))
    files[name] = _join(lines)
    return hdr + 1


def _drop_column(files, name, column):
    lines = _lines(files[name])
    hdr = next(i for i, ln in enumerate(lines) if ln and not ln.startswith("#"))
    j = lines[hdr].split(",").index(column)
    out = []
    for i, ln in enumerate(lines):
        if i >= hdr and ln:
            cells = ln.split(",")
            del cells[j]
            ln = ",".join(cells)
        out.append(ln)
    files[name] = _join(out)
    return hdr + 1


def _manifest(files, change):
    m = json.loads(files["manifest.json"])
    change(m)
    files["manifest.json"] = (json.dumps(m, indent=2) + "\n").encode()


def case(name):
    """(files, expected) for the named defect. expected: dict(file=, line=, field=) (None = not checked)."""
    f = make_bundle(seed=11, n_imu=1500)
    exp = {}
    if name == "missing_column":
        exp = dict(file="imu.csv", line=_drop_column(f, "imu.csv", "dvel_z"), field="dvel_z")
    elif name == "misspelled_column":
        exp = dict(file="ldv.csv", line=_rename_column(f, "ldv.csv", "v_up", "v_upp"), field="v_upp")
    elif name == "non_numeric_cell":
        exp = dict(file="imu.csv", line=_set_cell(f, "imu.csv", 700, "dvel_y", "0.0x1"), field="dvel_y")
    elif name == "nan_cell":
        exp = dict(file="ldv.csv", line=_set_cell(f, "ldv.csv", 42, "v_fwd", "NaN"), field="v_fwd")
    elif name == "inf_cell":
        exp = dict(file="imu.csv", line=_set_cell(f, "imu.csv", 1499, "dtheta_z", "inf"), field="dtheta_z")
    elif name == "empty_cell":
        exp = dict(file="ldv.csv", line=_set_cell(f, "ldv.csv", 3, "quality", ""), field="quality")
    elif name == "short_row":
        lines = _lines(f["imu.csv"])
        lines[200] = lines[200].rsplit(",", 1)[0]
        f["imu.csv"] = _join(lines)
        exp = dict(file="imu.csv", line=201, field=None)
    elif name == "empty_imu":
        f["imu.csv"] = b""
        exp = dict(file="imu.csv", line=1, field=None)
    elif name == "empty_ldv_header_only":
        f["ldv.csv"] = b"t,v_fwd,v_up,quality\n"
        exp = dict(file="ldv.csv", line=2, field=None)
    elif name == "time_backwards":
        lines = _lines(f["ldv.csv"])
        t_prev = float(lines[500].split(",")[0])
        exp = dict(file="ldv.csv", line=_set_cell(f, "ldv.csv", 500, "t", repr(t_prev - 0.5)), field="t")
    elif name == "time_repeats":
        lines = _lines(f["imu.csv"])
        t_prev = lines[800].split(",")[0]  # data row 798 (comment + header before)
        exp = dict(file="imu.csv", line=_set_cell(f, "imu.csv", 799, "t", t_prev), field="t")
    elif name == "manifest_key_missing":
        _manifest(f, lambda m: m["ldv"].pop("kind"))
        exp = dict(file="manifest.json", line=None, field="ldv.kind")
    elif name == "manifest_wrong_type":
        _manifest(f, lambda m: m["imu"].__setitem__("rotating", "yes"))
        exp = dict(file="manifest.json", line=None, field="imu.rotating")
    elif name == "manifest_unit_as_string":
        _manifest(f, lambda m: m["imu"].__setitem__("rate_hz", "100 Hz"))
        exp = dict(file="manifest.json", line=None, field="imu.rate_hz")
    elif name == "manifest_bad_json":
        f["manifest.json"] = f["manifest.json"].replace(b'"platform"', b"platform", 1)
        exp = dict(file="manifest.json", line=None, field=None)
    elif name == "missing_file":
        del f["ldv.csv"]
        exp = dict(file="ldv.csv", line=None, field=None)
    elif name == "ldv_without_manifest_section":
        _manifest(f, lambda m: m.pop("ldv"))  # ldv.csv kept: nothing says what it measures
        exp = dict(file="manifest.json", line=None, field="ldv")
    elif name == "nmea_bad_altitude":
        lines = f["gnss.nmea"].decode().split("\r\n")
        body = lines[4][1:].split("*")[0].split(",")
        body[9] = "12a.5"
        lines[4] = sentence(",".join(body))
        f["gnss.nmea"] = "\r\n".join(lines).encode()
        exp = dict(file="gnss.nmea", line=5, field="altitude")
    elif name == "nmea_time_backwards":
        lines = f["gnss.nmea"].decode().split("\r\n")
        lines[4], lines[6] = lines[6], lines[4]  # GGA of epochs 2 and 3 swapped
        f["gnss.nmea"] = "\r\n".join(lines).encode()
        exp = dict(file="gnss.nmea", line=7, field="time")
    elif name == "fd_without_optics":
        f = make_bundle(seed=11, n_imu=1500, fd=True)
        _manifest(f, lambda m: m["ldv"].pop("optics"))
        exp = dict(file="manifest.json", line=None, field="ldv.optics")
    elif name == "both_v_fwd_and_fd":
        lines = _lines(f["ldv.csv"])
        lines = [ln + (",fd_hz" if i == 0 else ",1.0") if ln else ln for i, ln in enumerate(lines)]
        f["ldv.csv"] = _join(lines)
        exp = dict(file="ldv.csv", line=1, field="v_fwd")
    else:
        raise KeyError(name)
    return f, exp


CASES = [
    "missing_column",
    "misspelled_column",
    "non_numeric_cell",
    "nan_cell",
    "inf_cell",
    "empty_cell",
    "short_row",
    "empty_imu",
    "empty_ldv_header_only",
    "time_backwards",
    "time_repeats",
    "manifest_key_missing",
    "manifest_wrong_type",
    "manifest_unit_as_string",
    "manifest_bad_json",
    "missing_file",
    "ldv_without_manifest_section",
    "nmea_bad_altitude",
    "nmea_time_backwards",
    "fd_without_optics",
    "both_v_fwd_and_fd",
]


def truncated_zip() -> bytes:
    z = zip_bytes(make_bundle(seed=12, n_imu=1500))
    return z[: len(z) // 2]


def traversal_zip(path: str) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for n, d in make_bundle(seed=12, n_imu=500).items():
            zf.writestr(n, d)
        zf.writestr(zipfile.ZipInfo(path), b"owned")
    return buf.getvalue()


def bomb_zip(size: int) -> bytes:
    buf = io.BytesIO()
    files = make_bundle(seed=12, n_imu=500)
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for n, d in files.items():
            zf.writestr(n, d)
        zf.writestr("padding.bin", b"\0" * size)
    return buf.getvalue()


def member_data_offset(archive: bytes, member: str) -> int:
    """Where the (compressed) data of ``member`` starts in ``archive``: after its local header."""
    info = zipfile.ZipFile(io.BytesIO(archive)).getinfo(member)
    name_len, extra_len = struct.unpack("<HH", archive[info.header_offset + 26 : info.header_offset + 30])
    return info.header_offset + 30 + name_len + extra_len


def corrupt_deflate_zip(member: str = "imu.csv") -> bytes:
    """A bundle zip whose ``member`` has corrupt deflate data (its directory and sizes intact): the
    first block claims to be a stored block, so inflating fails with zlib's "invalid stored block
    lengths"."""
    z = bytearray(zip_bytes(make_bundle(seed=12, n_imu=500)))
    z[member_data_offset(bytes(z), member)] = 0x00  # BFINAL=0, BTYPE=00 (stored), then garbage lengths
    return bytes(z)


def encrypted_flag_zip(member: str = "imu.csv") -> bytes:
    """A bundle zip whose central directory marks ``member`` as encrypted (general-purpose flag bit
    0): zipfile then asks for a password (a RuntimeError)."""
    z = bytearray(zip_bytes(make_bundle(seed=12, n_imu=500)))
    info = zipfile.ZipFile(io.BytesIO(bytes(z))).getinfo(member)
    pos = z.find(b"PK\x01\x02")
    while struct.unpack("<I", z[pos + 42 : pos + 46])[0] != info.header_offset:
        pos = z.find(b"PK\x01\x02", pos + 4)
    z[pos + 8] |= 0x1
    return bytes(z)


def wide_imu(files: dict[str, bytes], extra: int) -> dict[str, bytes]:
    """``files`` with ``extra`` unknown columns added to the header of imu.csv (line 2, after a comment)."""
    lines = files["imu.csv"].split(b"\n")
    assert lines[0].startswith(b"#") and lines[1].startswith(b"t,")
    lines[1] += b"," + b",".join(b"c%d" % i for i in range(extra))
    return {**files, "imu.csv": b"\n".join(lines)}
