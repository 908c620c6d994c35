"""Sensor axis conventions mapped to the bundle's body frame Right-Forward-Up (RFU).

A convention is three letters, one per sensor axis x, y, z, each naming where that axis
points on the vehicle: ``F``/``B`` (forward/back), ``R``/``L`` (right/left), ``U``/``D``
(up/down). ``RFU`` is the bundle's own frame, ``FRD`` the frame of KF-GINS and of most
aerospace IMUs, ``FLU`` the ROS body frame.
"""

from __future__ import annotations

import numpy as np

from ldvsurvey.errors import BundleError

_AXIS = {"R": (0, 1.0), "L": (0, -1.0), "F": (1, 1.0), "B": (1, -1.0), "U": (2, 1.0), "D": (2, -1.0)}
_NAMES = {
    (0, 1.0): "right",
    (0, -1.0): "left",
    (1, 1.0): "forward",
    (1, -1.0): "back",
    (2, 1.0): "up",
    (2, -1.0): "down",
}


def c_rfu_sensor(code: str, file: str | None = None, field: str = "axes") -> np.ndarray:
    """3×3 matrix taking a vector in the sensor axes ``code`` to RFU.

    Raises
    ------
    BundleError
        When ``code`` is not three letters covering the three directions once each.
    """
    code = str(code).strip().upper()
    if len(code) != 3 or any(ch not in _AXIS for ch in code) or len({_AXIS[ch][0] for ch in code}) != 3:
        raise BundleError(
            f"axis convention '{code}' is not valid: give three letters, one per sensor axis "
            "x, y, z, from F/B, R/L, U/D with each direction once (e.g. RFU, FRD, FLU)",
            file=file,
            field=field,
        )
    c = np.zeros((3, 3))
    for j, ch in enumerate(code):
        i, s = _AXIS[ch]
        c[i, j] = s
    return c


def _static_mean(dvel: np.ndarray, t_s: np.ndarray, static_s: float, file: str) -> np.ndarray:
    if len(t_s) < 2:
        raise BundleError("fewer than two IMU samples", file=file)
    sel = t_s <= t_s[0] + max(static_s, 1.0)
    if sel.sum() < 2:
        sel[:2] = True
    f = dvel[sel].sum(axis=0)
    if float(np.linalg.norm(f)) == 0.0:
        raise BundleError(
            "velocity increments are all zero in the first seconds: no specific force to check the axes with",
            file=file,
            field="dvel",
        )
    return f


def vertical_axis(f_sensor: np.ndarray) -> tuple[int, float]:
    """(sensor axis 0/1/2, +1 or -1) carrying the reaction to gravity (pointing up) in a static stretch."""
    j = int(np.argmax(np.abs(f_sensor)))
    return j, 1.0 if f_sensor[j] > 0 else -1.0


def fitting_codes(code: str | None, j: int, sign: float) -> list[str]:
    """Right-handed conventions that put sensor axis ``j`` up (sign +1) or down (sign -1), keeping as much
    of ``code`` as possible; all eight when ``code`` is None."""
    v = "U" if sign > 0 else "D"
    out = []
    for a in "FBRL":
        for b in "FBRL":
            letters = [None, None, None]
            letters[j] = v
            others = [k for k in range(3) if k != j]
            letters[others[0]], letters[others[1]] = a, b
            cand = "".join(letters)
            try:
                c = c_rfu_sensor(cand)
            except BundleError:
                continue
            if np.linalg.det(c) > 0:
                out.append(cand)
    if code:
        code = code.upper()
        out.sort(key=lambda c: -sum(x == y for x, y in zip(c, code)))
    return out


def require_axes(dvel_sensor: np.ndarray, t_s: np.ndarray, static_s: float, file: str, family: str) -> None:
    """Refuse a recording whose format has no fixed sensor frame, naming what its first seconds show."""
    f = _static_mean(dvel_sensor, t_s, static_s, file)
    j, sign = vertical_axis(f)
    fits = fitting_codes(None, j, sign)
    raise BundleError(
        f"the {family} sensor frame depends on how the module is mounted and no axes were given: in the first "
        f"{static_s:.0f} s gravity's reaction lies on the sensor's {'+' if sign > 0 else '-'}{'xyz'[j]} axis, "
        f"so that axis points {'up' if sign > 0 else 'down'}; state where x and y point with --axes or "
        f"import.imu.axes, one of {', '.join(fits)}",
        file=file,
        field="axes",
    )


def check_static_up(
    dvel_rfu: np.ndarray, t_s: np.ndarray, code: str, static_s: float, file: str, max_tilt_deg: float = 5.0
) -> float:
    """Check that specific force points up in the first ``static_s`` seconds.

    Returns the tilt (deg) of the mean specific force from body up.

    Raises
    ------
    BundleError
        When the tilt exceeds ``max_tilt_deg``, saying which sensor axis carries gravity and
        which right-handed conventions would put it up.
    """
    f = _static_mean(dvel_rfu, t_s, static_s, file)
    norm = float(np.linalg.norm(f))
    tilt = float(np.degrees(np.arccos(np.clip(f[2] / norm, -1.0, 1.0))))
    if tilt <= max_tilt_deg:
        return tilt
    c = c_rfu_sensor(code)
    f_s = c.T @ f  # back in sensor axes
    j, sign = vertical_axis(f_s)
    axis = "xyz"[j]
    i, s = int(np.flatnonzero(c[:, j])[0]), float(c[:, j].sum())
    now = _NAMES[(i, s * sign)]
    hint = ""
    if sign < 0:
        hint = f" (the sensor's {axis} axis points down where it was declared {_NAMES[(i, s)]})"
    fits = fitting_codes(code, j, sign)
    if now == "up":  # the declared up axis is the right one: not at rest, or mounted tilted
        raise BundleError(
            f"in the first {static_s:.0f} s the specific force points {tilt:.1f}° away from body up "
            f"(limit {max_tilt_deg:.1f}°) with axes '{code}', although gravity's reaction lies on the sensor's "
            f"{'+' if sign > 0 else '-'}{axis} axis, which this convention puts up: the first seconds were not at "
            "rest or the unit is mounted tilted; give initial.static_s for a stretch at rest or raise "
            "import.imu.max_static_tilt_deg",
            file=file,
            field="axes",
        )
    raise BundleError(
        f"in the first {static_s:.0f} s the specific force points {tilt:.1f}° away from body up "
        f"(limit {max_tilt_deg:.1f}°) with axes '{code}': gravity's reaction lies on the sensor's "
        f"{'+' if sign > 0 else '-'}{axis} axis, which this convention puts {now}{hint}; the axes look "
        f"swapped or a sign is flipped: declare the sensor axis that points up as U, e.g. "
        f"{' or '.join(repr(x) for x in fits[:2])} (right-handed, closest to '{code}')",
        file=file,
        field="axes",
    )
