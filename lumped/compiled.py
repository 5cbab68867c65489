"""The reference physics, compiled: numba copies of the very functions the reference path runs.

:func:`_jit_physics` compiles every function of :data:`physics_modules` (oil, orifice,
valve kinds, pump, switching, Jacobian) with ``numba.njit``: each function's own code
object, its module globals re-pointed at the compiled siblings. Nothing is written
twice; the fast stepper (``lumped.steppers.RodasStepper``) integrates these.

The copies use numba's ``error_model="numpy"`` (no zero test before each float
division, about 30 % of a right-hand side call): numbers are the same; where the Python
reference would raise ZeroDivisionError the compiled code gets inf or nan, which the
integrator rejects as a failed step.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import sys
import types

import numba

from lumped.valve import KINDS


def physics_modules() -> tuple[str, ...]:
    """Modules whose functions are the physics, in dependency order (valve kinds from the registry)."""
    kinds = tuple(sorted({k.acceleration.__module__ for k in KINDS.values()}))
    return ("lumped.oil", "lumped.orifice", "lumped.valve", *kinds, "lumped.pump", "lumped.switching",
            "lumped.jacobian")


def _jit_physics() -> dict[str, types.ModuleType]:
    """numba-compiled mirrors of the physics modules: name -> module of dispatchers.

    Every function defined in one of the physics modules is wrapped (lazily: only what is
    called is ever compiled) with its globals copied and every reference to a physics
    function or module replaced by its compiled counterpart.
    """
    mods = {name: importlib.import_module(name) for name in physics_modules()}
    mirrors = {name: types.ModuleType(f"{name}__jit") for name in mods}
    jitted: dict[tuple[str, str], object] = {}
    scopes = []
    for name, mod in mods.items():
        scope = dict(mod.__dict__)
        scopes.append(scope)
        for attr, fn in mod.__dict__.items():
            if isinstance(fn, types.FunctionType) and fn.__module__ == name:
                new = types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)
                new.__qualname__ = f"{fn.__qualname__}__jit"
                new.__module__ = name
                disp = numba.njit(new, error_model="numpy")
                jitted[(name, attr)] = disp
                setattr(mirrors[name], attr, disp)
    for scope in scopes:
        for attr, v in list(scope.items()):
            if isinstance(v, types.FunctionType) and (v.__module__, v.__name__) in jitted:
                scope[attr] = jitted[(v.__module__, v.__name__)]
            elif isinstance(v, types.FunctionType) and (v.__module__, attr) in jitted:
                scope[attr] = jitted[(v.__module__, attr)]      # a kind's function bound under another name
            elif isinstance(v, types.ModuleType) and v.__name__ in mirrors:
                scope[attr] = mirrors[v.__name__]
    return mirrors


PHYSICS = _jit_physics()


def function(module: str, name: str):
    """The compiled copy of ``module.name`` (a numba dispatcher, compiled in this process on first call)."""
    return getattr(PHYSICS[module], name)


_CACHED: dict = {}


def cached(module: str, name: str):
    """The compiled copy of ``module.name`` for calls from Python, cached on disk.

    (Inside the fast stepper the physics is compiled into the solver's own cache entry;
    called from Python each mirror would otherwise compile again in every new process,
    about 20 s for the driver's helpers.) The copy is named by the digest of the physics
    sources, so a change to any of them gets a fresh cache entry.
    """
    key = (module, name)
    if key not in _CACHED:
        from lumped.rodas import _rebind

        disp = function(module, name)
        _CACHED[key] = _rebind(disp, disp.py_func.__globals__, f"py_{source_digest('lumped.steppers')}", cache=True)
    return _CACHED[key]


def source_digest(*extra: str) -> str:
    """Hash of every source the compiled solver depends on: a change gets a fresh cache entry."""
    h = hashlib.sha256()
    for name in (*physics_modules(), "lumped.rodas", __name__, *extra):
        h.update(inspect.getsource(sys.modules[name]).encode())
    h.update(numba.__version__.encode())
    return h.hexdigest()[:12]
