"""Laser triangulation through air, a PMMA window and oil (Knutson 2016, section 5.3, Appendix B).

Geometry of Figure 5.2, as eqs 5.5-5.8 define it. The laser beam leaves the sensor
normal to the window, so it crosses every interface undeflected and the spot moves
along the beam by the actual displacement ``x_act``. The receiving lens sits a
distance C_1 behind the sensor face and C_2 across from the beam; the ray from the
spot back to the lens refracts at the oil-PMMA and PMMA-air interfaces (Snell,
eqs 5.1-5.4). With the lens at depth 0, the layers are air ``C_1 + t_a``, window
``t_p`` and oil ``t_o`` (+ ``x_act``), and the ray's lateral travel through them adds up
to C_2 (eqs 5.6, 5.7). At ``x_act = 0`` the target sits at the sensor's zero-voltage
reference, the point at the standoff L_s in air (eq 5.5): that fixes the oil gap
``t_o`` (eq 5.6). The sensor reads the apparent displacement as if all were air
(eq 5.8), and the voltage is ``x_app / C_app`` (eq 5.9). The actual scale factor
``C_act`` is the least-squares slope of ``x_act`` against that voltage (eq 5.10).

SI units throughout (m, m/V, rad). Uncertainties follow eq 5.11 (the sum of the
absolute one-at-a-time changes), reported in the unit of the result and in percent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from functools import cache
from typing import Callable, Mapping

import numpy as np

from geometry.data_files import package_toml
from geometry.declare import check_field, param, specs
from geometry.errors import InputError

# scipy is imported where it is used: every `valvelab` command imports this module to
# build its parser, and scipy.optimize alone costs about a second to import.

#: thesis manifolds with their inputs in ``instruments/data/lts.toml`` (Table 5.2; the reed one assumed)
MANIFOLDS = ("disc_inlet", "disc_delivery", "reed")
#: samples of the refractive-index experiment (Tables B.1, B.2)
SAMPLES = ("water", "isopropanol_70", "hydraulic_oil", "acrylic")


_SRC = "instruments/data/lts.toml (Table 5.2)"


@dataclass(frozen=True)
class LtsSetup:
    """One LTS measurement through air, a window and a fluid (inputs of Table 5.2), SI units."""

    apparent_scale: float = param("apparent_scale", "m/V", _SRC, bounds=(1e-6, 0.1), positive=True,
                                  doc="C_app, the manufacturer's scale in air")
    c1: float = param("c1", "m", _SRC, bounds=(-1.0, 1.0), doc="C_1, receiving lens behind the sensor face")
    c2: float = param("c2", "m", _SRC, bounds=(1e-4, 1.0), positive=True,
                      doc="C_2, receiving lens across from the laser beam")
    standoff: float = param("standoff", "m", _SRC, bounds=(1e-3, 10.0), positive=True,
                            doc="L_s, sensor face to the zero-voltage reference in air")
    n_air: float = param("n_air", "-", _SRC, bounds=(1.0, 4.0), doc="n_a")
    n_window: float = param("n_window", "-", "Table B.2", bounds=(1.0, 4.0), doc="n_p (PMMA)")
    n_fluid: float = param("n_fluid", "-", "Table B.2", bounds=(1.0, 4.0), doc="n_o (oil)")
    air_gap: float = param("air_gap", "m", _SRC, bounds=(0.0, 10.0), doc="t_a, sensor face to window",
                           typical=(1e-3, 1.0))
    window_thickness: float = param("window_thickness", "m", _SRC, bounds=(0.0, 1.0), doc="t_p",
                                    typical=(5e-4, 0.1))


@dataclass(frozen=True)
class IndexExperiment:
    """One refractive-index measurement of Appendix B (Figure B.1, Table B.1), SI units."""

    c1: float = param("c1", "m", "Table B.1", bounds=(-1.0, 1.0))
    c2: float = param("c2", "m", "Table B.1", bounds=(1e-4, 1.0), positive=True)
    standoff: float = param("standoff", "m", "Table B.1", bounds=(1e-3, 10.0), positive=True)
    n_air: float = param("n_air", "-", "Table B.1", bounds=(1.0, 4.0))
    air_gap: float = param("air_gap", "m", "Table B.1", bounds=(0.0, 10.0), doc="t_a, sensor face to the sample")
    thickness: float = param("thickness", "m", "Table B.1", bounds=(0.0, 1.0), doc="t_m, sample above the target")


@dataclass(frozen=True)
class ScaleFit:
    """Least-squares line x_act = C_act dV + b over the sweep (eq 5.10), SI units."""

    scale: float               # C_act [m/V]
    intercept: float           # b [m]
    x_act: np.ndarray          # [m]
    voltage: np.ndarray        # dV [V]
    max_residual: float        # largest |x_act - (C_act dV + b)| [m]
    r_squared: float


# ---------------------------------------------------------------- validation

def validate(obj, prefix: str = ""):
    """Check a setup or an experiment field by field (its declared bounds).

    Parameters
    ----------
    obj : LtsSetup or IndexExperiment
    prefix : str
        Prepended to a field's name in the refusal.

    Returns
    -------
    LtsSetup or IndexExperiment
        ``obj`` unchanged.

    Raises
    ------
    InputError
        Naming the bad field (also c1 + standoff <= 0).
    """
    for name, _ in specs(obj):
        check_field(obj, name, getattr(obj, name), prefix + name)
    if obj.c1 + obj.standoff <= 0:
        raise InputError(prefix + "c1", "c1 + standoff must be positive")
    return obj


# ------------------------------------------------------------ scale factor

def laser_angle(c1: float, c2: float, standoff: float) -> float:
    """The return ray's angle in air at the zero-voltage reference (eq 5.5 = eq B.1).

    theta_a = atan(C_2 / (C_1 + L_s))

    Parameters
    ----------
    c1 : float
        C_1, the receiving lens behind the sensor face [m].
    c2 : float
        C_2, the receiving lens across from the beam [m].
    standoff : float
        L_s, sensor face to the zero-voltage reference [m].

    Returns
    -------
    float
        [rad].

    References
    ----------
    Knutson (2016), eq 5.5 and eq B.1.
    """
    return math.atan2(c2, c1 + standoff)


def _refracted(s: float | np.ndarray, n: float):
    """Angle [rad] in a medium of index n for the Snell invariant s = n_a sin(theta_a) (eqs 5.1-5.4)."""
    return np.arcsin(s / n)


def oil_gap(setup: LtsSetup) -> float:
    """The oil gap that puts the target at the sensor's reference.

    Eq 5.6 with Snell's law (eqs 5.1, 5.2) and eq 5.5:
    t_o = (C_2 - (C_1 + t_a) tan theta_a - t_p tan theta_p) / tan theta_o.

    Parameters
    ----------
    setup : LtsSetup

    Returns
    -------
    float
        t_o [m].

    References
    ----------
    Knutson (2016), eqs 5.1, 5.2, 5.5, 5.6.

    Examples
    --------
    >>> setup, _ = thesis_setup("disc_inlet")
    >>> print(f"{oil_gap(setup) * 1e3:.2f} mm")
    32.79 mm
    """
    th_a = laser_angle(setup.c1, setup.c2, setup.standoff)
    s = setup.n_air * math.sin(th_a)
    if s >= min(setup.n_window, setup.n_fluid):
        raise InputError("n_air", "the return ray is totally reflected: n_air sin(theta_a) >= n_window or n_fluid")
    rest = setup.c2 - (setup.c1 + setup.air_gap) * math.tan(th_a) - setup.window_thickness * math.tan(
        _refracted(s, setup.n_window))
    t_o = rest / math.tan(_refracted(s, setup.n_fluid))
    if t_o < 0:
        raise InputError(
            "air_gap",
            f"air gap + window ({(setup.air_gap + setup.window_thickness) * 1e3:.3f} mm) reach past the sensor's "
            f"reference point; the oil gap from eq 5.6 would be {t_o * 1e3:.3f} mm",
        )
    return t_o


def _lateral(setup: LtsSetup, theta_a, depth_fluid):
    """Lateral travel [m] of the return ray leaving the lens at theta_a (left side of eqs 5.6/5.7)."""
    s = setup.n_air * np.sin(theta_a)
    return ((setup.c1 + setup.air_gap) * np.tan(theta_a)
            + setup.window_thickness * np.tan(_refracted(s, setup.n_window))
            + depth_fluid * np.tan(_refracted(s, setup.n_fluid)))


def apparent_displacement(setup: LtsSetup, x_act) -> np.ndarray:
    """The apparent displacement the sensor reports for actual displacements through air, window and oil.

    The ray ending on the lens solves eq 5.7 in theta_a2 (Snell gives the other angles; one
    bracketed root, the lateral travel grows with the angle); then eq 5.8.

    Parameters
    ----------
    setup : LtsSetup
    x_act : float or array_like
        Actual displacements [m] from the reference.

    Returns
    -------
    numpy.ndarray
        x_app [m].

    References
    ----------
    Knutson (2016), eqs 5.1-5.8.
    """
    from scipy.optimize import brentq

    x = np.atleast_1d(np.asarray(x_act, dtype=float))
    th1 = laser_angle(setup.c1, setup.c2, setup.standoff)
    t_o = oil_gap(setup)
    if np.any(t_o + x < 0):
        raise InputError("x_act", f"moves the target through the window (oil gap is {t_o * 1e3:.3f} mm)")
    # the ray angle that ends on the lens: eq 5.7 in theta_a2 alone (Snell gives the others);
    # the lateral travel grows monotonically with the angle, so one bracketed root
    hi = math.asin(min(1.0, min(setup.n_window, setup.n_fluid) / setup.n_air)) * (1 - 1e-12)
    th2 = np.array([
        brentq(lambda th: _lateral(setup, th, t_o + xi) - setup.c2, 0.0, min(hi, math.pi / 2 * (1 - 1e-12)),
               xtol=1e-15, rtol=4 * np.finfo(float).eps)
        for xi in x
    ])
    return setup.c2 * (1 / np.tan(th2) - 1 / math.tan(th1))


def actual_displacement(setup: LtsSetup, x_app) -> np.ndarray:
    """The actual displacement for apparent displacements: eq 5.8 then eq 5.7 solved explicitly.

    Parameters
    ----------
    setup : LtsSetup
    x_app : float or array_like
        Apparent displacements [m].

    Returns
    -------
    numpy.ndarray
        x_act [m].

    References
    ----------
    Knutson (2016), eqs 5.7, 5.8.
    """
    xa = np.atleast_1d(np.asarray(x_app, dtype=float))
    th1 = laser_angle(setup.c1, setup.c2, setup.standoff)
    depth_air = setup.c2 / math.tan(th1) + xa          # eq 5.8: C_2 / tan(theta_a2)
    if np.any(depth_air <= 0):
        raise InputError("voltage", "apparent position in front of the receiving lens")
    th2 = np.arctan(setup.c2 / depth_air)
    s = setup.n_air * np.sin(th2)
    rest = setup.c2 - (setup.c1 + setup.air_gap) * np.tan(th2) - setup.window_thickness * np.tan(
        _refracted(s, setup.n_window))
    return rest / np.tan(_refracted(s, setup.n_fluid)) - oil_gap(setup)


def sweep(setup: LtsSetup, x_max: float, points: int) -> tuple[np.ndarray, np.ndarray]:
    """The sensor's voltage at actual displacements from 0 to x_max (eqs 5.1-5.9).

    Parameters
    ----------
    setup : LtsSetup
    x_max : float
        The largest displacement [m].
    points : int
        At least 3.

    Returns
    -------
    x_act : numpy.ndarray
        [m].
    voltage : numpy.ndarray
        dV = x_app / C_app [V].
    """
    if not (math.isfinite(x_max) and x_max > 0):
        raise InputError("x_max", f"must be a positive length, got {x_max!r}")
    if points < 3:
        raise InputError("points", f"need at least 3 points for a line and its residual, got {points}")
    x = np.linspace(0.0, x_max, int(points))
    return x, apparent_displacement(setup, x) / setup.apparent_scale


def scale_factor(setup: LtsSetup, x_max: float | None = None, points: int | None = None) -> ScaleFit:
    """The actual scale factor: the least-squares slope of x_act on the voltage (eqs 5.9, 5.10).

    Parameters
    ----------
    setup : LtsSetup
    x_max : float, optional
        The sweep's largest displacement [m] (default the thesis's 1.2 mm).
    points : int, optional
        The sweep's points (default the thesis's 11).

    Returns
    -------
    ScaleFit
        C_act [m/V], the intercept [m], the sweep, its largest residual [m] and R^2.

    References
    ----------
    Knutson (2016), section 5.3.1, eqs 5.9, 5.10 and Table 5.2.

    Examples
    --------
    The disc inlet manifold (Table 5.2 prints 3.751e-3 m/V):

    >>> setup, _ = thesis_setup("disc_inlet")
    >>> print(f"{scale_factor(setup).scale:.4g} m/V")
    0.003752 m/V
    """
    dx, dp = sweep_settings()
    x, v = sweep(setup, dx if x_max is None else x_max, dp if points is None else points)
    slope, intercept = np.polynomial.polynomial.polyfit(v, x, 1)[::-1]
    resid = x - (slope * v + intercept)
    r2 = 1.0 - np.sum(resid**2) / np.sum((x - x.mean()) ** 2)
    return ScaleFit(float(slope), float(intercept), x, v, float(np.max(np.abs(resid))), float(r2))


def position_from_voltage(setup: LtsSetup, voltage, *, exact: bool = False, scale: float | None = None):
    """The actual position change from sensor voltages.

    Parameters
    ----------
    setup : LtsSetup
    voltage : array_like
        dV [V].
    exact : bool
        Invert eqs 5.7-5.9 exactly instead of the linear eq 5.10.
    scale : float, optional
        C_act [m/V] of eq 5.10 (default :func:`scale_factor`'s).

    Returns
    -------
    numpy.ndarray
        x_act [m], the shape of ``voltage``.
    """
    v = np.asarray(voltage, dtype=float)
    if exact:
        return actual_displacement(setup, v * setup.apparent_scale).reshape(v.shape)
    return (scale if scale is not None else scale_factor(setup).scale) * v


# ------------------------------------------------------------- uncertainty

def uncertainty(f: Callable[[object], float], params, deltas: Mapping[str, float]) -> tuple[float, dict]:
    """The uncertainty of a result by eq 5.11: the sum over the inputs of |f(x_i + dx_i) - f(x)|.

    Parameters
    ----------
    f : callable
        The result as a function of the inputs' dataclass.
    params : LtsSetup or IndexExperiment
        The inputs.
    deltas : mapping
        {input: its absolute uncertainty}, in the input's unit.

    Returns
    -------
    total : float
        In f's unit.
    contributions : dict
        {input: |change|}.

    References
    ----------
    Knutson (2016), eq 5.11.
    """
    f0 = f(params)
    parts = {}
    for name, d in deltas.items():
        if not d:
            parts[name] = 0.0
            continue
        parts[name] = abs(f(replace(params, **{name: getattr(params, name) + d})) - f0)
    return float(sum(parts.values())), parts


# --------------------------------------------------------- refractive index

def refractive_index(exp: IndexExperiment) -> float:
    """The refractive index of a sample from the LTS experiment of Figure B.1 (eqs B.1, B.2).

    n_m = n_a sin(theta_a) sqrt((t_m / (C_2 - (C_1 + t_a) tan theta_a))^2 + 1)

    Parameters
    ----------
    exp : IndexExperiment

    Returns
    -------
    float
        n_m [-].

    References
    ----------
    Knutson (2016), Appendix B, eqs B.1, B.2 and Table B.2.

    Examples
    --------
    The hydraulic oil of Table B.1 (Table B.2 prints 1.476):

    >>> exp, _ = thesis_index_experiment("hydraulic_oil")
    >>> print(f"{refractive_index(exp):.3f}")
    1.475
    """
    th = laser_angle(exp.c1, exp.c2, exp.standoff)
    lateral_left = exp.c2 - (exp.c1 + exp.air_gap) * math.tan(th)
    if lateral_left <= 0:
        raise InputError("air_gap", "the sample surface is at or past the sensor's reference point; "
                                    "eq B.2 needs C2 - (C1 + t_a) tan(theta_a) > 0")
    return exp.n_air * math.sin(th) * math.sqrt((exp.thickness / lateral_left) ** 2 + 1.0)


# ------------------------------------------------------------------- data

@cache
def lts_data() -> dict:
    """The thesis's inputs of the sensor, the manifolds and Appendix B (``instruments/data/lts.toml``).

    Returns
    -------
    dict
        SI units; an entry ``{value, unc}`` or ``{value, unc_pct}`` carries its uncertainty.
    """
    return package_toml("instruments", "lts.toml")


def _vu(entry) -> tuple[float, float]:
    """(value, absolute uncertainty) of a data-file entry {value, unc} or {value, unc_pct}."""
    if "unc_pct" in entry:
        return entry["value"], entry["value"] * entry["unc_pct"] / 100.0
    return entry["value"], entry["unc"]


#: where a thesis setup takes its refractive indices from
INDEX_SOURCES = ("table_b_2", "appendix_b")


def appendix_b_index(sample: str) -> tuple[float, float]:
    """A Table B.1 sample's refractive index recomputed by eqs B.1, B.2 (unrounded), and its eq 5.11 uncertainty.

    Parameters
    ----------
    sample : str
        ``water``, ``isopropanol_70``, ``hydraulic_oil`` or ``acrylic``.

    Returns
    -------
    tuple of float
        (n, its absolute uncertainty) [-].
    """
    exp, deltas = thesis_index_experiment(sample)
    n = refractive_index(exp)
    return n, uncertainty(refractive_index, exp, deltas)[0]


def thesis_setup(manifold: str, *, indices: str = "table_b_2",
                 table_5_2_index_unc: bool = False) -> tuple[LtsSetup, dict]:
    """A thesis manifold's setup and the inputs' uncertainties.

    Parameters
    ----------
    manifold : str
        ``disc_inlet``, ``disc_delivery`` or ``reed`` (its inputs are not printed: assumed the
        mean of the two disc manifolds).
    indices : str
        ``table_b_2`` takes n_o, n_p and their uncertainties as printed in Table B.2 (1.476 +/-
        1.062 %, 1.509 +/- 1.668 %); ``appendix_b`` recomputes them from the raw measurements of
        Table B.1 (eqs B.1, B.2, 5.11).
    table_5_2_index_unc : bool
        Use Table 5.2's rounded +/-0.016, +/-0.025 instead (only to document the erratum).

    Returns
    -------
    setup : LtsSetup
    deltas : dict
        {input: absolute uncertainty} for eq 5.11.

    References
    ----------
    Knutson (2016), Tables 5.2, B.1 and B.2.
    """
    if manifold not in MANIFOLDS:
        raise InputError("manifold", f"expected one of {', '.join(MANIFOLDS)}, got {manifold!r}")
    if indices not in INDEX_SOURCES:
        raise InputError("indices", f"expected one of {', '.join(INDEX_SOURCES)}, got {indices!r}")
    d = lts_data()
    sen, mat, man = d["sensor"], d["materials"], d["manifold"][manifold]
    vals: dict[str, tuple[float, float]] = {
        "apparent_scale": _vu(sen["apparent_scale"]), "c1": _vu(sen["c1"]), "c2": _vu(sen["c2"]),
        "standoff": _vu(sen["standoff"]), "n_air": _vu(d["air"]["refractive_index"]),
        "n_window": _vu(mat["acrylic"]), "n_fluid": _vu(mat["hydraulic_oil"]),
        "air_gap": _vu(man["air_gap"]), "window_thickness": _vu(man["window_thickness"]),
    }
    if indices == "appendix_b":
        vals["n_window"] = appendix_b_index("acrylic")
        vals["n_fluid"] = appendix_b_index("hydraulic_oil")
    if table_5_2_index_unc:
        vals["n_window"] = (vals["n_window"][0], mat["acrylic_unc_table_5_2"])
        vals["n_fluid"] = (vals["n_fluid"][0], mat["hydraulic_oil_unc_table_5_2"])
    setup = LtsSetup(**{k: v for k, (v, _) in vals.items()})
    return setup, {k: u for k, (_, u) in vals.items()}


def thesis_index_experiment(sample: str) -> tuple[IndexExperiment, dict]:
    """A Table B.1 sample's refractive-index experiment and the inputs' uncertainties.

    Parameters
    ----------
    sample : str
        ``water``, ``isopropanol_70``, ``hydraulic_oil`` or ``acrylic``.

    Returns
    -------
    experiment : IndexExperiment
    deltas : dict
        {input: absolute uncertainty} for eq 5.11.
    """
    if sample not in SAMPLES:
        raise InputError("sample", f"expected one of {', '.join(SAMPLES)}, got {sample!r}")
    d = lts_data()
    ie, smp = d["index_experiment"], d["index_experiment"]["sample"][sample]
    vals = {"c1": _vu(ie["c1"]), "c2": _vu(ie["c2"]), "standoff": _vu(ie["standoff"]),
            "n_air": _vu(d["air"]["refractive_index"]),
            "air_gap": _vu(smp["air_gap"]), "thickness": _vu(smp["thickness"])}
    return IndexExperiment(**{k: v for k, (v, _) in vals.items()}), {k: u for k, (_, u) in vals.items()}


def sweep_settings() -> tuple[float, int]:
    """The thesis's least-squares sweep (section 5.3.1).

    Returns
    -------
    tuple
        (x_max [m], points).
    """
    s = lts_data()["sweep"]
    return s["x_max"], s["points"]


def analyse(setup: LtsSetup, deltas: Mapping[str, float], x_max: float | None = None,
            points: int | None = None) -> dict:
    """The scale factor of one setup, its eq 5.11 uncertainty and the fit's quality, as a JSON-ready dict.

    Parameters
    ----------
    setup : LtsSetup
    deltas : mapping
        {input: absolute uncertainty}.
    x_max : float, optional
        The sweep's largest displacement [m] (default the thesis's).
    points : int, optional
        The sweep's points (default the thesis's).

    Returns
    -------
    dict
        ``scale_factor_m_per_v``, ``uncertainty_m_per_v`` and ``_pct``, each input's contribution
        [%], the fit's intercept [m], largest residual [m] and R^2, the oil gap [m], the laser angle
        [rad], the sweep, the inputs and their uncertainties.
    """
    validate(setup)
    dx, dp = sweep_settings()
    x_max = dx if x_max is None else x_max
    points = dp if points is None else points
    fit = scale_factor(setup, x_max, points)
    unc, parts = uncertainty(lambda s: scale_factor(s, x_max, points).scale, setup, deltas)
    return {
        "scale_factor_m_per_v": fit.scale,
        "uncertainty_m_per_v": unc,
        "uncertainty_pct": 100.0 * unc / fit.scale,
        "contributions_pct": {k: 100.0 * v / fit.scale for k, v in parts.items()},
        "intercept_m": fit.intercept,
        "max_residual_m": fit.max_residual,
        "r_squared": fit.r_squared,
        "oil_gap_m": oil_gap(setup),
        "laser_angle_rad": laser_angle(setup.c1, setup.c2, setup.standoff),
        "x_max_m": x_max,
        "points": int(points),
        "inputs": {f.name: getattr(setup, f.name) for f in fields(setup)},
        "input_uncertainties": dict(deltas),
    }
