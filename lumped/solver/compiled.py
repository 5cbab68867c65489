"""The reference physics, compiled: numba copies of the very functions the reference path runs.

``_jit_physics`` compiles every function of :data:`physics_modules` (oil, orifice, the valves' shared data and
force terms, valve kinds, pump kinematics, layout, right-hand side, switching, Jacobian) with ``numba.njit``: each
function's own code object, its module globals re-pointed at the compiled siblings. Nothing is written
twice; the fast stepper (``lumped.solver.steppers.RodasStepper``) integrates these.

The copies use numba's ``error_model="numpy"`` (no zero test before each float
division, about 30 % of a right-hand side call): numbers are the same; where the Python
reference would raise ZeroDivisionError the compiled code gets inf or nan, which the
integrator rejects as a failed step.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import types

import numba

from lumped.valves.kind import KINDS


def physics_modules() -> tuple[str, ...]:
    """Modules whose functions are the physics, in dependency order (valve kinds from the registry)."""
    kinds = tuple(sorted({f.__module__ for k in KINDS.values() for f in (k.acceleration, k.accelerations)
                          if f is not None}))
    return ("lumped.fluid.oil", "lumped.fluid.orifice", "lumped.valves.common", "lumped.valves.forces",
            "lumped.valves.kind", *kinds, "lumped.model.pump", "lumped.solver.layout", "lumped.solver.rhs",
            "lumped.solver.switching", "lumped.solver.jacobian")


def _jit_physics(one_dof: bool) -> dict[str, types.ModuleType]:
    """numba-compiled mirrors of the physics modules: name -> module of dispatchers.

    Every function defined in one of the physics modules is wrapped (lazily: only what is
    called is ever compiled) with its globals copied and every reference to a physics
    function or module replaced by its compiled counterpart. ``one_dof``: the flavour for pumps
    whose valves have one DOF each, with ``lumped.solver.layout.ONE_DOF_ONLY`` True in every module that
    reads it, so that numba folds the several-DOF paths away: merely present, their loops and calls cost
    the hot path time (docs/models.md, "Numerical choices").
    """
    mods = {name: importlib.import_module(name) for name in physics_modules()}
    # the symbol numba gives a function is its qualified name and a per-process counter: the flavour and
    # the digest of the sources and kinds keep two different physics from sharing one in a cached solver
    suffix = f"__jit{'1' if one_dof else 'n'}_{source_digest()}"
    mirrors = {name: types.ModuleType(f"{name}__jit{'1' if one_dof else 'n'}") for name in mods}
    jitted: dict[tuple[str, str], object] = {}
    scopes = []
    for name, mod in mods.items():
        scope = dict(mod.__dict__)
        scopes.append(scope)
        for attr, fn in mod.__dict__.items():
            if isinstance(fn, types.FunctionType) and fn.__module__ == name:
                new = types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)
                new.__qualname__ = f"{fn.__qualname__}{suffix}"
                new.__module__ = name
                # the layout's index helpers are a few loads each: inlined where they are called
                kw = {"inline": "always"} if attr in getattr(mod, "INLINE", ()) else {}
                disp = numba.njit(new, error_model="numpy", **kw)
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
    for scope in scopes:
        if "COMPILED" in scope:
            scope["COMPILED"] = True              # a module's loop form for numba, its numpy form in Python
        if one_dof and "ONE_DOF_ONLY" in scope:
            scope["ONE_DOF_ONLY"] = True          # a compile-time constant: the several-DOF paths fold away
    return mirrors


_PHYSICS: dict = {}


def kinds_key() -> tuple:
    """The registered valve kinds (name, id): the compiled physics dispatches on them, so a kind
    registered later (a user's, a test's) gets physics, helpers and a solver of its own."""
    return tuple((k.name, k.id) for k in KINDS.values())


def physics(one_dof: bool = False) -> dict[str, types.ModuleType]:
    """The compiled mirrors of a flavour (built on first use): ``one_dof`` for pumps whose valves have
    one DOF each, else any number."""
    key = (one_dof, kinds_key())
    if key not in _PHYSICS:
        _PHYSICS[key] = _jit_physics(one_dof)
    return _PHYSICS[key]


def function(module: str, name: str, one_dof: bool = False):
    """The compiled copy of ``module.name`` (a numba dispatcher, compiled in this process on first call)."""
    return getattr(physics(one_dof)[module], name)


_CACHED: dict = {}


def cached(module: str, name: str, one_dof: bool = False):
    """The compiled copy of ``module.name`` for calls from Python, cached on disk.

    (Inside the fast stepper the physics is compiled into the solver's own cache entry;
    called from Python each mirror would otherwise compile again in every new process,
    about 20 s for the driver's helpers.) The copy is named by the digest of the physics
    sources, so a change to any of them gets a fresh cache entry.
    """
    key = (module, name, one_dof, kinds_key())
    if key not in _CACHED:
        from lumped.solver.rodas import _rebind

        disp = function(module, name, one_dof)
        tag = f"py{'1' if one_dof else 'n'}_{source_digest('lumped.solver.steppers')}"
        _CACHED[key] = _rebind(disp, disp.py_func.__globals__, tag, cache=True)
    return _CACHED[key]


_DIGESTS: dict = {}


def source_digest(*extra: str) -> str:
    """Hash of every source the compiled solver depends on: a change gets a fresh cache entry."""
    key = (extra, kinds_key())
    if key not in _DIGESTS:
        _DIGESTS[key] = _digest(extra)
    return _DIGESTS[key]


def _digest(extra: tuple) -> str:
    h = hashlib.sha256()
    for name in (*physics_modules(), "lumped.solver.rosenbrock", "lumped.solver.rodas", __name__, *extra):
        h.update(inspect.getsource(importlib.import_module(name)).encode())
    h.update(numba.__version__.encode())
    return h.hexdigest()[:12]
