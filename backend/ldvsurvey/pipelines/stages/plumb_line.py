"""Deflection of the vertical (and Δg) in the mechanization's gravity, so the INS levels to the
ellipsoid normal instead of the plumb line (methods §5: g^n = [−γη, −γξ, −(γ + Δg)]).

Sources: the built-in EGM2008 synthesized on a 1′ grid around the track, or the user's ICGEM
``.gdf`` grids (ξ, η in arcsec, optionally Δg in mGal), interpolated bilinearly along the track
(GNSS positions, any fix; the start position when the log has none).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field

from ldvsurvey.errors import ParameterError
from ldvsurvey.io.gdf import parse_gdf
from ldvsurvey.nav.dovgrid import DovGrid, area_for_track, egm_grid
from ldvsurvey.pipelines.base import Params, Paths, Progress, Text
from ldvsurvey.pipelines.stages.aids import NavInputs
from ldvsurvey.units import MPS2_PER_MGAL, RAD_PER_ARCSEC

EGM_STEP_ARCMIN = 1.0
EGM_DEGREE = 2190
_EGM_MEMO: dict = {}  # in-process memo of synthesized grids (the job runner adds a database cache)


DovChoice = Literal["none", "egm2008", "grid"]
DOV_HELP = (
    "deflection of the vertical in the mechanization's gravity: none (normal gravity, the INS levels "
    "to the plumb line), egm2008 (built-in model, 1′ grid) or grid (dov_grid)"
)


class DovParams(Params):
    """The deflection-of-the-vertical parameters of the navigating pipelines (default: EGM2008)."""

    dov: DovChoice = Field("egm2008", description=DOV_HELP)
    dov_grid: Paths | None = Field(
        None,
        description="ICGEM .gdf grids ξ,η (arcsec) and optionally Δg (mGal), "
        "comma separated (with dov=grid; server files, not accepted by the API)",
    )
    dov_grid_id: Text | None = Field(
        None, max_length=200, description="id of grids uploaded with POST /api/grids (with dov=grid)"
    )


def load_grids(paths) -> DovGrid:
    """ξ, η (and Δg) grids from two (three) ``.gdf`` files on the same nodes.

    Parameters
    ----------
    paths : list of str
        ``xi.gdf, eta.gdf[, dg.gdf]``: ξ, η in arcsec, Δg in mGal (ICGEM grid files, server paths).

    Returns
    -------
    DovGrid
        The grids on their nodes (deg), named after the files; a ParameterError naming the file
        that is missing, malformed or on other nodes.
    """
    if len(paths) not in (2, 3):
        raise ParameterError("give two or three .gdf files: dov_grid=xi.gdf,eta.gdf[,dg.gdf]", field="dov_grid")
    parsed = []
    for p in paths:
        path = Path(p)
        if not path.is_file():
            raise ParameterError("no such file", file=str(path), field="dov_grid")
        parsed.append(parse_gdf(path.read_bytes(), path.name))
    _, la, lo, xi = parsed[0]
    for (_, la2, lo2, v), p in zip(parsed[1:], paths[1:]):
        if v.shape != xi.shape or not (np.allclose(la, la2) and np.allclose(lo, lo2)):
            raise ParameterError(
                f"the grids must share the nodes of {Path(paths[0]).name}", file=Path(p).name, field="dov_grid"
            )
    return DovGrid(
        la,
        lo,
        xi,
        parsed[1][3],
        parsed[2][3] if len(parsed) > 2 else None,
        source=", ".join(Path(p).name for p in paths),
    )


def _uploaded(grid_id: str) -> DovGrid:
    from ldvsurvey.pipelines.stages.grid_cache import GRID_CACHE

    cache = GRID_CACHE.get()
    if cache is None:
        raise ParameterError(
            "uploaded grids are available to jobs run by the server only; give dov_grid files", field="dov_grid_id"
        )
    grid = cache.get("upload:" + str(grid_id)) if str(grid_id).isalnum() else None
    if grid is None:
        raise ParameterError(f"no uploaded grid with id {grid_id!r}", field="dov_grid_id")
    return grid


def _egm(lat_deg, lon_deg, progress, h_m: float = 0.0) -> DovGrid:
    """The EGM2008 grid over the track at the ellipsoidal height ``h_m`` (m), memoized and cached."""
    from ldvsurvey.pipelines.stages.grid_cache import GRID_CACHE

    area = area_for_track(lat_deg, lon_deg, EGM_STEP_ARCMIN)
    h_m = float(round(h_m))  # to the metre: δg changes by ~µGal per metre of height at these wavelengths
    key = f"egm2008:deg{EGM_DEGREE}:step{EGM_STEP_ARCMIN}:{area}" + (f":h{h_m:.0f}" if h_m else "")
    grid = _EGM_MEMO.get(key)
    cache = GRID_CACHE.get()
    if grid is None and cache is not None:
        grid = cache.get(key)
    if grid is None:
        grid = egm_grid(area, EGM_STEP_ARCMIN, EGM_DEGREE, progress=lambda s, f: progress(s, 0.03), h_m=h_m)
        if cache is not None:
            cache.put(key, grid)
    _EGM_MEMO[key] = grid
    return grid


def _track(inp: NavInputs):
    """Latitude, longitude (deg) at the IMU samples: GNSS fixes interpolated, else the start position."""
    g = inp.log.gnss
    if g is not None:
        ok = (g.fix > 0) & np.isfinite(g.lat_deg)
        if ok.sum() >= 2:
            return (np.interp(inp.t_s, g.t_s[ok], g.lat_deg[ok]), np.interp(inp.t_s, g.t_s[ok], g.lon_deg[ok]), None)
    n = len(inp.t_s)
    return (
        np.full(n, np.degrees(inp.pos0[0])),
        np.full(n, np.degrees(inp.pos0[1])),
        "no GNSS track: the deflection at the start position is used along the whole drive",
    )


def apply_dov(inp: NavInputs, params: DovParams, progress: Progress) -> tuple[dict, list[str]]:
    """Set ``inp.gravity`` from the chosen source; return the summary block and warnings.

    The block states the source, max/RMS of ξ, η (arcsec) and Δg (mGal) along the track, and the
    first-order height difference the levelling makes: δh(t) = ∫ (ξ v_N + η v_E) dt (the height
    an INS levelled to the plumb line gains, the geoid change along the track with opposite sign),
    with v from the GNSS track.

    Parameters
    ----------
    inp : NavInputs
        The loaded log; its ``gravity`` is set to (ξ rad, η rad, Δg m/s²) per IMU sample.
    params : DovParams
        ``dov`` (none, egm2008, grid) and the grids for ``dov=grid`` (``dov_grid`` files or an
        uploaded ``dov_grid_id``).
    progress : Progress
        Stage reporter.

    Returns
    -------
    info : dict
        The summary block (``source``, ``xi_arcsec_max``/``_rms``, ``eta_arcsec_*``, ``dg_mgal_*``,
        ``dg_used``, ``height_effect_max_m``).
    warnings : list of str
        What had to be assumed (no GNSS track: the deflection at the start position throughout).
    """
    mode = params.dov
    paths = params.dov_grid or params.dov_grid_id
    if mode == "none":
        if paths:
            raise ParameterError("dov_grid is given but dov=none; set dov=grid to use it", field="dov")
        return {"source": "none (normal gravity: the INS levels to the plumb line)"}, []
    progress("deflection of the vertical along the track", 0.03)
    lat, lon, warn = _track(inp)
    if mode == "grid":
        if not paths:
            raise ParameterError(
                "dov=grid needs dov_grid=xi.gdf,eta.gdf[,dg.gdf] (or dov_grid_id of an upload)", field="dov_grid"
            )
        if params.dov_grid and params.dov_grid_id:
            raise ParameterError("give dov_grid or dov_grid_id, not both", field="dov_grid_id")
        grid = load_grids(params.dov_grid) if params.dov_grid else _uploaded(params.dov_grid_id)
    else:
        if paths:
            raise ParameterError("dov_grid is given but dov=egm2008; set dov=grid to use it", field="dov")
        grid = _egm(lat, lon, progress)
    problem = grid.missing_cover(lat, lon)
    if problem:
        raise ParameterError(f"the DOV grid does not cover the track: {problem}", field="dov_grid")
    xi, eta, dg = grid.interpolate(lat, lon, "linear")
    inp.gravity = (np.ascontiguousarray(xi), np.ascontiguousarray(eta), np.ascontiguousarray(dg))
    # first-order effect on the height: velocity from the track
    from ldvsurvey.nav.earth import radii

    rm, rn = radii(np.radians(lat))
    v_n = np.gradient(np.radians(lat), inp.t_s) * rm
    v_e = np.gradient(np.radians(lon), inp.t_s) * rn * np.cos(np.radians(lat))
    dh = np.concatenate(
        [[0.0], np.cumsum(0.5 * ((xi * v_n + eta * v_e)[1:] + (xi * v_n + eta * v_e)[:-1]) * np.diff(inp.t_s))]
    )
    info = {
        "source": grid.source or mode,
        "xi_arcsec_max": float(np.max(np.abs(xi)) / RAD_PER_ARCSEC),
        "xi_arcsec_rms": float(np.sqrt(np.mean(xi**2)) / RAD_PER_ARCSEC),
        "eta_arcsec_max": float(np.max(np.abs(eta)) / RAD_PER_ARCSEC),
        "eta_arcsec_rms": float(np.sqrt(np.mean(eta**2)) / RAD_PER_ARCSEC),
        "dg_mgal_max": float(np.max(np.abs(dg)) / MPS2_PER_MGAL),
        "dg_mgal_rms": float(np.sqrt(np.mean(dg**2)) / MPS2_PER_MGAL),
        "dg_used": grid.dg_mgal is not None,
        "height_effect_max_m": float(dh[np.argmax(np.abs(dh))]),
        "height_effect_note": "first-order height an INS levelled to the plumb line would gain, "
        "∫(ξ v_N + η v_E) dt along the track; removed by this compensation",
    }
    return info, [warn] if warn else []
