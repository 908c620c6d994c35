"""What every importer returns, the decoding of text files (byte-order marks, UTF-16), a strict reader for
whitespace/comma separated numbers, and WGS-84 ECEF to geodetic coordinates."""

from __future__ import annotations

import datetime as dt
import functools
import io
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ldvsurvey.errors import BundleError

WGS84_A_M = 6378137.0  #: semi-major axis, m
WGS84_F = 1.0 / 298.257223563  #: flattening


@dataclass
class Stamps:
    """Sample times as the recording states them.

    Attributes
    ----------
    kind : ``gps`` (seconds of GPS week, ``week`` per sample or None), ``utc_tod`` (UTC seconds of
        day, ``day`` the UTC day of the first sample if the recording states it), ``unix`` (UNIX s)
        or ``bundle`` (already the bundle clock).
    values : (N,) seconds.
    where : (N,) line or message number of each sample, for error messages.
    """

    kind: str
    values: np.ndarray
    where: np.ndarray
    week: np.ndarray | None = None
    day: dt.date | None = None
    offset_s: int = 0  #: whole seconds to add to ``values`` (keeps UNIX times precise in float64)


@dataclass
class ImuPart:
    """IMU increments over (t_prev, t] in the sensor's own axes ``axes`` (see :mod:`.axes`).

    dtheta_rad, dvel_mps : (N, 3) rad and m/s.
    """

    stamps: Stamps
    dtheta_rad: np.ndarray
    dvel_mps: np.ndarray
    axes: str = "RFU"
    turntable_deg: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)
    quantum: tuple[float, float] | None = None  #: (rad, m/s) of one count, when the format is integer
    reference: Reference | None = None  #: the receiver's own INS solution, if the recording has one
    report: dict = field(
        default_factory=dict
    )  #: how the importer established the time base etc., for the import report


@dataclass
class Reference:
    """A receiver's own navigation solution (e.g. NovAtel INSPVA), kept beside the bundle to compare
    against, never an input of the pipelines.

    lat_deg, lon_deg, h_ell_m : (N,) WGS-84; v_enu_mps : (N, 3); rpy_deg : (N, 3) roll, pitch and
    azimuth (clockwise from north) as the receiver states them; status : (N,) its solution status.
    """

    source: str
    stamps: Stamps
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    h_ell_m: np.ndarray
    v_enu_mps: np.ndarray
    rpy_deg: np.ndarray
    status: list[str]


@dataclass
class GnssPart:
    """Position fixes of the antenna: WGS-84 lat/lon (deg), ellipsoidal height (m)."""

    stamps: Stamps
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    h_ell_m: np.ndarray
    fix: np.ndarray
    sep_m: np.ndarray | None = None  #: geoid separation the recording states (GGA, BESTPOS undulation)
    n_sat: np.ndarray | None = None
    hdop: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)
    raw_nmea: bytes | None = None  #: native gnss.nmea, copied unchanged
    reference: Reference | None = None  #: the receiver's own INS solution, if the recording has one


@dataclass
class LdvPart:
    """LDV columns of ``ldv.csv`` (``v_fwd`` or ``fd_hz``, optional ``v_up``, ``quality``)."""

    stamps: Stamps
    columns: dict[str, np.ndarray]
    notes: list[str] = field(default_factory=list)


#: byte-order marks, longest first (UTF-32LE's begins with UTF-16LE's)
_BOMS = (
    (b"\xff\xfe\x00\x00", "utf-32-le", "UTF-32LE"),
    (b"\x00\x00\xfe\xff", "utf-32-be", "UTF-32BE"),
    (b"\xef\xbb\xbf", "utf-8", "UTF-8"),
    (b"\xff\xfe", "utf-16-le", "UTF-16LE"),
    (b"\xfe\xff", "utf-16-be", "UTF-16BE"),
)


def text_encoding(data: bytes) -> tuple[str, str, int] | None:
    """How a text file is encoded when it is not plain ASCII/UTF-8: (Python codec, name, bytes of its byte-order
    mark), or None. A byte-order mark decides; without one, UTF-16 is recognised by its zero bytes (Windows
    programs write ASCII text as UTF-16LE: every second byte 0, and no zero byte in between)."""
    for bom, codec, label in _BOMS:
        if data.startswith(bom):
            return codec, f"{label} with a byte-order mark", len(bom)
    head = data[:4096]
    n = len(head) // 2
    if n < 16:
        return None
    even, odd = head[0 : 2 * n : 2].count(0), head[1 : 2 * n : 2].count(0)
    if odd > 0.9 * n and even == 0:
        return "utf-16-le", "UTF-16LE without a byte-order mark", 0
    if even > 0.9 * n and odd == 0:
        return "utf-16-be", "UTF-16BE without a byte-order mark", 0
    return None


def decoded_text(data: bytes) -> tuple[bytes, str | None]:
    """The file as UTF-8 bytes, and how it was encoded (None when it already was ASCII/UTF-8 without a mark).

    Characters that do not decode become U+FFFD (so a damaged sentence keeps its line and fails its own check);
    the line structure, hence every line number, is kept."""
    enc = text_encoding(data)
    if enc is None:
        return data, None
    codec, label, skip = enc
    return data[skip:].decode(codec, "replace").encode("utf-8"), label


def text_reader(reader):
    """Decorate an importer's ``read(data, file, role, opts)`` so that it reads text files in any encoding
    :func:`decoded_text` knows (a note in the part's notes says which); a text format's importers all take it."""

    @functools.wraps(reader)
    def read(data: bytes, file: str, role: str, opts: dict):
        text, how = decoded_text(data)
        part = reader(text, file, role, opts)
        if how is not None:
            part.notes.append(f"{file}: {how}: read as text")
        return part

    return read


def text_sniffer(sniffer):
    """Decorate an importer's ``sniff(data, name)`` to look at the decoded text (see :func:`decoded_text`)."""

    @functools.wraps(sniffer)
    def sniff(data: bytes, name: str) -> str | None:
        return sniffer(decoded_text(data[:262144])[0], name)

    return sniff


def ecef_to_lla(x_m: float, y_m: float, z_m: float) -> tuple[float, float, float]:
    """WGS-84 geodetic coordinates of an Earth-centred Earth-fixed point.

    The latitude is iterated as φ = atan2(z + e² N(φ) sin φ, p) (p the distance from the axis) until it no
    longer changes (1e-15 rad; each step gains about a factor e² ≈ 0.0067), the height taken as
    h = p cos φ + z sin φ − a √(1 − e² sin² φ): both hold at every latitude, the poles included.

    Parameters
    ----------
    x_m, y_m, z_m : float
        ECEF coordinates, m.

    Returns
    -------
    lat_deg, lon_deg : float
        Geodetic latitude and longitude, deg (longitude in (−180, 180]; 0 on the axis).
    h_m : float
        Ellipsoidal height, m.
    """
    e2 = WGS84_F * (2.0 - WGS84_F)
    p = math.hypot(x_m, y_m)
    lat = math.atan2(z_m, p * (1.0 - e2))
    for _ in range(30):
        n = WGS84_A_M / math.sqrt(1.0 - e2 * math.sin(lat) ** 2)
        new = math.atan2(z_m + e2 * n * math.sin(lat), p)
        done = abs(new - lat) <= 1e-15
        lat = new
        if done:
            break
    s, c = math.sin(lat), math.cos(lat)
    h = p * c + z_m * s - WGS84_A_M * math.sqrt(1.0 - e2 * s * s)
    return math.degrees(lat), math.degrees(math.atan2(y_m, x_m)), h


def fix_from_sigma(sigma_h_m: np.ndarray) -> np.ndarray:
    """GGA fix quality from a horizontal 1-σ (m) when the recording has no solution type.

    ≤ 0.05 m: 4 (RTK fixed); ≤ 0.3 m: 5 (RTK float); ≤ 1 m: 2 (differential); else 1 (single).
    """
    s = np.asarray(sigma_h_m, dtype=np.float64)
    return np.select([s <= 0.05, s <= 0.3, s <= 1.0], [4, 5, 2], 1).astype(np.int16)


def read_number_table(
    data: bytes, file: str, min_cols: int, names: list[str] | None = None, comment: str = "#"
) -> tuple[np.ndarray, np.ndarray]:
    """Rows of numbers separated by whitespace or commas (no header).

    Returns
    -------
    (values (N, n_cols) float64, line number (N,) of each row)

    Raises
    ------
    BundleError
        A row with too few fields, a field that is not a finite number, an empty file.
    """
    text = data.decode("utf-8", "replace")
    fast = _regular_table(text, min_cols, comment)
    if fast is not None:
        return fast
    rows, lines = [], []
    width = None
    for lineno, raw in enumerate(io.StringIO(text), start=1):
        s = raw.strip()
        if not s or s.startswith(comment) or s.startswith("%"):
            continue
        parts = s.replace(",", " ").split()
        if len(parts) < min_cols:
            raise BundleError(
                f"expected at least {min_cols} fields, got {len(parts)}",
                file=file,
                line=lineno,
                field=(names[len(parts)] if names and len(parts) < len(names) else None),
            )
        if width is None:
            width = len(parts)
        parts = parts[: max(min_cols, min(width, len(parts)))]
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            for k, p in enumerate(parts):
                try:
                    float(p)
                except ValueError:
                    raise BundleError(
                        f"'{p}' is not a number",
                        file=file,
                        line=lineno,
                        field=names[k] if names and k < len(names) else f"column {k + 1}",
                    ) from None
        if not all(np.isfinite(vals)):
            k = int(np.flatnonzero(~np.isfinite(vals))[0])
            raise BundleError(
                f"'{parts[k]}' is not a finite number",
                file=file,
                line=lineno,
                field=names[k] if names and k < len(names) else f"column {k + 1}",
            )
        if len(vals) < width:
            vals += [np.nan] * (width - len(vals))
        rows.append(vals[:width])
        lines.append(lineno)
    if not rows:
        raise BundleError("file holds no data rows", file=file, line=1)
    return np.array(rows, dtype=np.float64), np.array(lines, dtype=np.int64)


#: printable ASCII, tab and line ends: the fast reader leaves text with any other character to the strict one
_PLAIN = bytes(range(0x20, 0x7F)) + b"\t\n\r"


def _regular_table(text: str, min_cols: int, comment: str) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`read_number_table`'s result for a plain table, read by numpy's C reader, or None.

    Plain: printable ASCII, every data row with the same number of fields (at least ``min_cols``), every
    field a finite number, line ends ``\\n`` or ``\\r\\n``. The lines are those the strict reader sees
    (split at ``\\n``, blank and comment lines skipped) and each field is converted as ``float`` converts it
    (both are correctly rounded), so the numbers and line numbers are the same; anything else (a bad
    field, a short row, a stray character) returns None and the strict reader reads the text, and names
    what is wrong.
    """
    if not text.isascii() or text.encode("ascii").translate(None, _PLAIN):
        return None
    if "\r" in text:
        text = text.replace("\r\n", "\n")
        if "\r" in text:
            return None
    lines = text.split("\n")
    if comment in text or "%" in text or any(not s.strip() for s in lines[:-1]):
        kept = [(k, s) for k, s in enumerate(lines, start=1) if (t := s.strip()) and not t.startswith((comment, "%"))]
        numbers = np.array([k for k, _ in kept], dtype=np.int64)
        lines = [s for _, s in kept]
    else:
        if not lines[-1].strip():
            lines.pop()
        numbers = np.arange(1, len(lines) + 1, dtype=np.int64)
    if not lines:
        return None
    if "," in text:
        lines = [s.replace(",", " ") for s in lines]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            a = np.loadtxt(lines, dtype=np.float64, comments=None, ndmin=2)
    except (ValueError, TypeError):
        return None
    if a.shape != (len(numbers), a.shape[1]) or a.shape[1] < min_cols or not np.isfinite(a).all():
        return None
    return a, numbers


def check_increasing(t: np.ndarray, where: np.ndarray, file: str, field: str = "time", unit: str = "line") -> None:
    """Times must strictly increase; name the first sample that does not.

    Parameters
    ----------
    t : (N,) array
        Times, s.
    where : (N,) array
        Line or message number of each sample.
    file, field : str
        The file and the field named in the error.
    unit : str
        ``line`` (the error names the line) or what ``where`` counts otherwise (e.g. ``message``).

    Raises
    ------
    BundleError
        At the first time that repeats or goes backwards.
    """
    bad = np.flatnonzero(np.diff(t) <= 0)
    if len(bad):
        k = int(bad[0]) + 1
        what = "repeats" if t[k] == t[k - 1] else "goes backwards"
        msg = f"time {what}: {t[k]:.6f} s after {t[k - 1]:.6f} s"
        if unit == "line":
            raise BundleError(msg, file=file, line=int(where[k]), field=field)
        raise BundleError(f"{unit} {int(where[k])}: {msg}", file=file, field=field)
