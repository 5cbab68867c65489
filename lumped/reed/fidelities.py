"""Reed fidelities: the models that give a reed valve its kappa, gamma1..3 and h_eff.

A fidelity is a function ``f(reed, mesh_size=None) -> ReedProperties``
(:class:`lumped.reed.mode_function.ReedProperties`). ``analytic`` (exact Euler-Bernoulli,
:func:`lumped.reed.euler_bernoulli.reed_properties`) is registered here; the FEA fidelities
``beam``, ``plate`` and ``solid`` belong to the ``fea`` package, which registers them
as entry points (group ``valvelab.reed_fidelities`` in pyproject.toml, loaded on first
use by :mod:`lumped.plugins`), so this layer never imports the one above it.
"""

from __future__ import annotations

import functools

from typing import Callable

from geometry.errors import InputError
from lumped import plugins
from lumped.reed.euler_bernoulli import reed_properties as _analytic

GROUP = "valvelab.reed_fidelities"
#: fidelity name -> reed_properties function; the FEA ones are added from the entry points
FIDELITIES: dict[str, Callable] = {"analytic": _analytic}
#: the order the fidelities are listed in (cheapest first)
ORDER = ("analytic", "beam", "plate", "solid")
_loaded = {"entry_points": False}


def register(name: str, func: Callable) -> None:
    """Add (or replace) a fidelity of the one-mode reed parameters.

    Parameters
    ----------
    name : str
        The fidelity's name (model-file key ``fidelity``).
    func : callable
        ``reed_properties(reed, mesh_size=None) -> ReedProperties``.

    Returns
    -------
    None
    """
    FIDELITIES[name] = func


def _load_plugins() -> None:
    if not _loaded["entry_points"]:
        _loaded["entry_points"] = True
        for name, func in plugins.entry_points(GROUP).items():
            FIDELITIES.setdefault(name, func)


def names() -> list[str]:
    """Every available fidelity, cheapest first.

    Returns
    -------
    list of str
    """
    _load_plugins()
    known = [n for n in ORDER if n in FIDELITIES]
    return known + sorted(n for n in FIDELITIES if n not in ORDER)


def reed_model(fidelity: str, field: str = "--fidelity") -> Callable:
    """The ``reed_properties`` function of a fidelity.

    Parameters
    ----------
    fidelity : str
        Its name; unknown: InputError naming ``field``.
    field : str
        The key or option the fidelity came from.

    Returns
    -------
    callable
        ``reed_properties(reed, mesh_size=None) -> ReedProperties``.
    """
    _load_plugins()
    if not isinstance(fidelity, str) or fidelity not in FIDELITIES:
        raise InputError(field, f"expected one of {', '.join(names())}, got {fidelity!r}")
    return FIDELITIES[fidelity]


def reed_properties(reed, fidelity: str = "analytic", mesh_size=None, field: str = "fidelity"):
    """The one-mode reed parameters of a reed (stiffness, gammas, h_eff, frequency) by a fidelity.

    kappa, gamma1..3, h_eff and omega_n of ``reed`` by ``fidelity`` (a ReedProperties); the reed is checked
    first as a reed file would be (geometry.reed_io.check_reed).

    Parameters
    ----------
    reed : geometry.Reed, str or Path
        The reed, or a preset name (``geometry.PRESETS``) or reed file that ``geometry.load_reed`` reads.
    fidelity : str
        ``analytic`` (exact Euler-Bernoulli) or a registered FEA fidelity (``beam``, ``plate``, ``solid``).
    mesh_size : float, optional
        FE element size [m]; None: the fidelity's default for this reed.

    Returns
    -------
    ReedProperties
        ``kappa`` [Pa/m] (eq 3.40's pressure per tip deflection), ``omega_n`` [rad/s],
        ``gamma1..3`` (eqs 3.62-3.64), ``h_eff`` [m].

    References
    ----------
    Knutson (2016), sections 3.4-3.7; Table 3.13 (the prototype reed).

    Examples
    --------
    >>> from geometry import load_reed
    >>> p = reed_properties(load_reed("uniform"))
    >>> print(f"{p.omega_n:.0f} rad/s")      # Table 3.3: exact E-B 3046 rad/s
    3046 rad/s
    """
    import os

    from geometry import validate
    from geometry.reed import Reed
    from geometry.reed_io import check_reed, load_reed

    if isinstance(reed, (str, os.PathLike)):
        reed = load_reed(reed)
    if not isinstance(reed, Reed):
        raise InputError("reed", f"expected a geometry.Reed, a preset name or a reed TOML file, got {reed!r}")
    if mesh_size is not None:
        mesh_size = validate.number(mesh_size, "mesh_size", unit="m", positive=True)
    model = reed_model(fidelity, field)
    reed = check_reed(reed)
    try:
        return _cached(model, fidelity, reed, mesh_size)
    except TypeError:            # an unhashable reed (a plug-in's): computed afresh
        return model(reed, mesh_size=mesh_size)


#: environment variable naming a folder where FEA reed properties are kept between processes (a design study
#: sets it for its workers: the solid FEA of a front design is then run once, not in each stage and worker)
CACHE_ENV = "VALVELAB_REED_CACHE"


@functools.lru_cache(maxsize=64)
def _cached(model, fidelity, reed, mesh_size):
    # a design study builds the same reed for both valves and every operating point: its properties are a
    # pure function of the (frozen) geometry, the fidelity and the mesh size
    import os

    folder = os.environ.get(CACHE_ENV)
    if not folder or fidelity == "analytic":
        return model(reed, mesh_size=mesh_size)
    import hashlib
    import pickle
    from pathlib import Path

    path = Path(folder) / (hashlib.sha256(repr((fidelity, reed, mesh_size)).encode()).hexdigest()[:32] + ".pkl")
    try:
        return pickle.loads(path.read_bytes())
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError):
        pass
    props = model(reed, mesh_size=mesh_size)
    try:                         # written whole or not at all (another process may read it meanwhile)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_bytes(pickle.dumps(props))
        os.replace(tmp, path)
    except OSError:
        pass
    return props
