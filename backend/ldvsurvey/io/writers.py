"""Writers for the ``ldv-drive-log/1`` files (used by the simulator, the demo and tests)."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from ldvsurvey.io.nmea import format_gga


def csv_bytes(columns: dict[str, np.ndarray], comment: str | None = None) -> bytes:
    """Numeric columns to CSV bytes (shortest round-trip float text), optional ``#`` comment first."""
    table = pa.table({k: np.asarray(v, dtype=np.float64) for k, v in columns.items()})
    buf = io.BytesIO()
    if comment:
        buf.write(f"# {comment}\n".encode())
    buf.write((",".join(table.column_names) + "\n").encode())
    pacsv.write_csv(table, buf, write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return buf.getvalue()


def imu_csv(t_s, dtheta_rad, dvel_mps, turntable_deg=None, comment=None) -> bytes:
    """``imu.csv`` bytes from (N,) times, (N,3) angle increments (rad), (N,3) velocity increments (m/s)."""
    cols = {"t": t_s, "dtheta_x": dtheta_rad[:, 0], "dtheta_y": dtheta_rad[:, 1], "dtheta_z": dtheta_rad[:, 2],
            "dvel_x": dvel_mps[:, 0], "dvel_y": dvel_mps[:, 1], "dvel_z": dvel_mps[:, 2]}
    if turntable_deg is not None:
        cols["turntable_deg"] = turntable_deg
    return csv_bytes(cols, comment)


def ldv_csv(t_s, v_fwd_mps=None, v_up_mps=None, quality=None, fd_hz=None, comment=None) -> bytes:
    """``ldv.csv`` bytes; give either ``v_fwd_mps`` or ``fd_hz``."""
    cols = {"t": t_s}
    if fd_hz is not None:
        cols["fd_hz"] = fd_hz
    else:
        cols["v_fwd"] = v_fwd_mps
    if v_up_mps is not None:
        cols["v_up"] = v_up_mps
    if quality is not None:
        cols["quality"] = quality
    return csv_bytes(cols, comment)


def nmea_text(t_s, lat_deg, lon_deg, h_ell_m, fix, sep_m: float = -16.0, talker: str = "GP",
              extra_sentences: bool = True) -> bytes:
    """``gnss.nmea`` bytes: one GGA per epoch (altitude = ellipsoidal height − separation), CRLF."""
    lines = []
    for k in range(len(t_s)):
        lines.append(format_gga(float(t_s[k]), float(lat_deg[k]), float(lon_deg[k]),
                                float(h_ell_m[k]) - sep_m, sep_m, int(fix[k]), talker=talker))
        if extra_sentences:
            body = f"{talker}GSA,A,3,01,02,03,04,05,06,07,08,,,,,1.5,0.9,1.2"
            acc = 0
            for ch in body.encode():
                acc ^= ch
            lines.append(f"${body}*{acc:02X}")
    return ("\r\n".join(lines) + "\r\n").encode()


def manifest_json(manifest: dict) -> bytes:
    return (json.dumps(manifest, indent=2) + "\n").encode()


def write_bundle(files: dict[str, bytes], path: str | Path) -> Path:
    """Write ``{name: bytes}`` as a folder, or as a zip when ``path`` ends in ``.zip``."""
    p = Path(path)
    if p.suffix.lower() == ".zip":
        p.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
            for name, data in files.items():
                zf.writestr(name, data)
    else:
        p.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (p / name).write_bytes(data)
    return p
