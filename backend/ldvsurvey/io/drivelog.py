"""An ``ldv-drive-log/1`` bundle: read from a zip, a folder or a set of uploaded files."""

from __future__ import annotations

import fcntl
import hashlib
import io
import os
import posixpath
import shutil
import struct
import tempfile
import weakref
import zipfile
import zlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ldvsurvey.errors import BundleError, TooLargeError
from ldvsurvey.io.csvtable import check_time, read_numeric_csv
from ldvsurvey.io.imutime import regularize_imu
from ldvsurvey.io.manifest import Manifest, parse_manifest
from ldvsurvey.io.nmea import GnssData, parse_nmea

REQUIRED_FILES = ("manifest.json", "imu.csv")
#: ldv.csv is there exactly when the manifest has an ``ldv`` section (an INS/GNSS log has neither)
OPTIONAL_FILES = ("ldv.csv", "gnss.nmea")
KNOWN_FILES = REQUIRED_FILES + OPTIONAL_FILES
#: files parsed from memory (a DriveLog holds them as bytes); the CSV files may stay on disk
SMALL_FILES = ("manifest.json", "gnss.nmea")
IMU_COLUMNS = ["t", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z"]
#: imu.csv columns read straight into one (N, 3) array each
IMU_GROUPS = {"dtheta": ["dtheta_x", "dtheta_y", "dtheta_z"], "dvel": ["dvel_x", "dvel_y", "dvel_z"]}
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
    bridges: list = field(default_factory=list)  #: io.imutime.BridgedGap: the short gaps bridged


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
    """A parsed, validated bundle plus its original files.

    ``files`` maps each file name to its bytes or to the path of a file holding them byte for byte
    (a file of a :class:`BundleFiles` folder, or of the log store); ``file_sha256`` their SHA-256.
    """

    manifest: Manifest
    imu: ImuData
    ldv: LdvData | None  #: None: a log without an LDV (no ldv.csv, no manifest ``ldv`` section)
    gnss: GnssData | None
    files: dict[str, bytes | Path]
    warnings: list[str] = field(default_factory=list)
    file_sha256: dict[str, str] = field(default_factory=dict)
    #: keeps the temporary folder of path-valued ``files`` alive as long as the log
    keep: object = field(default=None, repr=False, compare=False)

    def sha256_of(self, name: str) -> str:
        """SHA-256 (hex) of one original file (computed once)."""
        h = self.file_sha256.get(name)
        if h is None:
            h = self.file_sha256[name] = file_sha256(self.files[name])
        return h

    def size_of(self, name: str) -> int:
        """Size in bytes of one original file."""
        v = self.files[name]
        if isinstance(v, (bytes, bytearray, memoryview)):
            return len(v)
        size = getattr(v, "size_bytes", None)  # a stored file named without being read
        return size if size is not None else os.path.getsize(v)

    @property
    def sha256(self) -> str:
        """Identity of the bundle: SHA-256 over the sorted (name, SHA-256 of content) pairs."""
        return _combine({name: self.sha256_of(name) for name in self.files})


def file_sha256(data: bytes | Path) -> str:
    """SHA-256 (hex) of bytes or of a file's content (read in chunks)."""
    if isinstance(data, (bytes, bytearray, memoryview)):
        return hashlib.sha256(data).hexdigest()
    h = hashlib.sha256()
    with open(data, "rb") as fh:
        while chunk := fh.read(1 << 22):
            h.update(chunk)
    return h.hexdigest()


def _combine(hashes: dict[str, str]) -> str:
    h = hashlib.sha256()
    for name in sorted(hashes):
        h.update(name.encode() + b"\0" + hashes[name].encode() + b"\n")
    return h.hexdigest()


def bundle_sha256(files: dict[str, bytes | Path]) -> str:
    """SHA-256 (hex) of a bundle: of its files' names and SHA-256 in name order, so that the order given does not
    matter."""
    return _combine({name: file_sha256(v) for name, v in files.items()})


#: the lock file of a staging folder, held (``flock``) by the process using the folder
FOLDER_LOCK = ".lock"


def _lock_folder(path: Path) -> int:
    """Create and hold ``path/.lock``; the kernel frees the lock when the process ends, even killed."""
    fd = os.open(path / FOLDER_LOCK, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BaseException:
        os.close(fd)
        raise
    return fd


def _remove_folder(path: str, lock_fd: int) -> None:
    try:
        shutil.rmtree(path, True)
    finally:
        os.close(lock_fd)


class _TempFolder:
    """A temporary folder removed when the last object referring to it goes (or at exit)."""

    def __init__(self, parent: str | Path | None = None):
        if parent is not None:
            Path(parent).mkdir(parents=True, exist_ok=True)
        self.path = Path(tempfile.mkdtemp(prefix="ldvs-bundle-", dir=parent))
        # held while the folder lives: a folder whose lock is free was left by a process that died
        # (ldvsurvey.store.leftovers removes it)
        lock = _lock_folder(self.path)
        self._done = weakref.finalize(self, _remove_folder, str(self.path), lock)

    def cleanup(self) -> None:
        self._done()


class BundleFiles(dict):
    """``{file name: bytes or Path}`` of a bundle whose large files sit in a temporary folder on disk
    (removed when the last of this dict and the :class:`DriveLog` parsed from it goes), with the
    SHA-256 of the files already hashed while they were written (``sha256``)."""

    def __init__(self, *args, folder: _TempFolder | None = None, sha256: dict[str, str] | None = None, **kw):
        super().__init__(*args, **kw)
        self.folder = folder
        self.sha256 = dict(sha256 or {})

    @classmethod
    def in_temp_folder(cls, parent: str | Path | None = None) -> BundleFiles:
        """An empty bundle whose files go into a new temporary folder (under ``parent``, or the system's)."""
        return cls(folder=_TempFolder(parent))

    def write(self, name: str, chunks) -> Path:
        """Write ``name`` from an iterable of byte chunks into the folder, hashing it on the way."""
        return self.write_all([(name, chunks)])[0]

    def write_all(self, items: list[tuple[str, object]]) -> list[Path]:
        """:meth:`write` for several files at once, each in its own thread (inflating, hashing and
        writing release the GIL); the first failure is raised once all have stopped."""

        def one(k, name, chunks):
            path = self.folder.path / f"{len(self) + k}-{name}"
            h = hashlib.sha256()
            with open(path, "wb") as out:
                for chunk in chunks:
                    h.update(chunk)
                    out.write(chunk)
            return path, h.hexdigest()

        if len(items) == 1:
            done = [one(0, *items[0])]
        else:
            with ThreadPoolExecutor(max_workers=min(len(items), os.cpu_count() or 2)) as pool:
                futures = [pool.submit(one, k, name, chunks) for k, (name, chunks) in enumerate(items)]
            done = [f.result() for f in futures]  # in order: the first member's error first
        for (name, _), (path, sha) in zip(items, done):
            self[name] = path
            self.sha256[name] = sha
        return [path for path, _ in done]


def _small(v: bytes | Path) -> bytes:
    return bytes(v) if isinstance(v, (bytes, bytearray, memoryview)) else Path(v).read_bytes()


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


def _stacked(cols: dict, names: list[str], whole: np.ndarray | None) -> np.ndarray:
    """The (N, 3) array of ``names``: ``whole`` itself when the columns are still its views (no row
    was dropped, reordered or inserted), else a new stack."""
    if whole is not None and all(cols[n].base is whole and len(cols[n]) == len(whole) for n in names):
        return whole
    return np.column_stack([cols[n] for n in names])


def parse_imu(data: bytes | Path, manifest: Manifest) -> tuple[ImuData, list[str]]:
    """Parse ``imu.csv`` (see the format spec); ``turntable_deg`` is required for a rotating IMU."""
    file = "imu.csv"
    tab = read_numeric_csv(data, file, IMU_COLUMNS, optional=["turntable_deg"], groups=IMU_GROUPS)
    warnings = list(tab.warnings)
    cols, lines, dups = _drop_duplicate_rows(tab.columns, tab.line_of_row, file)
    reg = regularize_imu(cols, lines, manifest.imu.rate_hz, file)
    cols = reg.cols
    warnings += reg.warnings
    if manifest.imu.rotating and "turntable_deg" not in cols:
        raise BundleError(
            "manifest says imu.rotating is true but the column is missing", file=file, line=1, field="turntable_deg"
        )
    turn = cols.get("turntable_deg")
    if turn is not None and not manifest.imu.rotating:
        warnings.append("imu.csv: turntable_deg present but imu.rotating is false; ignored")
        turn = None
    if dups:
        warnings.append(f"imu.csv: {dups} exactly repeated row(s) dropped")
    imu = ImuData(
        t_s=cols["t"],
        dtheta_rad=_stacked(cols, IMU_GROUPS["dtheta"], tab.groups.get("dtheta")),
        dvel_mps=_stacked(cols, IMU_GROUPS["dvel"], tab.groups.get("dvel")),
        turntable_deg=turn,
        duplicated_rows=dups,
        bridged_rows=reg.n_bridged_rows,
        long_gaps=reg.long_gaps,
        bridges=reg.bridged,
    )
    return imu, warnings


def parse_ldv(data: bytes | Path, manifest: Manifest) -> tuple[LdvData, list[str]]:
    """Parse ``ldv.csv``; ``fd_hz`` is converted to ``v_fwd`` with the manifest optics."""
    file = "ldv.csv"
    kind = manifest.ldv.kind
    optional = ["quality"] + (["v_up"] if kind == "2d" else [])
    required = ["t"] + (["v_up"] if kind == "2d" else [])
    tab = read_numeric_csv(data, file, required, optional=optional, alternatives=[("v_fwd", "fd_hz")])
    warnings = list(tab.warnings)
    cols, lines, dups = _drop_duplicate_rows(tab.columns, tab.line_of_row, file)
    check_time(cols["t"], lines, file)
    if dups:
        warnings.append(f"ldv.csv: {dups} exactly repeated row(s) dropped")
    fd = None
    if "fd_hz" in cols:
        if manifest.ldv.optics is None:
            raise BundleError(
                "ldv.csv carries fd_hz but the manifest has no ldv.optics", file="manifest.json", field="ldv.optics"
            )
        fd = cols["fd_hz"]
        v_fwd = fd_to_v_fwd(fd, manifest.ldv.optics)
        source = "fd_hz"
    else:
        v_fwd, source = cols["v_fwd"], "v_fwd"
    ldv = LdvData(
        t_s=cols["t"],
        v_fwd_mps=v_fwd,
        v_up_mps=cols.get("v_up"),
        quality=cols.get("quality"),
        fd_hz=fd,
        source=source,
        duplicated_rows=dups,
    )
    return ldv, warnings


def parse_files(files: dict[str, bytes | Path]) -> DriveLog:
    """Validate and parse a bundle given as ``{file name: bytes or path}`` (a :class:`BundleFiles`
    passes on its folder and the hashes it knows to the log; a refused bundle's folder is removed
    at once, not whenever the last reference to it goes).

    Raises
    ------
    BundleError
        On the first defect, naming the file, line and field.
    """
    try:
        return _parse_files(files)
    except BundleError:
        folder = getattr(files, "folder", None)
        if folder is not None:
            folder.cleanup()
        raise


def _parse_files(files: dict[str, bytes | Path]) -> DriveLog:
    for name in REQUIRED_FILES:
        if name not in files:
            raise BundleError(
                f"required file '{name}' is missing from the bundle (got: {', '.join(sorted(files)) or 'nothing'})",
                file=name,
            )
    extra = sorted(set(files) - set(KNOWN_FILES))
    warnings = [f"file '{n}' is not part of the format and was ignored" for n in extra]
    known_sha = {k: v for k, v in getattr(files, "sha256", {}).items() if k in KNOWN_FILES}
    keep = getattr(files, "folder", None)
    files = {k: v for k, v in files.items() if k in KNOWN_FILES}
    for name in SMALL_FILES:  # read whole anyway: kept as bytes
        if name in files:
            files[name] = _small(files[name])
    manifest = parse_manifest(files["manifest.json"])
    if manifest.ldv is None and "ldv.csv" in files:
        raise BundleError(
            "the bundle has ldv.csv but the manifest has no ldv section (kind, rate_hz) describing it",
            file="manifest.json",
            field="ldv",
        )
    if manifest.ldv is not None and "ldv.csv" not in files:
        raise BundleError(
            "the manifest has an ldv section but the bundle has no ldv.csv (a log without an LDV has neither; "
            f"got: {', '.join(sorted(files))})",
            file="ldv.csv",
        )
    imu, w = parse_imu(files["imu.csv"], manifest)
    warnings += w
    # gnss.nmea (mostly Python) is parsed in a second thread while pyarrow parses ldv.csv (releasing the
    # GIL); ldv.csv's result is taken first, so a bundle with defects in both still names ldv.csv's.
    # (imu.csv is parsed alone: two large Arrow tables at once would raise the peak memory.)
    ldv = None
    with ThreadPoolExecutor(max_workers=1) as pool:
        gnss_job = None
        if "gnss.nmea" in files:
            gnss_job = pool.submit(parse_nmea, files["gnss.nmea"], t_ref_s=float(imu.t_s[0]))
        if "ldv.csv" in files:
            ldv, w = parse_ldv(files["ldv.csv"], manifest)
            warnings += w
        gnss = gnss_job.result() if gnss_job is not None else None
    if gnss is not None:
        warnings += gnss.warnings
    if ldv is not None and (ldv.t_s[-1] < imu.t_s[0] or ldv.t_s[0] > imu.t_s[-1]):
        raise BundleError(
            f"LDV times [{ldv.t_s[0]:.2f}, {ldv.t_s[-1]:.2f}] s do not overlap the IMU's "
            f"[{imu.t_s[0]:.2f}, {imu.t_s[-1]:.2f}] s (same clock expected)",
            file="ldv.csv",
            field="t",
        )
    for ln in manifest.lines:
        if not (ln.t_end > ln.t_start):
            raise BundleError(f"line '{ln.name}' ends before it starts", file="manifest.json", field="lines")
    return DriveLog(
        manifest=manifest, imu=imu, ldv=ldv, gnss=gnss, files=files, warnings=warnings, file_sha256=known_sha, keep=keep
    )


#: what reading a damaged archive raises: a bad directory or header (BadZipFile, EOFError,
#: struct.error, ValueError), corrupt deflate data (zlib.error), a wrong CRC (BadZipFile), an unknown
#: compression method (NotImplementedError); each becomes a BundleError naming the archive and member
ZIP_READ_ERRORS = (zipfile.BadZipFile, zlib.error, struct.error, EOFError, OSError, ValueError, NotImplementedError)


def read_zip(data, max_unzipped_bytes: int, max_ratio: float = 200.0, name: str = "upload.zip") -> dict[str, bytes]:
    """Members of a bundle zip, refusing traversal, absolute paths and zip bombs.

    ``data`` is the archive's bytes, or its path or an open binary file (then the compressed
    archive is read from disk member by member, never held in memory whole).
    Files may sit at the top level or inside one common top folder.
    """
    zf, infos = _open_zip(io.BytesIO(data) if isinstance(data, (bytes, bytearray, memoryview)) else data, name)
    members = {}
    total = 0
    for info in infos:
        fn = info.filename
        if not _screen_member(info, name, total, max_unzipped_bytes, max_ratio):
            continue
        try:
            with zf.open(info) as fh:  # read with a hard cap: headers can lie
                content = fh.read(max_unzipped_bytes - total + 1)
        except ZIP_READ_ERRORS as exc:
            raise BundleError(
                f"member '{fn}' cannot be read (truncated or corrupt: {exc})", file=name, field=fn
            ) from None
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


def stage_zip(
    path: str | Path,
    max_unzipped_bytes: int,
    max_ratio: float = 200.0,
    name: str | None = None,
    parent: str | Path | None = None,
) -> BundleFiles:
    """The bundle files of a zip inflated into a temporary folder (under ``parent``), never held in
    memory whole; the checks and messages of :func:`read_zip`. Files of the archive that are not
    part of the format map to ``b""`` (the parser names them in a warning; they are not inflated)."""
    name = name or Path(path).name
    zf, infos = _open_zip(path, name)
    with zf:
        entries = []
        declared = 0
        for info in infos:
            if not _screen_member(info, name, declared, max_unzipped_bytes, max_ratio):
                continue
            declared += info.file_size
            entries.append((info.filename, info))
        if not entries:
            raise BundleError("archive holds no files", file=name)
        names = [fn for fn, _ in entries]
        if len({n.split("/", 1)[0] for n in names}) == 1 and all("/" in n for n in names):
            names = [n.split("/", 1)[1] for n in names]
        nested = [n for n in names if "/" in n]
        if nested:
            raise BundleError(f"files must sit at the top level of the archive: '{nested[0]}'", file=name)
        out = BundleFiles.in_temp_folder(parent)
        jobs = []
        for member, (fn, info) in zip(names, entries):
            if member not in KNOWN_FILES:
                out[member] = b""
                continue

            def chunks(fn=fn, info=info):
                # read with a hard cap: headers can lie (the declared sizes are within the limit)
                left = info.file_size
                try:
                    with zf.open(info) as fh:
                        while chunk := fh.read(min(1 << 22, left + 1)):
                            left -= len(chunk)
                            if left < 0:
                                raise TooLargeError(
                                    f"member '{fn}' inflates past its declared size; refusing a possible zip bomb",
                                    file=name,
                                    field=fn,
                                )
                            yield chunk
                except ZIP_READ_ERRORS as exc:
                    raise BundleError(
                        f"member '{fn}' cannot be read (truncated or corrupt: {exc})", file=name, field=fn
                    ) from None

            jobs.append((member, chunks()))
        try:
            out.write_all(jobs)
        except BaseException:
            out.folder.cleanup()
            raise
        return out


def read_bundle_path(path: str | Path, max_unzipped_bytes: int = 4 << 30) -> dict[str, bytes | Path]:
    """Files of a bundle given as a ``.zip`` path or a folder: paths to files on disk (a zip is
    inflated into a temporary folder that lives as long as the returned :class:`BundleFiles` or the
    log parsed from it)."""
    p = Path(path)
    if not p.exists():
        raise BundleError("no such file or folder", file=str(p))
    if p.is_dir():
        return {f.name: f for f in sorted(p.iterdir()) if f.is_file() and f.name in KNOWN_FILES}
    return stage_zip(p, max_unzipped_bytes, name=p.name)


def load_bundle(path: str | Path) -> DriveLog:
    """Read, validate and parse a bundle from a zip or folder path."""
    return parse_files(read_bundle_path(path))


def _open_zip(source, name: str):
    """The open archive of ``source`` (a path or a binary file object) and its member list; a
    :class:`BundleError` naming ``name`` when it is not a readable zip."""
    try:
        zf = zipfile.ZipFile(source)
        return zf, zf.infolist()
    except ZIP_READ_ERRORS as exc:
        raise BundleError(f"not a readable zip archive (truncated or corrupt: {exc})", file=name) from None


def refuse_encrypted(info: zipfile.ZipInfo, archive: str) -> None:
    """A :class:`BundleError` naming the member when the archive says it is encrypted (flag bit 0):
    a bundle is never, and reading one would need a password."""
    if info.flag_bits & 0x1:
        raise BundleError(
            f"member '{info.filename}' is encrypted: send the bundle without a password",
            file=archive,
            field=info.filename,
        )


def _screen_member(
    info: zipfile.ZipInfo, name: str, before_bytes: int, max_unzipped_bytes: int, max_ratio: float
) -> bool:
    """Whether member ``info`` of archive ``name`` is a file to read (False: a folder or macOS
    metadata). Refuses an unsafe path, a total past ``max_unzipped_bytes`` (``before_bytes``
    unpacked before this member) and a compression ratio past ``max_ratio`` (a possible zip bomb)."""
    fn = info.filename
    if fn.startswith(("/", "\\")) or (len(fn) > 1 and fn[1] == ":") or ".." in fn.replace("\\", "/").split("/"):
        raise BundleError(f"unsafe path in archive: '{fn}'", file=name, field=fn)
    if info.is_dir() or fn.startswith("__MACOSX/") or posixpath.basename(fn).startswith("._"):
        return False
    refuse_encrypted(info, name)
    if info.file_size > max_unzipped_bytes or before_bytes + info.file_size > max_unzipped_bytes:
        raise TooLargeError(f"archive unpacks to more than {max_unzipped_bytes} bytes", file=name, field=fn)
    if info.compress_size and info.file_size / info.compress_size > max_ratio and info.file_size > 1 << 20:
        raise TooLargeError(
            f"member '{fn}' compresses {info.file_size / info.compress_size:.0f}:1 "
            f"(limit {max_ratio:.0f}:1): refusing a possible zip bomb",
            file=name,
            field=fn,
        )
    return True
