"""An ``ldv-drive-log/1`` bundle: read from a zip, a folder or a set of uploaded files."""

from __future__ import annotations

import hashlib
import io
import posixpath
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ldvsurvey.errors import BundleError, TooLargeError
from ldvsurvey.io.csvtable import check_time, read_numeric_csv
from ldvsurvey.io.imutime import regularize_imu
from ldvsurvey.io.manifest import Manifest, parse_manifest
from ldvsurvey.io.nmea import GnssData, parse_nmea

REQUIRED_FILES = ("manifest.json", "imu.csv", "ldv.csv")
OPTIONAL_FILES = ("gnss.nmea",)
KNOWN_FILES = REQUIRED_FILES + OPTIONAL_FILES
IMU_COLUMNS = ["t", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z"]
C0_MPS = 299_792_458.0


@dataclass
class ImuData:
    """IMU increments in the sensor frame s over (t_prev, t].

    Attributes
    ----------
    t_s : (N,) seconds of day; dtheta_rad : (N, 3) rad; dvel_mps : (N, 3) m/s;
    turntable_deg : (N,) encoder angle eta in degrees, or None for a fixed IMU.
    """

    t_s: np.ndarray
    dtheta_rad: np.ndarray
    dvel_mps: np.ndarray
    turntable_deg: np.ndarray | None = None
    duplicated_rows: int = 0
    bridged_rows: int = 0  #: rows inserted over short gaps in the time tags (see io.imutime)
    long_gaps: list = field(default_factory=list)  #: io.imutime.LongGap: too long to bridge


@dataclass
class LdvData:
    """LDV output: forward (and for 2-D, up) speed of the head in m/s.

    ``source`` is ``v_fwd`` or ``fd_hz`` (then ``fd_hz`` holds the raw frequency).
    """

    t_s: np.ndarray
    v_fwd_mps: np.ndarray
    v_up_mps: np.ndarray | None = None
    quality: np.ndarray | None = None
    fd_hz: np.ndarray | None = None
    source: str = "v_fwd"
    duplicated_rows: int = 0


@dataclass
class DriveLog:
    """A parsed, validated bundle plus its original file bytes."""

    manifest: Manifest
    imu: ImuData
    ldv: LdvData
    gnss: GnssData | None
    files: dict[str, bytes]
    warnings: list[str] = field(default_factory=list)

    @property
    def sha256(self) -> str:
        """Identity of the bundle: SHA-256 over the sorted (name, SHA-256 of content) pairs."""
        return bundle_sha256(self.files)


def bundle_sha256(files: dict[str, bytes]) -> str:
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + hashlib.sha256(files[name]).hexdigest().encode() + b"\n")
    return h.hexdigest()


def fd_to_v_fwd(fd_hz: np.ndarray, optics) -> np.ndarray:
    """Doppler frequency to forward speed: v = lambda0 f_D / (2 n_a sin(theta/2)), v_fwd = v / cos(lambda_s).

    Parameters
    ----------
    fd_hz : Doppler frequency f_D in Hz.
    optics : manifest ``ldv.optics`` (vacuum wavelength nm, beam angle deg, surface angle deg, n_a).

    Returns
    -------
    numpy.ndarray : forward speed in m/s.
    """
    lam0_m = optics.wavelength_nm * 1e-9
    half = np.deg2rad(optics.beam_angle_deg) / 2.0
    v = lam0_m * fd_hz / (2.0 * optics.refractive_index * np.sin(half))
    return v / np.cos(np.deg2rad(optics.surface_angle_deg))


def _drop_duplicate_rows(cols: dict[str, np.ndarray], lines: np.ndarray, file: str):
    """Drop rows that repeat the previous row exactly (a recorder re-sending a sample)."""
    t = cols["t"]
    same_t = np.flatnonzero(np.diff(t) == 0) + 1
    if len(same_t) == 0:
        return cols, lines, 0
    identical = np.ones(len(same_t), dtype=bool)
    for v in cols.values():
        identical &= v[same_t] == v[same_t - 1]
    drop = same_t[identical]
    if len(drop) == 0:
        return cols, lines, 0
    keep = np.ones(len(t), dtype=bool)
    keep[drop] = False
    return {k: v[keep] for k, v in cols.items()}, lines[keep], int(len(drop))


def parse_imu(data: bytes, manifest: Manifest) -> tuple[ImuData, list[str]]:
    """Parse ``imu.csv`` (see the format spec); ``turntable_deg`` is required for a rotating IMU."""
    file = "imu.csv"
    tab = read_numeric_csv(data, file, IMU_COLUMNS, optional=["turntable_deg"])
    warnings = list(tab.warnings)
    cols, lines, dups = _drop_duplicate_rows(tab.columns, tab.line_of_row, file)
    cols, lines, w, bridged, long_gaps = regularize_imu(cols, lines, manifest.imu.rate_hz, file)
    warnings += w
    if manifest.imu.rotating and "turntable_deg" not in cols:
        raise BundleError("manifest says imu.rotating is true but the column is missing",
                          file=file, line=1, field="turntable_deg")
    turn = cols.get("turntable_deg")
    if turn is not None and not manifest.imu.rotating:
        warnings.append("imu.csv: turntable_deg present but imu.rotating is false; ignored")
        turn = None
    if dups:
        warnings.append(f"imu.csv: {dups} exactly repeated row(s) dropped")
    imu = ImuData(t_s=cols["t"],
                  dtheta_rad=np.column_stack([cols["dtheta_x"], cols["dtheta_y"], cols["dtheta_z"]]),
                  dvel_mps=np.column_stack([cols["dvel_x"], cols["dvel_y"], cols["dvel_z"]]),
                  turntable_deg=turn, duplicated_rows=dups, bridged_rows=bridged, long_gaps=long_gaps)
    return imu, warnings


def parse_ldv(data: bytes, manifest: Manifest) -> tuple[LdvData, list[str]]:
    """Parse ``ldv.csv``; ``fd_hz`` is converted to ``v_fwd`` with the manifest optics."""
    file = "ldv.csv"
    kind = manifest.ldv.kind
    optional = ["quality"] + (["v_up"] if kind == "2d" else [])
    required = ["t"] + (["v_up"] if kind == "2d" else [])
    tab = read_numeric_csv(data, file, required, optional=optional,
                           alternatives=[("v_fwd", "fd_hz")])
    warnings = list(tab.warnings)
    cols, lines, dups = _drop_duplicate_rows(tab.columns, tab.line_of_row, file)
    check_time(cols["t"], lines, file)
    if dups:
        warnings.append(f"ldv.csv: {dups} exactly repeated row(s) dropped")
    fd = None
    if "fd_hz" in cols:
        if manifest.ldv.optics is None:
            raise BundleError("ldv.csv carries fd_hz but the manifest has no ldv.optics",
                              file="manifest.json", field="ldv.optics")
        fd = cols["fd_hz"]
        v_fwd = fd_to_v_fwd(fd, manifest.ldv.optics)
        source = "fd_hz"
    else:
        v_fwd, source = cols["v_fwd"], "v_fwd"
    ldv = LdvData(t_s=cols["t"], v_fwd_mps=v_fwd, v_up_mps=cols.get("v_up"),
                  quality=cols.get("quality"), fd_hz=fd, source=source, duplicated_rows=dups)
    return ldv, warnings


def parse_files(files: dict[str, bytes]) -> DriveLog:
    """Validate and parse a bundle given as ``{file name: bytes}``.

    Raises
    ------
    BundleError
        On the first defect, naming the file, line and field.
    """
    for name in REQUIRED_FILES:
        if name not in files:
            raise BundleError(f"required file '{name}' is missing from the bundle "
                              f"(got: {', '.join(sorted(files)) or 'nothing'})", file=name)
    extra = sorted(set(files) - set(KNOWN_FILES))
    warnings = [f"file '{n}' is not part of the format and was ignored" for n in extra]
    files = {k: v for k, v in files.items() if k in KNOWN_FILES}
    manifest = parse_manifest(files["manifest.json"])
    imu, w = parse_imu(files["imu.csv"], manifest)
    warnings += w
    ldv, w = parse_ldv(files["ldv.csv"], manifest)
    warnings += w
    gnss = None
    if "gnss.nmea" in files:
        gnss = parse_nmea(files["gnss.nmea"], t_ref_s=float(imu.t_s[0]))
        warnings += gnss.warnings
    if ldv.t_s[-1] < imu.t_s[0] or ldv.t_s[0] > imu.t_s[-1]:
        raise BundleError(f"LDV times [{ldv.t_s[0]:.2f}, {ldv.t_s[-1]:.2f}] s do not overlap the IMU's "
                          f"[{imu.t_s[0]:.2f}, {imu.t_s[-1]:.2f}] s (same clock expected)",
                          file="ldv.csv", field="t")
    for ln in manifest.lines:
        if not (ln.t_end > ln.t_start):
            raise BundleError(f"line '{ln.name}' ends before it starts", file="manifest.json",
                              field="lines")
    return DriveLog(manifest=manifest, imu=imu, ldv=ldv, gnss=gnss, files=files, warnings=warnings)


def read_zip(data, max_unzipped_bytes: int, max_ratio: float = 200.0,
             name: str = "upload.zip") -> dict[str, bytes]:
    """Members of a bundle zip, refusing traversal, absolute paths and zip bombs.

    ``data`` is the archive's bytes, or its path or an open binary file (then the compressed
    archive is read from disk member by member, never held in memory whole).
    Files may sit at the top level or inside one common top folder.
    """
    try:
        zf = zipfile.ZipFile(io.BytesIO(data) if isinstance(data, (bytes, bytearray, memoryview)) else data)
        infos = zf.infolist()
    except (zipfile.BadZipFile, EOFError, ValueError) as exc:
        raise BundleError(f"not a readable zip archive (truncated or corrupt: {exc})", file=name) from None
    members = {}
    total = 0
    for info in infos:
        fn = info.filename
        if fn.startswith(("/", "\\")) or (len(fn) > 1 and fn[1] == ":") or ".." in fn.replace("\\", "/").split("/"):
            raise BundleError(f"unsafe path in archive: '{fn}'", file=name, field=fn)
        if info.is_dir() or fn.startswith("__MACOSX/") or posixpath.basename(fn).startswith("._"):
            continue
        if info.file_size > max_unzipped_bytes or total + info.file_size > max_unzipped_bytes:
            raise TooLargeError(f"archive unpacks to more than {max_unzipped_bytes} bytes", file=name, field=fn)
        if info.compress_size and info.file_size / info.compress_size > max_ratio and info.file_size > 1 << 20:
            raise TooLargeError(f"member '{fn}' compresses {info.file_size / info.compress_size:.0f}:1 "
                                f"(limit {max_ratio:.0f}:1): refusing a possible zip bomb", file=name, field=fn)
        try:
            with zf.open(info) as fh:  # read with a hard cap: headers can lie
                content = fh.read(max_unzipped_bytes - total + 1)
        except (zipfile.BadZipFile, EOFError, OSError, ValueError, NotImplementedError) as exc:
            raise BundleError(f"member '{fn}' cannot be read (truncated or corrupt: {exc})",
                              file=name, field=fn) from None
        total += len(content)
        if total > max_unzipped_bytes:
            raise TooLargeError(f"archive unpacks to more than {max_unzipped_bytes} bytes", file=name, field=fn)
        members[fn] = content
    if not members:
        raise BundleError("archive holds no files", file=name)
    tops = {m.split("/", 1)[0] for m in members}
    if len(tops) == 1 and all("/" in m for m in members):
        members = {m.split("/", 1)[1]: v for m, v in members.items()}
    nested = [m for m in members if "/" in m]
    if nested:
        raise BundleError(f"files must sit at the top level of the archive: '{nested[0]}'", file=name)
    return members


def read_bundle_path(path: str | Path, max_unzipped_bytes: int = 4 << 30) -> dict[str, bytes]:
    """Files of a bundle given as a ``.zip`` path or a folder."""
    p = Path(path)
    if not p.exists():
        raise BundleError("no such file or folder", file=str(p))
    if p.is_dir():
        return {f.name: f.read_bytes() for f in sorted(p.iterdir()) if f.is_file() and f.name in KNOWN_FILES}
    return read_zip(p, max_unzipped_bytes, name=p.name)


def load_bundle(path: str | Path) -> DriveLog:
    """Read, validate and parse a bundle from a zip or folder path."""
    return parse_files(read_bundle_path(path))
