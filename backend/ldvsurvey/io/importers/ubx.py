"""u-blox UBX binary logs, framed and checked with ``pyubx2``.

IMU (``ESF-RAW`` or ``ESF-MEAS``)
    The sensor fusion's gyro (data types 14, 13, 5: x, y, z, 2^-12 deg/s) and accelerometer (16, 17,
    18: x, y, z, 2^-10 m/s²) samples, 24-bit signed. They are rates, turned into increments over
    (t_prev, t] as sample × (t − t_prev).

    **Time base.** ``ESF-RAW sTag`` and ``ESF-MEAS timeTag`` are sensor time tags on the receiver's own
    clock (on the NEO-M8U the ESF-RAW tag counts at about 25.6 kHz and wraps at 2^24; ESF-MEAS
    counts about 1 kHz), not GPS time. Their rate and offset are established from the log itself,
    separately for each message type (the two run on different clocks and are never merged): every
    GNSS epoch message (NAV-PVT, else NAV-TIMEGPS, NAV-SOL, NAV-HPPOSLLH, NAV-POSLLH, HNR-PVT) in
    the stream is bracketed by the last sensor sample before it and the first one after it; a
    straight line tag = c + R·(GPS time) fitted through these anchors gives the tag rate R and the
    offset. The import refuses when fewer than two anchors exist, when R is not known to 1 % (3σ),
    or when the anchors leave the line (a tag reset). The NAV messages' output latency (tens of ms
    after their epoch) is not in the log: ``import.imu.time_offset_s`` adds a known one.

    **ESF-MEAS from real receivers.** Accelerometer and gyro arrive in separate messages a few ms
    apart, beside tick-only messages (wheel ticks, speed): an accelerometer message is joined with
    the gyro message nearest in time within ±min(20 ms, a quarter of the sample interval); tick-only
    and unmatched messages are counted and left out.

    When a log holds both, ESF-RAW is read (``import.imu.esf``: ``raw`` or ``meas`` chooses).

    Axes: the sensor's own frame (see docs/importers.md); no default is assumed: ``import.imu.axes``
    (or ``--axes``) names it, and the build's static check names the vertical axis it finds.

GNSS
    ``NAV-HPPOSLLH`` (0.1 mm / 1e-9°, preferred when present), ``NAV-PVT``, ``NAV-SOL`` (ECEF, older
    receivers), ``NAV-POSLLH``, and ``HNR-PVT`` (the receiver's fused high-rate solution, used only
    when nothing else is there: aiding an INS with it is circular). Fix quality: ``carrSoln`` fixed → 4,
    float → 5, ``diffSoln`` → 2, else 1; epochs without a valid fix are left out.
"""

from __future__ import annotations

import datetime as dt
import io
import math
import struct

import numpy as np

from ldvsurvey.errors import BundleError
from ldvsurvey.io.importers.common import GnssPart, ImuPart, Stamps, ecef_to_lla, fix_from_sigma
from ldvsurvey.io.importers.contract import Importer, Option
from ldvsurvey.io.importers.gpstime import GPS_EPOCH, WEEK_S, gps_minus_utc_s, unwrap_sow

NAME = "ubx"
ROLES = ("imu", "gnss")
GYRO = {14: 0, 13: 1, 5: 2}
ACCEL = {16: 0, 17: 1, 18: 2}
GYRO_LSB_RPS = math.radians(2.0**-12)
ACCEL_LSB_MPS2 = 2.0**-10
#: GNSS epoch messages that anchor the sensor clock, in order of preference
EPOCH_SOURCES = ("NAV-PVT", "NAV-TIMEGPS", "NAV-SOL", "NAV-HPPOSLLH", "NAV-POSLLH", "HNR-PVT")
#: position messages, in order of preference
POSITION_SOURCES = ("NAV-HPPOSLLH", "NAV-PVT", "NAV-SOL", "NAV-POSLLH", "HNR-PVT")
MAX_RATE_UNCERTAINTY = 0.01  #: 3σ of the fitted tag rate, relative
MAX_EXTRAPOLATION_S = 0.1  #: 3σ time error the rate's uncertainty may cause at the recording's ends
JOIN_MAX_S = 0.020  #: ESF-MEAS accelerometer/gyro join tolerance (also at most a quarter sample interval)
_IDS = {
    b"\x10\x03": "ESF-RAW",
    b"\x10\x02": "ESF-MEAS",
    b"\x01\x07": "NAV-PVT",
    b"\x01\x14": "NAV-HPPOSLLH",
    b"\x01\x02": "NAV-POSLLH",
    b"\x01\x06": "NAV-SOL",
    b"\x28\x00": "HNR-PVT",
}


#: payload lengths of the fixed-length messages read (u-blox interface descriptions, M8 and F9)
_LENGTH = {
    "NAV-PVT": 92,
    "NAV-HPPOSLLH": 36,
    "NAV-POSLLH": 28,
    "NAV-SOL": 52,
    "NAV-STATUS": 16,
    "NAV-TIMEGPS": 16,
    "HNR-PVT": 72,
}


def sniff(data: bytes, name: str) -> str | None:
    """``imu`` (ESF-RAW or ESF-MEAS frames) or ``gnss`` (navigation frames) in the first 64 kB, else None."""
    head = data[:65536]
    if b"\xb5\x62\x10\x03" in head or b"\xb5\x62\x10\x02" in head:
        return "imu"
    if any(b"\xb5\x62" + k in head for k, v in _IDS.items() if not v.startswith("ESF")):
        return "gnss"
    return None


def _signed24(v: int) -> int:
    v &= 0xFFFFFF
    return v - (1 << 24) if v & 0x800000 else v


class _Esf:
    """Stand-in for a parsed ESF message: ESF payloads are read here from the bytes (much faster)."""

    def __init__(self, identity: str):
        self.identity = identity


#: messages decoded with pyubx2; every other frame is only counted
_PARSED = {b"\x01\x07", b"\x01\x14", b"\x01\x02", b"\x01\x06", b"\x01\x03", b"\x01\x20", b"\x28\x00"}
_ESF = {b"\x10\x03": "ESF-RAW", b"\x10\x02": "ESF-MEAS"}


def _checksum_ok(raw: bytes) -> bool:
    """The UBX 8-bit Fletcher checksum over class, id, length and payload."""
    b = np.frombuffer(raw, dtype=np.uint8)[2:-2].astype(np.int64)
    ck_a = int(b.sum()) & 0xFF
    ck_b = int((b * np.arange(len(b), 0, -1)).sum()) & 0xFF
    return ck_a == raw[-2] and ck_b == raw[-1]


def _frames(data: bytes, file: str, errors: list):
    """(message number, raw frame, message) of the UBX frames the importer reads, with a good checksum.

    Frames are counted from 1 in stream order (every UBX frame, read or not, good or bad), as error
    messages name them.
    """
    try:
        from pyubx2 import UBX_PROTOCOL, UBXReader
    except ImportError:  # pragma: no cover
        raise BundleError("the pyubx2 package is not installed", file=file) from None
    reader = UBXReader(io.BytesIO(data), protfilter=UBX_PROTOCOL, quitonerror=1, parsing=0, errorhandler=errors.append)
    n = 0
    while True:
        try:
            raw, _ = reader.read()
        except Exception as exc:  # the library's framing errors
            raise BundleError(
                f"UBX frame after message {n} cannot be framed ({type(exc).__name__}: {exc})",
                file=file,
                field=f"message {n + 1}",
            ) from None
        if raw is None:
            return
        n += 1
        key = bytes(raw[2:4])
        if key not in _ESF and key not in _PARSED:
            continue
        if len(raw) < 8 or not _checksum_ok(raw):
            errors.append(f"message {n}: bad checksum")
            continue
        if key in _ESF:
            yield n, raw, _Esf(_ESF[key])
            continue
        try:
            msg = UBXReader.parse(raw)
        except Exception as exc:  # the library's own parse errors on a frame whose checksum passed
            raise BundleError(
                f"UBX message cannot be decoded ({type(exc).__name__}: {exc})", file=file, field=f"message {n}"
            ) from None
        yield n, raw, msg


def _week_of_date(msg) -> tuple[int, float] | None:
    """GPS week and seconds of week of a message stating a UTC date and time (NAV-PVT, HNR-PVT)."""
    try:
        day = dt.date(int(msg.year), int(msg.month), int(msg.day))
        utc = dt.datetime(day.year, day.month, day.day, int(msg.hour), int(msg.min), int(msg.second))
    except (ValueError, TypeError, AttributeError):
        return None
    gps_s = (utc - GPS_EPOCH).total_seconds() + gps_minus_utc_s(day)
    return int((gps_s + 1.0) // WEEK_S), gps_s


class _Log:
    """Everything the importer uses from one UBX file, in stream order."""

    def __init__(self, data: bytes, file: str):
        self.file = file
        self.errors: list = []
        self.raw: list[tuple[int, int, dict]] = []  # (message, tag, {dtype: value}) per sample
        self.meas: list[tuple[int, int, dict]] = []  # (message, tag, {dtype: value}) per message
        self.epochs: dict[str, list] = {k: [] for k in EPOCH_SOURCES}  # (message, iTOW s, week or None)
        self.fixes: dict[str, list] = {k: [] for k in POSITION_SOURCES}
        self.status: dict[int, int] = {}  # iTOW ms -> GGA quality from NAV-PVT / NAV-SOL / NAV-STATUS
        self.weeks: list[tuple[int, int]] = []  # (iTOW ms, week) stated by NAV-TIMEGPS, NAV-SOL, NAV-PVT date
        self.repeats = 0
        self.polls = 0
        seen: set[bytes] = set()
        for n, raw, msg in _frames(data, file, self.errors):
            key = bytes(raw)
            if key in seen:  # the same frame again (logged twice, several ports): time tags never repeat
                self.repeats += 1
                continue
            seen.add(key)
            try:
                self._take(n, raw, msg)
            except BundleError:
                raise
            except (AttributeError, TypeError, ValueError, KeyError, OverflowError, struct.error) as exc:
                raise BundleError(
                    f"{msg.identity} cannot be read ({type(exc).__name__}: {exc})", file=file, field=f"message {n}"
                ) from None

    def _take(self, n, raw, msg):
        ident = msg.identity
        payload = raw[6:-2]
        want = _LENGTH.get(ident)
        if want is not None and len(payload) != want:
            if not payload:  # a poll request echoed into the log
                self.polls += 1
                return
            raise BundleError(
                f"{ident} payload of {len(payload)} bytes, the message has {want}",
                file=self.file,
                field=f"message {n} length",
            )
        if ident == "ESF-RAW":
            if (len(payload) - 4) % 8:
                raise BundleError(f"ESF-RAW payload of {len(payload)} bytes", file=self.file, field=f"message {n}")
            groups: dict[int, dict] = {}
            for k in range(4, len(payload), 8):
                word, tag = struct.unpack_from("<II", payload, k)
                groups.setdefault(tag, {})[word >> 24] = _signed24(word)
            for tag, vals in groups.items():
                self.raw.append((n, tag, vals))
        elif ident == "ESF-MEAS":
            if len(payload) < 8:
                raise BundleError(f"ESF-MEAS payload of {len(payload)} bytes", file=self.file, field=f"message {n}")
            tag, flags = struct.unpack_from("<IH", payload, 0)
            num = (flags >> 11) & 0x1F
            if len(payload) < 8 + 4 * num:
                raise BundleError(
                    f"ESF-MEAS announces {num} measurements in {len(payload)} bytes",
                    file=self.file,
                    field=f"message {n} numMeas",
                )
            vals = {}
            for k in range(num):
                (word,) = struct.unpack_from("<I", payload, 8 + 4 * k)
                vals[word >> 24] = _signed24(word)
            self.meas.append((n, tag, vals))
        elif ident == "NAV-PVT":
            if msg.validTime:
                wk = _week_of_date(msg) if msg.validDate else None
                week = None
                if wk is not None:
                    week = wk[0]
                    if msg.iTOW < 1000 and (wk[1] - week * WEEK_S) > WEEK_S - 2.0:
                        week += 1
                    self.weeks.append((int(msg.iTOW), week))
                self.epochs["NAV-PVT"].append((n, msg.iTOW / 1000.0, week))
            if msg.gnssFixOk and msg.fixType in (2, 3, 4) and not getattr(msg, "invalidLlh", 0):
                fix = 4 if msg.carrSoln == 2 else 5 if msg.carrSoln == 1 else 2 if msg.diffSoln else 1
                self.status[int(msg.iTOW)] = fix
                self.fixes["NAV-PVT"].append(
                    (n, int(msg.iTOW), msg.lat, msg.lon, msg.height / 1e3, msg.hMSL / 1e3, msg.numSV, msg.pDOP)
                )
            elif msg.validTime:
                self.status[int(msg.iTOW)] = 0
        elif ident == "NAV-TIMEGPS":
            if msg.towValid:
                week = int(msg.week) if msg.weekValid else None
                if week is not None:
                    self.weeks.append((int(msg.iTOW), week))
                self.epochs["NAV-TIMEGPS"].append((n, (msg.iTOW + msg.fTOW * 1e-6) / 1000.0, week))
        elif ident == "NAV-SOL":
            week = int(msg.week) if msg.wknSet else None
            if msg.towSet:
                if week is not None:
                    self.weeks.append((int(msg.iTOW), week))
                self.epochs["NAV-SOL"].append((n, (msg.iTOW + msg.fTOW * 1e-6) / 1000.0, week))
            ok = msg.gpsfixOK and msg.gpsFix in (2, 3, 4)
            self.status.setdefault(int(msg.iTOW), (2 if msg.diffSoln else 1) if ok else 0)
            if ok:
                lat, lon, h = ecef_to_lla(msg.ecefX / 100.0, msg.ecefY / 100.0, msg.ecefZ / 100.0)
                self.fixes["NAV-SOL"].append((n, int(msg.iTOW), lat, lon, h, None, msg.numSV, msg.pDOP))
        elif ident == "NAV-STATUS":
            ok = msg.gpsFixOk and msg.gpsFix in (2, 3, 4)
            fix = (4 if msg.carrSoln == 2 else 5 if msg.carrSoln == 1 else 2 if msg.diffSoln else 1) if ok else 0
            self.status.setdefault(int(msg.iTOW), fix)
        elif ident in ("NAV-HPPOSLLH", "NAV-POSLLH"):
            self.epochs[ident].append((n, msg.iTOW / 1000.0, None))
            if not getattr(msg, "invalidLlh", 0):
                self.fixes[ident].append(
                    (n, int(msg.iTOW), msg.lat, msg.lon, msg.height / 1e3, msg.hMSL / 1e3, None, None, msg.hAcc / 1e3)
                )
        elif ident == "HNR-PVT":
            if msg.validTime:
                wk = _week_of_date(msg) if msg.validDate else None
                self.epochs["HNR-PVT"].append((n, msg.iTOW / 1000.0, wk[0] if wk else None))
            if msg.GPSfixOK and msg.gpsFix in (2, 3, 4):
                self.fixes["HNR-PVT"].append(
                    (n, int(msg.iTOW), msg.lat, msg.lon, msg.height / 1e3, msg.hMSL / 1e3, None, None)
                )

    def week_at(self, itow_ms: int) -> int | None:
        """The GPS week stated nearest to a time of week (None when no message states one)."""
        if not self.weeks:
            return None
        ms = np.array([w[0] for w in self.weeks], dtype=np.float64)
        k = int(np.argmin(np.abs(ms - itow_ms)))
        week = self.weeks[k][1]
        d = itow_ms - ms[k]
        if d < -WEEK_S * 500:
            week += 1
        elif d > WEEK_S * 500:
            week -= 1
        return week


# ---------------------------------------------------------------------------------------------- time base


def unwrap_tags(tags: np.ndarray, modulus: int, where: np.ndarray, file: str, field: str) -> np.ndarray:
    """Sensor time tags made continuous across their roll-over; a tag going back otherwise is refused.

    Parameters
    ----------
    tags : (N,) int array
        Sensor time tags, counts of the receiver's sensor clock.
    modulus : int
        Where the tags roll over (a drop of more than half of it is a roll-over).
    where : (N,) array
        Message number of each tag, for errors.
    file, field : str
        The file and the tag's field named in the error.

    Returns
    -------
    (N,) int array
        The tags, counting on across roll-overs.
    """
    t = np.asarray(tags, dtype=np.int64)
    d = np.diff(t)
    back = d < 0
    wrap = back & (d < -modulus // 2)
    bad = np.flatnonzero(back & ~wrap)
    if len(bad):
        k = int(bad[0]) + 1
        raise BundleError(
            f"sensor time tag goes backwards: {t[k]} after {t[k - 1]}", file=file, field=f"message {where[k]} {field}"
        )
    return t + np.concatenate(([0], np.cumsum(np.where(wrap, modulus, 0))))


def fit_clock(
    sample_msg: np.ndarray, sample_tag: np.ndarray, epochs: list, file: str, what: str
) -> tuple[float, float, float, dict]:
    """Tie a sensor clock to GPS time through the GNSS epoch messages around it in the stream.

    Parameters
    ----------
    sample_msg, sample_tag : (N,) message number and unwrapped tag of each sensor sample, stream order.
    epochs : [(message number, GPS s, source)] of the GNSS epoch messages, stream order, GPS s continuous.

    Returns
    -------
    (tag rate R in ticks/s, tag c at GPS time T0, T0 in GPS s, report dict)
    """
    anchors = []
    for n, t_gps, _src in epochs:
        k = int(np.searchsorted(sample_msg, n))  # first sample after the epoch message
        if k == 0 or k >= len(sample_msg):
            continue
        a, b = int(sample_tag[k - 1]), int(sample_tag[k])
        # the message after the epoch message was output after its last sample: that sample bounds the epoch
        j = int(np.searchsorted(sample_msg, sample_msg[k], side="right")) - 1
        anchors.append(
            (t_gps, 0.5 * (a + b), 0.5 * (b - a), n, 0.5 * (a + int(sample_tag[j])), 0.5 * (sample_tag[j] - a))
        )
    src = epochs[0][2] if epochs else "GNSS epoch"
    if len(anchors) < 2:
        raise BundleError(
            f"the {what} time tags are on the receiver's sensor clock, not GPS time, and this file has "
            f"{len(anchors)} GNSS epoch message(s) ({', '.join(EPOCH_SOURCES)}) among the sensor messages to tie "
            "them to GPS time: log the sensor messages together with NAV-PVT (or NAV-TIMEGPS, HNR-PVT)",
            file=file,
            field=what,
        )
    a = np.array(anchors, dtype=np.float64)
    t0 = float(a[0, 0])
    x = a[:, 0] - t0
    span = float(x.max() - x.min())
    if span <= 0:
        raise BundleError(f"the GNSS epochs around the {what} samples do not advance", file=file, field=what)
    rate, c = np.polyfit(x, a[:, 1], 1)
    resid = a[:, 1] - (c + rate * x)
    step = float(np.median(np.diff(sample_tag))) if len(sample_tag) > 1 else 0.0
    sigma = max(float(np.sqrt(np.mean(resid**2))), float(np.median(a[:, 2])) / math.sqrt(3.0), 1.0)
    sxx = float(np.sum((x - x.mean()) ** 2))
    u_rate = sigma / math.sqrt(sxx) / abs(rate) if rate else math.inf
    if rate <= 0 or 3.0 * u_rate > MAX_RATE_UNCERTAINTY:
        # σ(rate) falls as span^-1.5 (more anchors, further apart)
        need = span * (3.0 * u_rate / MAX_RATE_UNCERTAINTY) ** (2 / 3) if np.isfinite(u_rate) and rate > 0 else None
        raise BundleError(
            f"the {what} sensor clock cannot be tied to GPS time to 1 %: {len(a)} {src} epochs over {span:.1f} s "
            f"give a tag rate of {rate:.1f} ticks/s ± {3 * u_rate * 100:.1f} % (3σ)"
            + (f"; a log of at least {need:.0f} s is needed" if need else ""),
            file=file,
            field=what,
        )
    worst = int(np.argmax(np.abs(resid)))
    # an epoch may fall anywhere in a sensor message's output cycle: allow two message intervals
    last = np.flatnonzero(np.diff(sample_msg) != 0)
    msg_step = float(np.median(np.diff(sample_tag[last]))) if len(last) > 1 else step
    limit = 2.0 * msg_step + 4.0 * float(np.median(a[:, 2])) + 2.0 * step
    if abs(resid[worst]) > limit:
        raise BundleError(
            f"the {what} time tags do not follow GPS time: at the {src} epoch of message {int(a[worst, 3])} the tag is "
            f"{resid[worst] / rate * 1000:.1f} ms off the line through the other epochs (tag reset, lost messages?)",
            file=file,
            field=f"message {int(a[worst, 3])}",
        )
    # The rate comes from the samples next to each epoch message (a constant output delay does not change
    # it); the offset from the bracket the epoch lies in: between the last sample output before its
    # message and the last sample of the first sensor message output after it (that message was sent
    # only once all its samples were taken).
    c = c + float(np.mean(a[:, 4] - (c + rate * x)))
    half = float(np.median(a[:, 5]))
    report = {
        "source": src,
        "anchors": len(a),
        "span_s": round(span, 3),
        "tag_rate_hz": float(rate),
        "tag_rate_3sigma_rel": float(3.0 * u_rate),
        "offset_uncertainty_ms": round(float(max(half, 3 * np.sqrt(np.mean(resid**2)))) / rate * 1000, 2),
        "anchor_mid_s": t0 + float(x.mean()),  # where the fitted line is known best
    }
    return float(rate), float(c), t0, report


def _epochs(log: _Log) -> tuple[list, bool]:
    """GNSS epoch messages of the preferred source with continuous GPS seconds, and whether the week is known."""
    for src in EPOCH_SOURCES:
        ep = log.epochs[src]
        if len(ep) >= 2:
            sow = np.array([e[1] for e in ep])
            week0 = ep[0][2] if ep[0][2] is not None else log.week_at(int(sow[0] * 1000))
            cont = unwrap_sow(sow) + (week0 or 0) * WEEK_S
            return [(e[0], float(t), src) for e, t in zip(ep, cont)], week0 is not None
    return [], False


def _clock(log: _Log, msgs: np.ndarray, tags: np.ndarray, what: str, opts: dict):
    """GPS seconds (continuous) of sensor tags, and the report."""
    epochs, week_known = _epochs(log)
    rate, c, t0, rep = fit_clock(msgs, tags, epochs, log.file, what)
    t = t0 + (tags - c) / rate + float(opts.get("time_offset_s", 0.0))
    rep["week_known"] = week_known
    # the rate's uncertainty grows into a time error away from the anchors: samples far outside the GNSS
    # epochs that tie the clock are placed no better than this
    reach = float(np.max(np.abs(t - rep.pop("anchor_mid_s"))))
    err = rep["tag_rate_3sigma_rel"] * reach
    rep["time_3sigma_at_ends_s"] = round(err, 4)
    if err > MAX_EXTRAPOLATION_S:
        raise BundleError(
            f"the {what} samples reach {reach:.0f} s from the middle of the {rep['anchors']} {rep['source']} epochs "
            f"that tie their clock to GPS time: with the tag rate known to ±{rep['tag_rate_3sigma_rel'] * 100:.2f} % "
            f"(3σ) their times would be off by up to {err:.2f} s; log NAV-PVT over the whole recording",
            file=log.file,
            field=what,
        )
    return t, rep


# ---------------------------------------------------------------------------------------------- reading


def read(data: bytes, file: str, role: str, opts: dict):
    """ESF-RAW/ESF-MEAS increments or NAV fixes of a u-blox UBX log (see the module docstring).

    Parameters
    ----------
    data : bytes
        The file's content.
    file : str
        The file's name, for messages.
    role : str
        ``imu`` or ``gnss``.
    opts : dict
        ``import.<role>`` of the partial manifest: ``esf`` (``raw`` or ``meas``), ``time_offset_s``
        (s, the NAV messages' known output latency), ``axes``.

    Returns
    -------
    ImuPart or GnssPart
        Increments (rad, m/s; in the sensor's own frame, as ``axes`` names it) or fixes (deg, ellipsoidal height m).

    Raises
    ------
    BundleError
        Naming the frame and the field.
    """
    if role not in ROLES:
        raise BundleError(f"the ubx format has no '{role}' data (it has: imu, gnss)", file=file)
    log = _Log(data, file)
    notes = []
    if log.repeats:
        notes.append(f"{file}: {log.repeats} UBX frame(s) identical to an earlier one dropped as repeats")
    if log.errors:
        notes.append(f"{file}: {len(log.errors)} UBX frame(s) with a bad checksum or length skipped ({log.errors[0]})")
    if role == "gnss":
        return _gnss(log, notes)
    return _imu(log, opts, notes)


def _stamps_of(t_gps: np.ndarray, where: np.ndarray, week_known: bool) -> Stamps:
    week = np.floor(t_gps / WEEK_S).astype(np.int64)
    sow = t_gps - week * WEEK_S
    return Stamps("gps", sow, where, week=week if week_known else None)


def _imu(log: _Log, opts: dict, notes: list) -> ImuPart:
    file = log.file
    choice = str(opts.get("esf", "raw" if log.raw else "meas")).lower()
    if choice not in ("raw", "meas"):
        raise BundleError(f"'{choice}' is not raw or meas", file="manifest (partial)", field="import.imu.esf")
    imu_meas = [m for m in log.meas if set(m[2]) & (set(GYRO) | set(ACCEL))]
    if choice == "raw" and log.raw:
        tags = [s[1] for s in log.raw]
        modulus = 1 << 24 if max(tags) < (1 << 24) else 1 << 32
        msgs = np.array([s[0] for s in log.raw], dtype=np.int64)
        tag = unwrap_tags(np.array(tags), modulus, msgs, file, "sTag")
        rows = np.full((len(log.raw), 6), np.nan)
        for k, (_, _, vals) in enumerate(log.raw):
            _fill(rows[k], vals)
        _complete(rows, msgs, file, "ESF-RAW")
        t, rep = _clock(log, msgs, tag.astype(np.float64), "ESF-RAW sTag", opts)
        what = "ESF-RAW"
        if imu_meas:
            notes.append(f"{file}: {len(imu_meas)} ESF-MEAS messages left out: ESF-RAW is read (on its own clock)")
    elif imu_meas:
        t, rows, msgs, rep = _meas(log, imu_meas, opts, notes)
        what = "ESF-MEAS"
    else:
        raise BundleError("no ESF-RAW or ESF-MEAS message with gyro or accelerometer data", file=file, field="ESF")
    keep = np.concatenate(([True], np.diff(t) > 0))
    dup = (~keep) & np.concatenate(([False], np.all(rows[1:] == rows[:-1], axis=1)))
    if (~keep & ~dup).any():
        k = int(np.flatnonzero(~keep & ~dup)[0])
        raise BundleError(
            f"{what} time tag repeats or goes backwards with other data", file=file, field=f"message {msgs[k]} time tag"
        )
    if dup.any():
        notes.append(f"{file}: {int(dup.sum())} repeated {what} sample(s) dropped")
        t, rows, msgs = t[keep], rows[keep], msgs[keep]
    if len(t) < 2:
        raise BundleError("fewer than two sensor samples", file=file, field=what)
    dt_s = np.diff(t)
    dt_s = np.concatenate(([np.median(dt_s)], dt_s))
    d = np.diff(t)
    rate_hz = 1.0 / float(np.mean(d[d < 1.5 * np.median(d)]))  # mean interval: the tags step by whole ticks
    notes.append(
        f"{file}: {what} time base: tag rate {rep['tag_rate_hz']:.1f} ticks/s "
        f"(±{rep['tag_rate_3sigma_rel'] * 100:.2f} %, 3σ) and offset from {rep['anchors']} {rep['source']} epochs "
        f"over {rep['span_s']:.1f} s bracketed by the sensor messages around them in the stream "
        f"(±{rep['offset_uncertainty_ms']:.1f} ms, receiver output latency not included); samples at {rate_hz:.2f} Hz"
    )
    rep["message"] = what
    rep["sample_rate_hz"] = rate_hz
    axes = opts.get("axes")
    return ImuPart(
        stamps=_stamps_of(t, msgs, rep["week_known"]),
        dtheta_rad=rows[:, 0:3] * GYRO_LSB_RPS * dt_s[:, None],
        dvel_mps=rows[:, 3:6] * ACCEL_LSB_MPS2 * dt_s[:, None],
        axes=str(axes) if axes else "",  # no default: the sensor frame depends on the module's mounting
        notes=notes,
        quantum=(GYRO_LSB_RPS * float(np.median(dt_s)), ACCEL_LSB_MPS2 * float(np.median(dt_s))),
        report={"time_base": rep},
    )


def _fill(row, vals):
    for dtype, v in vals.items():
        if dtype in GYRO:
            row[GYRO[dtype]] = v
        elif dtype in ACCEL:
            row[3 + ACCEL[dtype]] = v


def _complete(rows, msgs, file, what):
    missing = np.isnan(rows).any(axis=1)
    if missing.any():
        k = int(np.flatnonzero(missing)[0])
        which = ["gyro x (14)", "gyro y (13)", "gyro z (5)", "accel x (16)", "accel y (17)", "accel z (18)"]
        gaps = [w for w, v in zip(which, rows[k]) if np.isnan(v)]
        raise BundleError(f"{what} sample lacks {', '.join(gaps)}", file=file, field=f"message {msgs[k]} dataType")


def _meas(log: _Log, imu_meas: list, opts: dict, notes: list):
    """ESF-MEAS: accelerometer and gyro messages joined by time tag."""
    file = log.file
    msgs = np.array([m[0] for m in imu_meas], dtype=np.int64)
    has_a = np.array([set(ACCEL) <= set(m[2]) for m in imu_meas])
    has_g = np.array([set(GYRO) <= set(m[2]) for m in imu_meas])
    # accelerometer and gyro messages interleave out of tag order: each kind is unwrapped on its own
    raw_tag = np.array([m[1] for m in imu_meas], dtype=np.int64)
    tag = raw_tag.copy()
    ref = None
    for kind in (has_a & has_g, has_a & ~has_g, has_g & ~has_a):
        if kind.any():
            u = unwrap_tags(raw_tag[kind], 1 << 32, msgs[kind], file, "timeTag")
            if ref is not None:
                u = u + (1 << 32) * round((ref - u[0]) / float(1 << 32))
            ref = int(u[0]) if ref is None else ref
            tag[kind] = u
    partial = ~(has_a | has_g)
    if partial.any():
        rows = np.full((1, 6), np.nan)
        _fill(rows[0], imu_meas[int(np.flatnonzero(partial)[0])][2])
        _complete(rows, msgs[partial][:1], file, "ESF-MEAS")
    # the clock is fitted on the accelerometer messages (or the gyro ones when there are none)
    sel = has_a if has_a.sum() >= 2 else has_g
    t_sel, rep = _clock(log, msgs[sel], tag[sel].astype(np.float64), "ESF-MEAS timeTag", opts)
    rate = rep["tag_rate_hz"]
    t_all = t_sel[0] + (tag - tag[sel][0]) / rate  # the same line for every message of this clock
    both = has_a & has_g
    rows, times, where = [], [], []
    for k in np.flatnonzero(both):
        r = np.full(6, np.nan)
        _fill(r, imu_meas[k][2])
        rows.append(r)
        times.append(t_all[k])
        where.append(msgs[k])
    ia = np.flatnonzero(has_a & ~has_g)
    ig = np.flatnonzero(has_g & ~has_a)
    joined = 0
    tol = 0.0
    offsets = []
    if len(ia) and len(ig):
        interval = float(np.median(np.diff(t_all[ia]))) if len(ia) > 1 else JOIN_MAX_S * 4
        tol = min(JOIN_MAX_S, 0.25 * interval)
        tg = t_all[ig]
        used = np.zeros(len(ig), dtype=bool)
        for k in ia:
            j = int(np.searchsorted(tg, t_all[k]))
            best = None
            for c in (j - 1, j):
                if 0 <= c < len(ig) and not used[c] and abs(tg[c] - t_all[k]) <= tol:
                    if best is None or abs(tg[c] - t_all[k]) < abs(tg[best] - t_all[k]):
                        best = c
            if best is None:
                continue
            used[best] = True
            r = np.full(6, np.nan)
            _fill(r, imu_meas[ig[best]][2])
            _fill(r, imu_meas[k][2])
            rows.append(r)
            offsets.append(t_all[k] - tg[best])
            times.append(0.5 * (t_all[k] + tg[best]))
            where.append(msgs[k])
            joined += 1
    lone = int(len(ia) + len(ig) - 2 * joined)
    ticks = len(log.meas) - len(imu_meas)
    if not rows:
        raise BundleError(
            "no ESF-MEAS message carries both gyro and accelerometer data, and no accelerometer message has a gyro "
            f"message within ±{tol * 1000:.0f} ms to join it with",
            file=file,
            field="ESF-MEAS dataType",
        )
    order = np.argsort(np.array(times), kind="stable")
    rows_a = np.array(rows)[order]
    t = np.array(times)[order]
    msgs_o = np.array(where, dtype=np.int64)[order]
    if joined:
        notes.append(
            f"{file}: ESF-MEAS accelerometer and gyro messages joined by time tag within ±{tol * 1000:.1f} ms: "
            f"{joined} pairs (accelerometer − gyro median {np.median(offsets) * 1000:.1f} ms), {lone} unmatched "
            f"message(s) left out, {ticks} tick/speed-only message(s) ignored"
        )
    rep["join_tolerance_ms"] = round(tol * 1000, 3)
    rep["joined"] = joined
    rep["unmatched"] = lone
    rep["tick_only"] = ticks
    return t, rows_a, msgs_o, rep


def _gnss(log: _Log, notes: list) -> GnssPart:
    file = log.file
    src = next((s for s in POSITION_SOURCES if log.fixes[s]), None)
    if src is None:
        raise BundleError(
            f"no position message with a valid fix ({', '.join(POSITION_SOURCES)})", file=file, field="NAV"
        )
    rows = log.fixes[src]
    if src == "HNR-PVT":
        notes.append(
            f"{file}: positions from HNR-PVT, the receiver's own fused (GNSS + IMU) high-rate solution: aiding "
            "an INS with it is circular; log NAV-PVT for the GNSS-only fixes"
        )
    others = [s for s in POSITION_SOURCES if log.fixes[s] and s != src]
    if others:
        notes.append(f"{file}: positions from {src}; {', '.join(others)} in the file left out")
    out = []
    for r in rows:
        n, itow = r[0], r[1]
        if src in ("NAV-HPPOSLLH", "NAV-POSLLH"):
            fix = log.status.get(itow)
            if fix is None:
                fix = int(fix_from_sigma(np.array([r[8]]))[0])
            if fix == 0:
                continue
        elif src == "HNR-PVT":
            fix = 1
        else:
            fix = log.status.get(itow, 1)
        week = log.week_at(itow)
        out.append(
            (
                -1 if week is None else week,
                itow / 1000.0,
                r[2],
                r[3],
                r[4],
                np.nan if r[5] is None else r[4] - r[5],
                fix,
                np.nan if r[6] is None else r[6],
                np.nan if r[7] is None else r[7],
                n,
            )
        )
    if not out:
        raise BundleError(f"no {src} message with a valid fix", file=file, field=src)
    a = np.array(out, dtype=np.float64)
    week_known = bool((a[:, 0] >= 0).all())
    sep = a[:, 5] if np.isfinite(a[:, 5]).all() else None
    return GnssPart(
        stamps=Stamps("gps", a[:, 1], a[:, 9].astype(np.int64), week=a[:, 0].astype(np.int64) if week_known else None),
        lat_deg=a[:, 2],
        lon_deg=a[:, 3],
        h_ell_m=a[:, 4],
        sep_m=sep,
        fix=a[:, 6].astype(np.int16),
        n_sat=a[:, 7],
        hdop=a[:, 8],
        notes=notes,
    )


IMPORTER = Importer(
    NAME,
    ROLES,
    read,
    sniff,
    options=(
        Option("esf", (str,), "the IMU message read when a log holds both: 'raw' (ESF-RAW) or 'meas'", ("imu",)),
        Option(
            "time_offset_s",
            (float,),
            "added to the sensor samples' times: the NAV messages' known output latency, s",
            ("imu",),
        ),
    ),
    summary="u-blox UBX logs: ESF-RAW/ESF-MEAS (IMU), NAV-HPPOSLLH/PVT/SOL/POSLLH, HNR-PVT (GNSS)",
)
