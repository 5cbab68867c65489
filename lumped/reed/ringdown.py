"""Free-vibration identification of a plucked reed (thesis section 3.8.2, Table 3.10).

A reed plucked in air rings down as eq 3.67::

    v(t) = C4 exp(-sigma t) sin(omega_d t + phi) (+ offset),  sigma = gamma1 c_c / (2 rho_c h_eff);

fitting it by nonlinear least squares gives sigma and omega_d, hence the internal
damping c_c (eq 3.67), the undamped frequency omega_n (eq 3.70) and the reed stiffness
kappa (eq 3.73) once gamma1, rho_c and h_eff are known. Several runs are summarised
as Table 3.10 does (mean, sample standard deviation, uncertainty). SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import find_peaks

from geometry.errors import InputError

# -- the relations of section 3.8.2 -----------------------------------------------------


def decay_rate(c_c: float, gamma1: float, rho_c: float, h_eff: float) -> float:
    """Envelope decay rate of a plucked reed's ring-down, sigma = gamma1 c_c / (2 rho_c h_eff) (eq 3.67).

    Parameters
    ----------
    c_c : float
        Internal damping [Pa s/m].
    gamma1 : float
        [-].
    rho_c : float
        [kg/m^3].
    h_eff : float
        [m].

    Returns
    -------
    float
        sigma [1/s].

    References
    ----------
    Knutson (2016), eq 3.67.
    """
    return gamma1 * c_c / (2.0 * rho_c * h_eff)


def internal_damping(sigma: float, gamma1: float, rho_c: float, h_eff: float) -> float:
    """Internal damping from a fitted decay rate, c_c = 2 rho_c h_eff sigma / gamma1 (eq 3.67 inverted).

    Parameters
    ----------
    sigma : float
        Decay rate [1/s].
    gamma1 : float
        [-].
    rho_c : float
        [kg/m^3].
    h_eff : float
        [m].

    Returns
    -------
    float
        c_c [Pa s/m].

    References
    ----------
    Knutson (2016), eq 3.67, Table 3.10.

    Examples
    --------
    Table 3.10's mean c_c, through its decay rate and back:

    >>> round(internal_damping(decay_rate(77.50, 1.6, 1410.0, 1.161e-3), 1.6, 1410.0, 1.161e-3), 2)
    77.5
    """
    return 2.0 * rho_c * h_eff * sigma / gamma1


def undamped_frequency(omega_d: float, c_c: float, gamma1: float, rho_c: float, h_eff: float) -> float:
    """Undamped frequency of a plucked reed from its damped one, omega_n = sqrt(omega_d^2 + sigma^2) (eq 3.70).

    Parameters
    ----------
    omega_d : float
        Damped frequency [rad/s].
    c_c : float
        Internal damping [Pa s/m].
    gamma1 : float
        [-].
    rho_c : float
        [kg/m^3].
    h_eff : float
        [m].

    Returns
    -------
    float
        omega_n [rad/s].

    References
    ----------
    Knutson (2016), eq 3.70.
    """
    return float(np.hypot(omega_d, decay_rate(c_c, gamma1, rho_c, h_eff)))


def stiffness_from_frequency(omega_n: float, gamma1: float, rho_c: float, h_eff: float) -> float:
    """Stiffness of a reed from its undamped frequency, kappa = rho_c h_eff omega_n^2 / gamma1 (eq 3.73).

    Parameters
    ----------
    omega_n : float
        [rad/s].
    gamma1 : float
        [-].
    rho_c : float
        [kg/m^3].
    h_eff : float
        [m].

    Returns
    -------
    float
        kappa [Pa/m].

    References
    ----------
    Knutson (2016), eq 3.73, Table 3.10.
    """
    return rho_c * h_eff * omega_n**2 / gamma1


def implied_effective_thickness(kappa: float, omega_d: float, c_c: float, gamma1: float,
                                rho_c: float) -> float:
    """The effective thickness for which eqs 3.70 and 3.73 turn (c_c, omega_d) into kappa: the larger root h of
    kappa = rho_c h omega_d^2 / gamma1 + gamma1 c_c^2 / (4 rho_c h).

    Parameters
    ----------
    kappa : float
        [Pa/m].
    omega_d : float
        [rad/s].
    c_c : float
        [Pa s/m].
    gamma1 : float
        [-].
    rho_c : float
        [kg/m^3].

    Returns
    -------
    float
        h_eff [m].

    References
    ----------
    Knutson (2016), eqs 3.70, 3.73.
    """
    a = rho_c * omega_d**2 / gamma1
    c = gamma1 * c_c**2 / (4.0 * rho_c)
    return (kappa + np.sqrt(kappa**2 - 4.0 * a * c)) / (2.0 * a)


def ringdown(t, amplitude: float, sigma: float, omega_d: float, phase: float, offset: float = 0.0):
    """A plucked reed's ring-down, amplitude exp(-sigma t) sin(omega_d t + phase) + offset (eq 3.67).

    Parameters
    ----------
    t : array_like
        Time [s].
    amplitude : float
        In the trace's units.
    sigma : float
        [1/s].
    omega_d : float
        [rad/s].
    phase : float
        [rad].
    offset : float
        In the trace's units.

    Returns
    -------
    numpy.ndarray
        The signal (the amplitude's units).

    References
    ----------
    Knutson (2016), eq 3.67.
    """
    t = np.asarray(t, dtype=float)
    return amplitude * np.exp(-sigma * t) * np.sin(omega_d * t + phase) + offset


# -- fitting --------------------------------------------------------------------------


@dataclass(frozen=True)
class RingdownFit:
    """Eq 3.67 fitted to one trace: amplitude (trace units), sigma [1/s], omega_d [rad/s], phase [rad],
    offset (trace units), rms residual (trace units), and the derived c_c [Pa s/m], omega_n [rad/s],
    kappa [Pa/m]."""

    amplitude: float
    sigma: float
    omega_d: float
    phase: float
    offset: float
    rms_residual: float
    c_c: float
    omega_n: float
    kappa: float


def _check_trace(t, v, where: str):
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.ndim != 1 or v.shape != t.shape:
        raise InputError(where, f"time and signal must be 1-D arrays of equal length, got {t.shape} and {v.shape}")
    if t.size < 20:
        raise InputError(where, f"needs at least 20 samples, got {t.size}")
    if not np.all(np.isfinite(t)):
        raise InputError(f"{where}.t", "contains NaN or infinite times")
    if not np.all(np.isfinite(v)):
        raise InputError(f"{where}.v", "contains NaN or infinite values")
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{where}.t", "times must increase strictly")
    if np.ptp(v) == 0.0:
        raise InputError(f"{where}.v", "the signal is constant: nothing to fit")
    return t, v


def initial_guess(t, v) -> tuple[float, float, float, float, float]:
    """Starting values of eq 3.67's fit from the FFT peak and the logarithmic decrement.

    omega_d: Hann-windowed, zero-padded FFT peak refined by parabolic interpolation; sigma: slope of log(peak
    height) over successive peaks (log decrement / period); amplitude and phase: linear least squares with sigma and
    omega_d fixed; the offset: the median of the last fifth.

    Parameters
    ----------
    t : array of float
        Sample times [s], increasing.
    v : array of float
        The trace (any unit: volts or metres).

    Returns
    -------
    (amplitude, sigma, omega_d, phase, offset) : tuple of float
        In v's unit, 1/s, rad/s, rad, v's unit.

    References
    ----------
    Knutson (2016), eq 3.67.
    """
    t = np.asarray(t, float)
    v = np.asarray(v, float)
    t0 = t - t[0]
    offset = float(np.median(v[-max(len(v) // 5, 5):]))
    y = v - offset
    dt = float(np.median(np.diff(t0)))
    nfft = 1 << int(np.ceil(np.log2(len(y) * 8)))
    spec = np.abs(np.fft.rfft(y * np.hanning(len(y)), nfft))
    spec[0] = 0.0
    k = int(np.argmax(spec))
    if 0 < k < len(spec) - 1:
        a, b, c = np.log(spec[k - 1 : k + 2] + 1e-300)
        k = k + 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else k
    omega = 2 * np.pi * k / (nfft * dt)
    # log decrement from the positive peaks
    period = 2 * np.pi / omega
    peaks, _ = find_peaks(y, distance=max(int(0.6 * period / dt), 1))
    peaks = peaks[y[peaks] > 0]
    sigma = 0.0
    if len(peaks) >= 3:
        keep = y[peaks] > 0.1 * y[peaks].max()  # above the noise floor
        if keep.sum() >= 3:
            slope = np.polyfit(t0[peaks][keep], np.log(y[peaks][keep]), 1)[0]
            sigma = max(-slope, 0.0)
    env = np.exp(-sigma * t0)
    A = np.column_stack([env * np.sin(omega * t0), env * np.cos(omega * t0)])
    (p, q), *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(np.hypot(p, q)), float(sigma), float(omega), float(np.arctan2(q, p)), offset


def fit_ringdown(t, v, *, with_offset: bool = True, where: str = "trace") -> tuple[np.ndarray, float]:
    """Fit eq 3.67, v = A exp(-sigma t) sin(omega_d t + phase) + offset, to one trace by nonlinear least squares
    (scipy.optimize.least_squares from :func:`initial_guess`).

    Parameters
    ----------
    t : array of float
        Sample times [s], increasing; time is measured from the first sample.
    v : array of float
        The trace (any unit).
    with_offset : bool
        False fixes the offset at 0 (eq 3.67 as printed).
    where : str
        Names the trace in an InputError (NaN, times not increasing, constant).

    Returns
    -------
    x : array of float
        [amplitude, sigma [1/s], omega_d [rad/s], phase [rad], offset].
    rms : float
        The residual's root mean square (v's unit).

    References
    ----------
    Knutson (2016), eq 3.67.
    """
    t, v = _check_trace(t, v, where)
    t0 = t - t[0]
    A0, s0, w0, p0, o0 = initial_guess(t, v)
    if not with_offset:
        o0 = 0.0
    scale = max(np.ptp(v), 1e-300)

    def resid(x):
        off = x[4] if with_offset else 0.0
        return (ringdown(t0, x[0], x[1], x[2], x[3], off) - v) / scale

    x0 = np.array([A0, s0, w0, p0, o0])
    lo = [-np.inf, 0.0, 0.5 * w0, -np.inf, -np.inf]
    hi = [np.inf, np.inf, 1.5 * w0, np.inf, np.inf]
    sol = least_squares(resid, x0, bounds=(lo, hi), x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14)
    x = sol.x.copy()
    if not with_offset:
        x[4] = 0.0
    if x[0] < 0:  # same curve with a positive amplitude
        x[0], x[3] = -x[0], x[3] + np.pi
    x[3] = (x[3] + np.pi) % (2 * np.pi) - np.pi
    rms = float(np.sqrt(np.mean((sol.fun * scale) ** 2)))
    return x, rms


def identify_run(t, v, gamma1: float, rho_c: float, h_eff: float, *, with_offset: bool = True,
                 where: str = "trace") -> RingdownFit:
    """One plucked-reed run: eq 3.67's fit, then c_c (eq 3.69), omega_n (eq 3.70) and kappa (eq 3.73).

    Parameters
    ----------
    t, v : array of float
        The trace: times [s] and values (any unit).
    gamma1 : float
        The reed's gamma1 [-] (the thesis took stepped reed #2's 1.640).
    rho_c : float
        Density [kg/m^3].
    h_eff : float
        Effective thickness [m].
    with_offset, where
        As :func:`fit_ringdown`.

    Returns
    -------
    RingdownFit
        The fit and c_c [Pa s/m], omega_n [rad/s], kappa [Pa/m].

    References
    ----------
    Knutson (2016), section 3.8.2.1, eqs 3.67-3.73.
    """
    for name, val in (("gamma1", gamma1), ("rho_c", rho_c), ("h_eff", h_eff)):
        if not (np.isfinite(val) and val > 0):
            raise InputError(name, f"must be a positive number, got {val}")
    x, rms = fit_ringdown(t, v, with_offset=with_offset, where=where)
    amp, sigma, omega_d, phase, off = (float(a) for a in x)
    c_c = internal_damping(sigma, gamma1, rho_c, h_eff)
    omega_n = undamped_frequency(omega_d, c_c, gamma1, rho_c, h_eff)
    return RingdownFit(amp, sigma, omega_d, phase, off, rms, c_c, omega_n,
                       stiffness_from_frequency(omega_n, gamma1, rho_c, h_eff))


def summarise(values) -> dict:
    """Mean, sample standard deviation and uncertainty [+- %] of repeated runs, as in Table 3.10.

    Table 3.10's uncertainty is 100 std / (2 sqrt(n) |mean|): it gives 0.3954 % for c_c (printed 0.3953,
    truncated) and 0.04083 % for omega; its kappa entry 0.8174 is 10x the same formula's 0.08174
    (docs/errata.md).

    Parameters
    ----------
    values : array_like of float
        One value per run.

    Returns
    -------
    dict
        {"mean", "std", "uncertainty_pct", "n"}.

    References
    ----------
    Knutson (2016), Table 3.10.

    Examples
    --------
    Table 3.10's six runs of c_c [Pa s/m] (printed: mean 77.50, standard deviation 1.501, +- 0.3953 %):

    >>> s = summarise([79.18, 77.52, 75.88, 76.00, 77.07, 79.34])
    >>> print(f"{s['mean']:.2f} {s['std']:.3f} {s['uncertainty_pct']:.3f}")
    77.50 1.501 0.395
    """
    a = np.asarray(values, dtype=float)
    n = a.size
    mean = float(a.mean())
    std = float(a.std(ddof=1)) if n > 1 else 0.0
    unc = 100.0 * std / (2.0 * np.sqrt(n) * abs(mean)) if n > 1 and mean != 0 else 0.0
    return {"mean": mean, "std": std, "uncertainty_pct": float(unc), "n": n}


def identify(traces, gamma1: float, rho_c: float, h_eff: float, *, with_offset: bool = True) -> dict:
    """Identify c_c, omega_d, omega_n and kappa from plucked-reed traces, summarised like Table 3.10.

    Parameters
    ----------
    traces : iterable of (array, array)
        (t [s], v) pairs (v in any unit: volts or metres).
    gamma1, rho_c, h_eff, with_offset
        As :func:`identify_run`.

    Returns
    -------
    dict
        {"runs": [RingdownFit, ...], "c_c", "omega_d", "omega_n", "kappa"}, each summary from :func:`summarise`.

    References
    ----------
    Knutson (2016), section 3.8.2.1, Table 3.10.
    """
    runs = [identify_run(t, v, gamma1, rho_c, h_eff, with_offset=with_offset, where=f"trace[{i}]")
            for i, (t, v) in enumerate(traces)]
    if not runs:
        raise InputError("traces", "no trace given")
    out = {"runs": runs}
    for key in ("c_c", "omega_d", "omega_n", "kappa"):
        out[key] = summarise([getattr(r, key) for r in runs])
    return out
