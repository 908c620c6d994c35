"""Regional grids of ξ, η (arcsec) and Δg (mGal): interpolation, coverage, resampling, EGM synthesis."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldvsurvey.units import RAD_PER_ARCSEC as ARCSEC  # noqa: E402  (rad per arcsecond)


@dataclass
class DovGrid:
    """Values on lat × lon nodes (degrees, both ascending). ξ, η in arcsec, Δg in mGal (optional)."""

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    xi_arcsec: np.ndarray  # (n_lat, n_lon)
    eta_arcsec: np.ndarray
    dg_mgal: np.ndarray | None = None
    source: str = ""

    @property
    def step_arcmin(self) -> float:
        """Node spacing in latitude (arcmin, the median)."""
        return float(np.median(np.diff(self.lat_deg)) * 60.0)

    def covers(self, lat_deg, lon_deg) -> bool:
        """Whether every point (deg) lies within the grid's nodes, edges included."""
        return bool(
            np.all(
                (lat_deg >= self.lat_deg[0])
                & (lat_deg <= self.lat_deg[-1])
                & (lon_deg >= self.lon_deg[0])
                & (lon_deg <= self.lon_deg[-1])
            )
        )

    def missing_cover(self, lat_deg, lon_deg) -> str | None:
        """A description of how the track leaves the grid, or None when it is covered."""
        lo_lat, hi_lat = float(np.min(lat_deg)), float(np.max(lat_deg))
        lo_lon, hi_lon = float(np.min(lon_deg)), float(np.max(lon_deg))
        if self.covers(np.array([lo_lat, hi_lat]), np.array([lo_lon, hi_lon])):
            return None
        return (
            f"the track spans lat {lo_lat:.4f}..{hi_lat:.4f}°, lon {lo_lon:.4f}..{hi_lon:.4f}° but the grid "
            f"covers lat {self.lat_deg[0]:.4f}..{self.lat_deg[-1]:.4f}°, "
            f"lon {self.lon_deg[0]:.4f}..{self.lon_deg[-1]:.4f}°"
        )

    def interpolate(self, lat_deg, lon_deg, method: str = "linear"):
        """ξ, η and Δg interpolated at the points.

        Parameters
        ----------
        lat_deg, lon_deg : arrays
            The points (deg), same shape, inside the grid.
        method : str
            'linear' (bilinear) or 'cubic' (interpolating bicubic spline).

        Returns
        -------
        xi_rad, eta_rad : arrays
            Deflection (rad), the shape of ``lat_deg``.
        dg_mps2 : array
            Δg (m/s²; zeros when the grid has none).
        """
        from scipy.interpolate import RectBivariateSpline, RegularGridInterpolator

        la = np.asarray(lat_deg, float).ravel()
        lo = np.asarray(lon_deg, float).ravel()
        pts = np.column_stack([la, lo])
        out = []
        arrays = [(self.xi_arcsec, ARCSEC), (self.eta_arcsec, ARCSEC)]
        arrays.append((self.dg_mgal, 1e-5) if self.dg_mgal is not None else (None, 0.0))
        for arr, unit in arrays:
            if arr is None:
                out.append(np.zeros(np.shape(lat_deg)))
            elif method == "cubic":  # interpolating bicubic spline (exact for cubic polynomials)
                f = RectBivariateSpline(self.lat_deg, self.lon_deg, arr, kx=3, ky=3, s=0)
                out.append(f.ev(la, lo).reshape(np.shape(lat_deg)) * unit)
            else:
                f = RegularGridInterpolator((self.lat_deg, self.lon_deg), arr, method="linear")
                out.append(f(pts).reshape(np.shape(lat_deg)) * unit)
        return tuple(out)

    def resample(self, step_arcmin: float) -> DovGrid:
        """The grid's values sampled at a coarser step, covering at least the original extent.

        Parameters
        ----------
        step_arcmin : float
            The new node spacing (arcmin).

        Returns
        -------
        DovGrid
            Bilinear samples of ξ, η (arcsec) and Δg (mGal) from the south-west corner on.
        """
        from scipy.interpolate import RegularGridInterpolator

        st = step_arcmin / 60.0
        # nodes from the south-west corner until past the north-east one (the last row/column is
        # extrapolated linearly by less than one coarse step), so the coarse grid covers the fine one
        lat = self.lat_deg[0] + st * np.arange(int(np.ceil((self.lat_deg[-1] - self.lat_deg[0]) / st - 1e-9)) + 1)
        lon = self.lon_deg[0] + st * np.arange(int(np.ceil((self.lon_deg[-1] - self.lon_deg[0]) / st - 1e-9)) + 1)
        gl, go = np.meshgrid(lat, lon, indexing="ij")
        vals = []
        for arr in (self.xi_arcsec, self.eta_arcsec) + ((self.dg_mgal,) if self.dg_mgal is not None else ()):
            f = RegularGridInterpolator(
                (self.lat_deg, self.lon_deg), arr, method="linear", bounds_error=False, fill_value=None
            )
            vals.append(f(np.column_stack([gl.ravel(), go.ravel()])).reshape(gl.shape))
        return DovGrid(
            lat,
            lon,
            vals[0],
            vals[1],
            vals[2] if len(vals) > 2 else None,
            source=f"{self.source} resampled to {step_arcmin}'",
        )


def area_for_track(lat_deg, lon_deg, step_arcmin: float, margin_steps: int = 3):
    """Grid bounds snapped to the step, covering the track with a margin.

    Parameters
    ----------
    lat_deg, lon_deg : arrays
        The track (deg).
    step_arcmin : float
        Grid step (arcmin).
    margin_steps : int
        Margin beyond the track on each side (steps).

    Returns
    -------
    tuple of float
        (south, north, west, east) (deg).
    """
    st = step_arcmin / 60.0
    s = np.floor(np.min(lat_deg) / st) * st - margin_steps * st
    n = np.ceil(np.max(lat_deg) / st) * st + margin_steps * st
    w = np.floor(np.min(lon_deg) / st) * st - margin_steps * st
    e = np.ceil(np.max(lon_deg) / st) * st + margin_steps * st
    return round(s, 9), round(n, 9), round(w, 9), round(e, 9)


def egm_grid(
    area,
    step_arcmin: float = 1.0,
    degree: int = 2190,
    model_name: str = "egm2008",
    progress=None,
    h_m: float = 0.0,
) -> DovGrid:
    """Synthesize ξ, η and the gravity disturbance δg from the built-in model on an area.

    Parameters
    ----------
    area : tuple of float
        (south, north, west, east) (deg), e.g. from :func:`area_for_track`.
    step_arcmin : float
        Grid step (arcmin).
    degree : int
        Degree of the synthesis.
    model_name : str
        Coefficient file (:func:`ldvsurvey.nav.egm.model_path`).
    progress : callable, optional
        ``progress(message, fraction)`` after each block of rows.
    h_m : float
        Ellipsoidal height of the synthesis (m; 0: on the ellipsoid).

    Returns
    -------
    DovGrid
        ξ, η (arcsec) and δg (mGal) on the nodes.
    """
    from ldvsurvey.nav.egm import disturbing_coefficients, load_model, synthesize

    s, n, w, e = area
    st = step_arcmin / 60.0
    lat = np.arange(s, n + st / 2, st)
    lon = np.arange(w, e + st / 2, st)
    model = disturbing_coefficients(load_model(model_name, n_max=degree))
    xi = np.empty((len(lat), len(lon)))
    eta = np.empty_like(xi)
    dg = np.empty_like(xi)
    chunk = 8
    for i in range(0, len(lat), chunk):
        a, b, c = synthesize(model, lat[i : i + chunk], lon, h_m)
        xi[i : i + chunk], eta[i : i + chunk], dg[i : i + chunk] = a, b, c
        if progress is not None:
            progress(f"EGM2008 synthesis to degree {degree}", min(1.0, (i + chunk) / len(lat)))
    at = f", h = {h_m:.0f} m" if h_m else ""
    return DovGrid(lat, lon, xi, eta, dg, source=f"{model_name} degree {degree}, {step_arcmin}' grid{at}")
