"""``manifest.json`` of an ``ldv-drive-log/1`` bundle as pydantic models.

Numbers must be JSON numbers (a unit given as a string such as ``"100 Hz"`` or
``"100"`` is rejected); unknown keys are kept (``extra='allow'``) and ignored.
"""

from __future__ import annotations

import datetime as dt
import json
import re
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictStr, ValidationError

from ldvsurvey import FORMAT_VERSION
from ldvsurvey.errors import BundleError

FILE = "manifest.json"

# strict: an int is accepted where a float is wanted, a string never is.
Num = Annotated[float, Field(strict=True)]
PosNum = Annotated[float, Field(strict=True, gt=0)]
Vec3 = Annotated[list[Num], Field(min_length=3, max_length=3)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True)


class ImuSpec(_Model):
    """IMU description. Biases and noise feed the filter's process noise."""

    rate_hz: PosNum
    rotating: StrictBool = False
    gyro_bias_dph: Num | None = None  #: gyro bias stability, deg/h
    accel_bias_ug: Num | None = None  #: accelerometer bias, micro-g
    gyro_arw_deg_per_rth: Num | None = None  #: angle random walk, deg/sqrt(h)
    accel_noise_ug_per_rthz: Num | None = None  #: velocity random walk, micro-g/sqrt(Hz)


class LdvNominal(_Model):
    """Nominal LDV mounting: pitch eta_L and heading phi_L in degrees, scale factor K."""

    pitch_deg: Num = 0.0
    heading_deg: Num = 0.0
    scale: PosNum = 1.0


class LdvOptics(_Model):
    """Dual-beam differential LDV optics, needed to convert ``fd_hz`` to speed."""

    wavelength_nm: PosNum  #: vacuum wavelength lambda_0, nm
    beam_angle_deg: PosNum  #: beam crossing angle theta, deg
    surface_angle_deg: Num  #: angle lambda_s between beam bisector and surface, deg
    refractive_index: PosNum = 1.00027  #: n_a of air


class LdvSpec(_Model):
    kind: Literal["1d", "2d", "water"]
    rate_hz: PosNum
    min_quality: Num | None = None
    nominal: LdvNominal = LdvNominal()
    optics: LdvOptics | None = None
    lever_arm_m: Vec3 = [0.0, 0.0, 0.0]  #: LDV head in body RFU, m


class GnssHeightNoise(_Model):
    """The receiver's height error for one fix quality: epoch-to-epoch white part and a slowly
    wandering part (first-order Gauss-Markov); the gravity pipeline's noise floor of the SINS/GNSS chain."""

    white_m: PosNum  #: white σ per epoch, m
    correlated_m: Annotated[float, Field(strict=True, ge=0)] = 0.0  #: stationary σ of the wandering part, m
    correlation_s: PosNum = 300.0  #: its correlation time, s


class GnssSpec(_Model):
    lever_arm_m: Vec3 = [0.0, 0.0, 0.0]  #: antenna in body RFU, m
    #: height error by fix quality ("4" RTK fixed, "5" float, "2" differential, "1" single point)
    height_noise: dict[Literal["1", "2", "4", "5"], GnssHeightNoise] = {}


class Initial(_Model):
    lat_deg: Annotated[float, Field(strict=True, ge=-90, le=90)] | None = None
    lon_deg: Annotated[float, Field(strict=True, ge=-180, le=360)] | None = None
    h_m: Num | None = None
    static_s: Annotated[float, Field(strict=True, ge=0)] | None = None


class Line(_Model):
    name: StrictStr
    t_start: Num
    t_end: Num


class Manifest(_Model):
    """The whole manifest. ``date`` is the UTC day that ``t = 0`` belongs to; ``ldv`` is absent
    (None) exactly when the bundle has no ``ldv.csv``."""

    format: Literal["ldv-drive-log/1"]
    name: StrictStr = ""
    date: dt.date
    platform: Literal["vehicle", "vessel"]
    imu: ImuSpec
    ldv: LdvSpec | None = None  #: None: the bundle has no LDV (an INS/GNSS log, no ldv.csv)
    gnss: GnssSpec = GnssSpec()
    initial: Initial = Initial()
    lines: list[Line] = []


def _line_of_key(text: str, loc: tuple) -> int | None:
    """1-based line where the deepest named key of ``loc`` appears (best effort)."""
    keys = [k for k in loc if isinstance(k, str)]
    pos = 0
    for key in keys:  # walk down the path so a repeated key name finds the right one
        m = re.compile('"' + re.escape(key) + r'"\s*:').search(text, pos)
        if m is None:
            break
        pos = m.start()
    if pos == 0 and not keys:
        return None
    return text.count("\n", 0, pos) + 1


def _describe(err: dict) -> str:
    kind = err.get("type", "")
    got = err.get("input")
    if kind == "missing":
        return "required key is missing"
    if kind == "bool_type":
        return f"expected true or false, got {type(got).__name__} {got!r}"
    if kind in ("float_type", "int_type") or (
        kind.endswith("_type") and isinstance(got, str) and kind not in ("string_type", "date_type")
    ):
        return f"expected a number, got {type(got).__name__} {got!r} (give units by the key name, not in the value)"
    if kind == "literal_error":
        return f"{err.get('msg')} (got {got!r})"
    return f"{err.get('msg')} (got {got!r})"


def parse_manifest(data: bytes) -> Manifest:
    """Parse and validate ``manifest.json`` bytes.

    Raises
    ------
    BundleError
        Naming the line and the dotted key path of the first problem.
    """
    if not data.strip():
        raise BundleError("file is empty", file=FILE, line=1)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise BundleError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", file=FILE) from None
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise BundleError(f"invalid JSON: {exc.msg}", file=FILE, line=exc.lineno) from None
    if not isinstance(raw, dict):
        raise BundleError("top level must be a JSON object", file=FILE, line=1)
    if raw.get("format") != FORMAT_VERSION:
        raise BundleError(
            f"format must be {FORMAT_VERSION!r}, got {raw.get('format')!r}",
            file=FILE,
            line=_line_of_key(text, ("format",)) or 1,
            field="format",
        )
    try:
        # JSON mode: dates come as strings; numbers stay strict.
        return Manifest.model_validate_json(text)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = tuple(err["loc"])
        field = ".".join(str(p) for p in loc)
        raise BundleError(_describe(err), file=FILE, line=_line_of_key(text, loc), field=field) from None
