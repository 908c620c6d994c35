"""Strapdown gravity disturbance (methods §4, with the sign of the gravimetry paper's eq. 2 corrected).

δg = f_U − v̇_U − γ(L, h) + (v_E/(R_N+h) + 2ω_ie cos L) v_E + v_N²/(R_M+h)

f_U is the up component of C_b^n f^b, v̇_U the vertical acceleration from the aiding velocity
(LDV or GNSS). Then a window-based zero-phase FIR low-pass (:class:`Lowpass`: Blackman,
``firwin(2·L·fs taps, cutoff 1/L Hz)`` applied forward and backward as in filtfilt), NaN-aware so
gaps do not smear; its one design is :meth:`Lowpass._taps_at`.
All inputs in SI units; outputs in m/s² unless the name says mGal.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.signal import firwin, oaconvolve

from ldvsurvey.nav.earth import MGAL, OMEGA_IE, normal_gravity, radii
from ldvsurvey.units import G0_MPS2

#: standard gravity, m/s² (the old name, still imported by the gravity pipeline; new code: ``units.G0_MPS2``)
G0 = G0_MPS2


def disturbance_mps2(f_u, vdot_u, v_e, v_n, lat_rad, h_m):
    """Gravity disturbance δg from the up specific force and the vehicle motion.

    Parameters
    ----------
    f_u : float or array_like
        Up component of the specific force in the navigation frame n, m/s².
    vdot_u : float or array_like
        Vertical (up) acceleration of the vehicle, m/s².
    v_e, v_n : float or array_like
        East and north velocity, m/s.
    lat_rad : float or array_like
        Geodetic latitude, rad.
    h_m : float or array_like
        Ellipsoidal height, m.

    Returns
    -------
    float or numpy.ndarray
        δg = f_U − v̇_U − γ(L, h) + Eötvös and centripetal terms, m/s² (broadcast shape of the inputs).
    """
    rm, rn = radii(lat_rad)
    return (
        f_u
        - vdot_u
        - normal_gravity(lat_rad, h_m)
        + (v_e / (rn + h_m) + 2 * OMEGA_IE * np.cos(lat_rad)) * v_e
        + v_n**2 / (rm + h_m)
    )


#: sampling rate (per filter length) of the grid the filter's continuous response is computed on
RESPONSE_RATE_PER_LENGTH = 50.0
#: points of that grid's FFT
RESPONSE_N_F = 1 << 16


@dataclass(frozen=True)
class Lowpass:
    """The gravity low-pass: a Blackman-window FIR of length L (cut-off 1/L Hz), applied forward and back.

    A value: built once per run from ``fir_length_s`` and handed to every stage, which binds it to its
    series' sampling rate with :meth:`at`. The taps and the applied kernel h ⋆ h of a bound filter are
    computed once.

    The design is one method, :meth:`_taps_at` (one pass's taps at a given rate): the taps, the kernel,
    the response, the fine |H|⁴ behind the noise gain, the half-amplitude frequency and every noise
    floor all come from it, so a subclass overriding it (another window, a Gaussian FIR) changes them
    all consistently; :meth:`at` keeps the subclass.

    Parameters
    ----------
    length_s : float
        Filter length L, s (one pass has 2·L·f_s (+1, odd) taps).
    rate_hz : float or None
        Sampling rate the filter is bound to, Hz; None for the filter as a design (its response and
        noise gain do not depend on the rate).
    """

    length_s: float
    rate_hz: float | None = None

    def at(self, rate_hz: float) -> Lowpass:
        """The same filter bound to the sampling rate ``rate_hz`` (Hz)."""
        if self.rate_hz is not None and float(rate_hz) == self.rate_hz:
            return self
        return replace(self, rate_hz=float(rate_hz))

    def _taps_at(self, fs_hz: float) -> np.ndarray:
        """One pass's taps at the rate ``fs_hz`` (Hz), unit sum: the filter's design, and its only one.

        Blackman-window low-pass (``scipy.signal.firwin``), 2·L·f_s (+1, odd) taps, cut-off 1/L Hz.
        """
        n = int(round(2 * self.length_s * fs_hz))
        n += 1 - n % 2
        return firwin(n, 1.0 / self.length_s, window="blackman", fs=fs_hz)

    def _rate(self) -> float:
        if self.rate_hz is None:
            raise ValueError("the low-pass is not bound to a sampling rate: use Lowpass.at(rate_hz)")
        return self.rate_hz

    @cached_property
    def taps(self) -> np.ndarray:
        """One pass's taps at the bound rate (:meth:`_taps_at`), unit sum."""
        return self._taps_at(self._rate())

    @cached_property
    def kernel(self) -> np.ndarray:
        """The applied zero-phase kernel h ⋆ h (forward then backward = one pass with it), unit sum."""
        h = self.taps
        return oaconvolve(h, h[::-1])

    def apply(self, x, min_weight: float = 0.5, weights=None, den_cache=None) -> np.ndarray:
        """Forward-backward FIR (as filtfilt) of a series at the bound rate; NaN samples are gaps.

        The filter is applied to the data and to the valid-sample mask and the two are divided,
        so gaps are bridged by the neighbours (normalized convolution).

        Parameters
        ----------
        x : array_like
            Series sampled at ``rate_hz`` (any unit; the output has the same).
        min_weight : float
            Output is NaN where the valid weight under the (doubled) filter is below this (0-1).
        weights : array_like or None
            Optional per-sample weights (e.g. 1/σ²) so better samples dominate; scaled to a maximum of 1.
        den_cache : dict or None
            A dict the caller keeps while it filters several series of one length; the filtered mask of
            a series without gaps or weights (the same for all of them) is computed once.

        Returns
        -------
        numpy.ndarray
            The filtered series, same length and unit as ``x``.
        """
        x = np.asarray(x, dtype=float)
        h2 = self.kernel
        ok = np.isfinite(x)
        w = ok.astype(float)
        if weights is not None:
            w = w * np.nan_to_num(np.asarray(weights, float))
            w = w / max(float(w.max()), 1e-300)
        num = oaconvolve(np.where(ok, x, 0.0) * w, h2, mode="same")
        key = (len(x), self)  # the filter value itself: its design (class, fields) and bound rate
        if den_cache is not None and weights is None and key in den_cache and ok.all():
            den = den_cache[key]
        else:
            den = oaconvolve(w, h2, mode="same")
            if den_cache is not None and weights is None and ok.all():
                den_cache[key] = den
        with np.errstate(invalid="ignore", divide="ignore"):
            y = num / den
        y[den < min_weight] = np.nan
        return y

    @cached_property
    def fine_response4(self) -> tuple[np.ndarray, np.ndarray]:
        """Frequencies (Hz) and |H(f)|⁴ of the applied (forward and back) filter on a fine grid.

        The taps at a rate of 50 samples per filter length (any rate well above the cut-off gives the same
        response), zero-padded to an FFT of ``RESPONSE_N_F`` points; whatever the bound rate."""
        fs = RESPONSE_RATE_PER_LENGTH / self.length_s
        h = self._taps_at(fs)
        hf = np.fft.rfft(h, RESPONSE_N_F)
        f = np.fft.rfftfreq(RESPONSE_N_F, 1.0 / fs)
        return f, np.abs(hf) ** 4

    def response(self, freq_hz) -> np.ndarray:
        """Amplitude response |H(f)|² of the applied (forward and back) filter at ``freq_hz`` (Hz); 1 at 0 Hz.

        Of the taps at the bound rate; unbound, at a rate of 50 samples per filter length (the continuous
        response below that rate's Nyquist frequency)."""
        fs = self.rate_hz or RESPONSE_RATE_PER_LENGTH / self.length_s
        h = self.taps if self.rate_hz else self._taps_at(fs)
        k = np.arange(len(h)) - (len(h) - 1) / 2
        f = np.atleast_1d(np.asarray(freq_hz, float))
        hf = np.exp(-2j * np.pi * np.outer(f, k) / fs) @ h
        return np.abs(hf) ** 2 / np.sum(h) ** 2

    def noise_integral(self, power: int = 0) -> float:
        """2 ∫₀^∞ (2πf)^p |H(f)|⁴ df (two-sided): the filtered variance of noise of unit two-sided PSD
        differenced p/2 times (p = 0 white acceleration, 2 white velocity, 4 white height), in Hz^(p+1)."""
        f, h4 = self.fine_response4
        w = 2 * np.pi * f
        return 2.0 * np.sum(w**power * h4) * (f[1] - f[0])

    @property
    def noise_gain(self) -> float:
        """∫|H|⁴ df over all frequencies (Hz): white noise of density N (unit/√Hz) comes out with variance
        N²·noise_gain; its inverse is the correlation time τ_c (s)."""
        return self.noise_integral(0)

    @property
    def correlation_time_s(self) -> float:
        """τ_c = 1/∫|H|⁴df (s): a mean over T ≫ L of filtered white noise has the variance of T/τ_c samples."""
        return float(1.0 / self.noise_gain)

    @cached_property
    def half_amplitude_hz(self) -> float:
        """Frequency (Hz) where the applied filter passes half the amplitude (−6 dB; the single pass's
        nominal cut-off 1/L passes a quarter after both passes)."""
        f, h4 = self.fine_response4
        amp = np.sqrt(h4 / h4[0])
        k = int(np.argmax(amp < 0.5))
        return float(np.interp(0.5, [amp[k], amp[k - 1]], [f[k], f[k - 1]]))

    def half_wavelength_m(self, speed_mps: float) -> float:
        """Half-wavelength resolution (m) at ``speed_mps`` (m/s): v / (2 f½), f½ = :attr:`half_amplitude_hz`."""
        return float(speed_mps / (2.0 * self.half_amplitude_hz))

    def nominal_half_wavelength_m(self, speed_mps: float) -> float:
        """Half-wavelength (m) at the single pass's cut-off 1/L: v·L/2 (``speed_mps`` in m/s)."""
        return 0.5 * speed_mps * self.length_s


def second_difference_noise_gain(valid, lowpass: Lowpass) -> np.ndarray:
    """σ of the low-pass of a second difference of white noise, relative to the interior.

    ``lowpass``: the filter bound to the series' rate (:meth:`Lowpass.at`). ``valid``: the samples of
    the double-differenced series (e.g. δg from GNSS heights) the filter uses (False: a break). Far
    from breaks the filter's kernel is smooth and the second differences of white height noise cancel
    into the small interior σ; next to a break the truncated kernel
    keeps one edge velocity error (σ_h·√2/Δt, centimetres per second) almost unweighted, which is
    tens of mGal. Exact propagation: the filtered value is Σ_k c_k Δ²e_k, c_k = h2(t−k)·valid_k/den,
    so its variance is σ²·Σ_j (Δ²ᵀc)_j² = σ²·[6 S₀ − 4 (S₁ + S₋₁) + S₂ + S₋₂]/den² with
    S_δ(t) = Σ_i valid_i valid_{i+δ} h2(t−i) h2(t−i−δ). Returns that σ over the σ with every sample
    valid (1 in the interior; NaN where the filter gives no value).
    """
    g = np.asarray(valid, bool).astype(float)
    h2 = lowpass.kernel
    m = len(h2) // 2
    n = len(g)

    def s_delta(d):
        x = np.zeros(n)
        if d >= 0:
            x[: n - d] = g[: n - d] * g[d:]
        else:
            x[-d:] = g[-d:] * g[: n + d]
        k = h2 * np.roll(np.r_[h2, 0.0], d)[: len(h2)] if d >= 0 else h2 * np.r_[h2[-d:], np.zeros(-d)]
        full = oaconvolve(x, k)
        return full[m : m + n]

    var = 6 * s_delta(0) - 4 * (s_delta(1) + s_delta(-1)) + s_delta(2) + s_delta(-2)
    den = oaconvolve(g, h2)[m : m + n]
    k1 = h2 * np.r_[0.0, h2[:-1]]
    k2 = h2 * np.r_[0.0, 0.0, h2[:-2]]
    inner = np.sqrt(max(6 * np.sum(h2 * h2) - 8 * np.sum(k1) + 2 * np.sum(k2), 1e-300))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.sqrt(np.maximum(var, 0.0)) / den / inner
    out[den < 0.5] = np.nan
    return out


# ---------------------------------------------------------------------------------------------
# gaps


def runs(mask):
    """(start, stop) index pairs of the True runs of a boolean array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    e = np.flatnonzero(m[1:] != m[:-1])  # where the padded mask changes (bytes, not an int per sample)
    return list(zip(e[::2], e[1::2]))


def _edge_offset(seg, lo: int, hi: int, at: int, fit: str) -> float:
    """The offset at sample ``at`` from the valid samples lo..hi−1 next to it, ``seg`` their offsets (mean or line)."""
    if fit == "line" and len(seg) >= 3:
        x = np.arange(lo, hi, dtype=float) - at
        _slope, a0 = np.polyfit(x, seg, 1)
        return float(a0)
    return float(np.mean(seg))


def bridge_velocity(v_mps, ok, v_ref_mps, edge_n: int = 1, edge_fit: str = "mean"):
    """Fill the gaps (``~ok``) of a series with a reference series tied to both gap ends.

    Inside a gap: the reference (e.g. the smoothed navigation velocity) plus an offset varying
    linearly from the left to the right edge's ``v − v_ref``, each taken from up to ``edge_n``
    valid samples next to the edge (so one noisy edge sample is not spread over the whole gap):
    their mean (``edge_fit="mean"``), or a least-squares line through them evaluated at the edge
    sample (``"line"``: unbiased where the offset trends, e.g. heights against a doubly
    integrated specific force whose velocity has drifted; a mean over n samples would put a step
    of slope·(n−1)/2 at each edge). The bridged series is continuous with the data, so its
    difference quotient still telescopes and a gap costs only its own samples. Gaps at either
    end take the offset of their one edge. Works for any quantity (velocity through velocity,
    height through the doubly integrated specific force, ...).
    """
    if edge_fit not in ("mean", "line"):
        raise ValueError(f"edge_fit is 'mean' or 'line', got {edge_fit!r}")
    v = np.array(v_mps, float, copy=True)
    ok = np.asarray(ok, bool) & np.isfinite(v)
    if not ok.any():
        raise ValueError("no valid sample to bridge from")
    n = len(v)
    segs = runs(~ok)
    for i, (a, b) in enumerate(segs):
        lo = segs[i - 1][1] if i > 0 else 0
        hi = segs[i + 1][0] if i + 1 < len(segs) else n
        # the offsets v − v_ref only next to the gap (never a whole per-sample series of them)
        la, hb = max(lo, a - edge_n), min(hi, b + edge_n)
        oa = _edge_offset(v[la:a] - v_ref_mps[la:a], la, a, a - 1, edge_fit) if a > 0 else None
        ob = _edge_offset(v[b:hb] - v_ref_mps[b:hb], b, hb, b, edge_fit) if b < n else None
        oa = ob if oa is None else oa
        ob = oa if ob is None else ob
        w = (np.arange(a, b) - (a - 1)) / (b - a + 1)
        v[a:b] = v_ref_mps[a:b] + (1 - w) * oa + w * ob
    return v


# ---------------------------------------------------------------------------------------------
# white-noise floor of a repeated-line coincidence


def noise_floor_mgal(
    lowpass: Lowpass,
    accel_noise_ug_rthz: float | None = None,
    ldv_noise_mps: float | None = None,
    ldv_rate_hz: float | None = None,
    height_noise_m: float | None = None,
    gnss_rate_hz: float | None = None,
    height_correlated_m: float | None = None,
    height_correlation_s: float | None = None,
) -> dict:
    """1-σ of white sensor noise after the zero-phase FIR: the floor of a repeated-line coincidence (mGal).

    The per-line coincidence ε_i estimates the σ of one line's filtered δg (the n/(n−1) factor
    undoes the mean line), so white noise alone gives ε = this σ:

    - accelerometer, density N (µg/√Hz, per-sample σ = N·√f_s): σ² = N² ∫|H|⁴ df;
    - LDV vertical velocity, white σ_v per sample at rate f_L, differenced once:
      σ² = σ_v²/f_L ∫(2πf)²|H|⁴ df;
    - GNSS height, white σ_h per epoch at rate f_G, differenced twice: σ² = σ_h²/f_G ∫(2πf)⁴|H|⁴ df;
    - GNSS height, a slowly wandering part (first-order Gauss-Markov, stationary σ_c, correlation
      time τ; two-sided PSD S(f) = 2σ_c²τ / (1 + (2πfτ)²)) differenced twice:
      σ² = ∫(2πf)⁴ S(f) |H|⁴ df (receivers' RTK heights wander by centimetres over minutes).

    Integrals run over all (two-sided) frequencies; |H|⁴ because the FIR runs forward and back.

    Parameters
    ----------
    lowpass : Lowpass
        The filter (bound to a rate or not: the floor does not depend on it), e.g. ``Lowpass(length_s)``.
    accel_noise_ug_rthz : float or None
        Accelerometer white-noise density N, µg/√Hz.
    ldv_noise_mps, ldv_rate_hz : float or None
        LDV vertical velocity white σ per sample (m/s) and its rate (Hz).
    height_noise_m, gnss_rate_hz : float or None
        GNSS height white σ per epoch (m) and the epoch rate (Hz).
    height_correlated_m, height_correlation_s : float or None
        Stationary σ (m) and correlation time (s) of the heights' Gauss-Markov wander.

    Returns
    -------
    dict
        The components given (``accel_mgal``, ``ldv_mgal``, ``gnss_height_mgal``,
        ``gnss_height_correlated_mgal``) and their root-sum-square ``total_mgal``, mGal.
    """
    if not isinstance(lowpass, Lowpass):
        raise TypeError(f"noise_floor_mgal takes the filter, e.g. Lowpass(length_s), not {type(lowpass).__name__}")
    f, h4 = lowpass.fine_response4
    df = f[1] - f[0]
    w = 2 * np.pi * f
    integral = lowpass.noise_integral

    out = {}
    if accel_noise_ug_rthz:
        out["accel_mgal"] = float(accel_noise_ug_rthz * 1e-6 * G0_MPS2 * np.sqrt(integral(0)) / MGAL)
    if ldv_noise_mps and ldv_rate_hz:
        out["ldv_mgal"] = float(ldv_noise_mps * np.sqrt(integral(2) / ldv_rate_hz) / MGAL)
    if height_noise_m and gnss_rate_hz:
        out["gnss_height_mgal"] = float(height_noise_m * np.sqrt(integral(4) / gnss_rate_hz) / MGAL)
    if height_correlated_m and height_correlation_s:
        tau = float(height_correlation_s)
        psd = 2.0 * height_correlated_m**2 * tau / (1.0 + (w * tau) ** 2)
        out["gnss_height_correlated_mgal"] = float(np.sqrt(2.0 * np.sum(w**4 * psd * h4) * df) / MGAL)
    out["total_mgal"] = float(np.sqrt(sum(v**2 for v in out.values())))
    return out


def trim_line(t_s, t_start: float, t_end: float, trim_s: float):
    """Mask of the samples of a line [t_start, t_end] with ``trim_s`` removed at both ends."""
    t = np.asarray(t_s, float)
    return (t >= t_start + trim_s) & (t <= t_end - trim_s)
