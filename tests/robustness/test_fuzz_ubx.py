"""Property-based fuzzing of the u-blox reader: whatever the bytes, a part or a typed error naming the
file and the message (exit 2 / HTTP 422), never another exception (exit 1 / HTTP 500)."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers import get_importer

pytest.importorskip("pyubx2")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real"
FILES = sorted(REAL.glob("*.log")) if REAL.is_dir() else []
CFG = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck), database=None)
IDS = [b"\x10\x03", b"\x10\x02", b"\x01\x07", b"\x01\x14", b"\x01\x02", b"\x01\x06", b"\x01\x20", b"\x28\x00"]


def frame(cls_id: bytes, payload: bytes) -> bytes:
    """A UBX frame with a correct checksum around any payload (the u-blox framing, Fletcher-8)."""
    body = cls_id + struct.pack("<H", len(payload)) + payload
    a = b = 0
    for x in body:
        a = (a + x) & 0xFF
        b = (b + a) & 0xFF
    return b"\xb5\x62" + body + bytes((a, b))


def read_both(data: bytes, name: str = "fuzz.ubx") -> None:
    for role in ("imu", "gnss"):
        try:
            get_importer("ubx").read(data, name, role, {})
        except BundleError as exc:
            assert exc.file == name and exc.message


@CFG
@given(st.binary(max_size=2000))
def test_garbage(data):
    read_both(data)


@CFG
@given(st.lists(st.tuples(st.sampled_from(IDS), st.binary(max_size=120)), max_size=30))
def test_frames_with_good_checksums_and_any_payload(frames):
    """Checksums pass, payloads are anything: lengths, counts, dates and flags out of range."""
    read_both(b"".join(frame(c, p) for c, p in frames))


needs_real = pytest.mark.skipif(not FILES, reason="real u-blox fixtures not present")


@needs_real
@CFG
@given(st.data())
def test_real_files_cut_and_bit_flipped(data):
    path = data.draw(st.sampled_from(FILES))
    raw = bytearray(path.read_bytes())
    cut = data.draw(st.integers(0, len(raw)))
    raw = raw[:cut]
    for _ in range(data.draw(st.integers(0, 8))):
        if raw:
            k = data.draw(st.integers(0, len(raw) - 1))
            raw[k] ^= 1 << data.draw(st.integers(0, 7))
    read_both(bytes(raw), path.name)


@needs_real
@CFG
@given(st.data())
def test_real_frames_shuffled_and_repeated(data):
    path = data.draw(st.sampled_from(FILES))
    raw = path.read_bytes()
    frames, k = [], raw.find(b"\xb5\x62")
    while 0 <= k < len(raw) - 6:
        n = struct.unpack_from("<H", raw, k + 4)[0]
        frames.append(raw[k : k + 8 + n])
        k = raw.find(b"\xb5\x62", k + 8 + n)
    order = data.draw(st.permutations(list(range(len(frames)))))
    picked = [frames[i] for i in order[: data.draw(st.integers(0, len(frames)))]]
    picked += (
        [frames[i] for i in data.draw(st.lists(st.integers(0, max(len(frames) - 1, 0)), max_size=5))] if frames else []
    )
    read_both(b"".join(picked), path.name)


def test_cli_exit_code_on_bad_ubx(tmp_path, capsys):
    """Through the command line: exit 2 and a message naming the file, never exit 1."""
    from ldvsurvey import cli

    bad = tmp_path / "bad.ubx"
    bad.write_bytes(frame(b"\x10\x03", b"\x00" * 4 + struct.pack("<II", 16 << 24 | 5, 100) * 3) * 4)
    man = tmp_path / "partial.json"
    man.write_text('{"ldv": {"kind": "1d"}}')
    code = cli.main(["import", "--imu", f"ubx:{bad}", "--manifest", str(man), "--out", str(tmp_path / "o.zip")])
    assert code == 2 and "bad.ubx" in capsys.readouterr().err
    assert not (tmp_path / "o.zip").exists()
