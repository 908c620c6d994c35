"""Small, valid bundles made from random numbers, for format and storage tests.

They carry no physics: the parsers and the store do not need any. Physically
consistent bundles come from the product's simulator (``ldvsurvey.sim``).
"""

from __future__ import annotations

import copy

import numpy as np

from ldvsurvey.io.writers import imu_csv, ldv_csv, manifest_json, nmea_text

MANIFEST = {
    "format": "ldv-drive-log/1",
    "name": "test bundle",
    "date": "2023-03-20",
    "platform": "vehicle",
    "imu": {"rate_hz": 100, "rotating": False, "gyro_bias_dph": 0.003, "accel_bias_ug": 20},
    "ldv": {
        "kind": "2d",
        "rate_hz": 100,
        "min_quality": 100,
        "nominal": {"pitch_deg": 0.0, "heading_deg": 0.0, "scale": 1.0},
        "optics": {
            "wavelength_nm": 1064.0,
            "beam_angle_deg": 10.0,
            "surface_angle_deg": 30.0,
            "refractive_index": 1.00027,
        },
        "lever_arm_m": [0.0, 0.0, -0.8],
    },
    "gnss": {"lever_arm_m": [0.0, 0.5, 1.6]},
    "initial": {"lat_deg": 28.4861, "lon_deg": 113.0623, "h_m": 120.0, "static_s": 300},
    "vendor_extra": {"kept": True},
}


def make_arrays(n_imu=2000, rate=100.0, t0=30000.0, n_gnss=None, seed=0, rotating=False):
    rng = np.random.default_rng(seed)
    t = t0 + np.arange(1, n_imu + 1) / rate
    arr = {
        "t": t,
        "dtheta": rng.normal(0, 1e-5, (n_imu, 3)),
        "dvel": rng.normal(0, 1e-3, (n_imu, 3)) + [0, 0, 0.098],
        "turn": (np.floor(np.arange(n_imu) / 500) % 4 * 90.0) if rotating else None,
        "v_fwd": rng.uniform(0, 20, n_imu),
        "v_up": rng.normal(0, 0.1, n_imu),
        "quality": rng.integers(50, 300, n_imu).astype(float),
    }
    n_gnss = n_gnss or int(n_imu / rate) + 1
    tg = t0 + np.arange(n_gnss, dtype=float)
    arr["gnss"] = {
        "t": tg,
        "lat": 28.4861 + rng.normal(0, 1e-4, n_gnss),
        "lon": 113.0623 + rng.normal(0, 1e-4, n_gnss),
        "h": 120 + rng.normal(0, 1, n_gnss),
        "fix": np.where(np.arange(n_gnss) % 7 == 3, 2, 4),
    }
    return arr


def make_bundle(
    seed=0, n_imu=2000, manifest=None, gnss=True, fd=False, rotating=False, ldv=True, **kw
) -> dict[str, bytes]:
    """``{name: bytes}`` of a valid 2-D LDV bundle with random content (``ldv=False``: an INS/GNSS
    bundle, no ldv.csv and no manifest ldv section)."""
    m = copy.deepcopy(manifest or MANIFEST)
    if not ldv:
        m.pop("ldv", None)
    m["imu"]["rotating"] = rotating
    a = make_arrays(n_imu=n_imu, seed=seed, rotating=rotating, **kw)
    files = {
        "manifest.json": manifest_json(m),
        "imu.csv": imu_csv(a["t"], a["dtheta"], a["dvel"], a["turn"], comment="test IMU"),
        "ldv.csv": ldv_csv(
            a["t"],
            v_fwd_mps=None if fd else a["v_fwd"],
            v_up_mps=a["v_up"],
            quality=a["quality"],
            fd_hz=a["v_fwd"] * 1e5 if fd else None,
        ),
    }
    if not ldv:
        del files["ldv.csv"]
    if gnss:
        g = a["gnss"]
        files["gnss.nmea"] = nmea_text(g["t"], g["lat"], g["lon"], g["h"], g["fix"])
    return files


def zip_bytes(files: dict[str, bytes]) -> bytes:
    import io
    import zipfile

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for n, d in files.items():
            zf.writestr(n, d)
    return buf.getvalue()
