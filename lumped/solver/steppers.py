"""Steppers behind one interface: the reference (scipy Radau, BDF, LSODA) and the fast (compiled Rodas4P/Rodas5P).

The pump driver (:mod:`lumped.run.simulate`) owns everything around the integration; a stepper
only advances the state over a span of time (a revolution), switching the mode at the
located crossings of the switching functions (:mod:`lumped.solver.switching`, defined once),
and returns a :class:`Span`: the end state and mode, the events, and a dense output from
which the driver samples traces. In the style of scipy's ``OdeSolver``: every stepper is
constructed the same way, ``Stepper(problem, rtol, atol, **options)`` (a
:class:`lumped.solver.problem.PumpProblem`, the relative tolerance and the absolute one in units
of each state's scale), then :meth:`Stepper.advance` is called; :data:`METHODS` maps the
``method`` names of :func:`lumped.run.simulate.simulate` to them.

- :class:`RadauStepper`: scipy's implicit ``OdeSolver`` on the *Python* physics, each mode
  change located on its dense output (the reference; independent of numba);
- :class:`RodasStepper`: the compiled Rodas4P or Rodas5P (:func:`rodas_order`) of :mod:`lumped.solver.rodas` on the compiled
  copies of the same functions (:mod:`lumped.solver.compiled`), events located on its dense
  output, the analytic Jacobian of :mod:`lumped.solver.jacobian`, per-state tolerances.
"""

from __future__ import annotations

import bisect
import math
import sys
import time as _time
from dataclasses import dataclass, field
from functools import cached_property, partial

import numpy as np

from geometry.errors import ModelFailure
from lumped.solver import switching as sw
from lumped.solver.layout import (
    BLOCK_OFFSET, G, MODE_AT, N_MODE, N_SWITCHES, N_TOL, N_VALVES, S_MCYL, TOL_AT, event, mode_of, mode_tag,
    opening, tol_slot, valve_tolerances,
)
from lumped.solver.rhs import evaluate
from lumped.valves.kind import FREE, KINDS, SEAT, STOP, VALVE

#: events per revolution before a run is called chatter
MAX_EVENTS_PER_REV = 20_000


class IntegrationError(ModelFailure):
    """A stepper gave up: the integrator failed, ran out of its step budget, or the valves chatter."""


@dataclass
class Span:
    """What a stepper returns for [t0, t1]: end state and mode, events, dense output.

    ``events``: :class:`lumped.solver.layout.Event` records; ``event_states``: the state just before
    each; ``peaks``: the largest opening of each valve; ``sample(ts)`` -> (states, modes) at
    sorted times in the span. The driver reads events and peaks of the last revolution only, so
    a stepper may hand them over as ``details()`` -> (events, event_states, peaks), computed on
    first access. The fast stepper's ``sampler`` carries ``step_times``, the knots of its dense output.
    """

    t0: float
    t1: float
    y_end: np.ndarray
    mode_end: np.ndarray
    n_events: int
    n_rhs: int
    n_steps: int
    sampler: object = field(repr=False, default=None)
    details: object = field(repr=False, default=None)

    @cached_property
    def _details(self) -> tuple:
        return self.details()

    @property
    def events(self) -> list:
        return self._details[0]

    @property
    def event_states(self) -> list:
        return self._details[1]

    @property
    def peaks(self) -> tuple:
        return self._details[2]

    def sample(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.sampler(np.asarray(ts, dtype=float))


class Stepper:
    """Interface: ``Stepper(problem, rtol, atol, **options)``; ``advance(t0, t1, y, mode) -> Span``.

    ``problem.p`` (the packed parameters) may be changed by the driver between spans.
    """

    name = "abstract"

    def __init__(self, problem, rtol: float, atol: float, **options):  # pragma: no cover - interface
        raise NotImplementedError

    def advance(self, t0: float, t1: float, y: np.ndarray, mode: np.ndarray) -> Span:  # pragma: no cover
        """Integrate from t0 to t1 [s] from state y in mode ``mode``, locating every switch on the way."""
        raise NotImplementedError


# --------------------------------------------------------------------------- reference: scipy
class RadauStepper(Stepper):
    """scipy's implicit ``OdeSolver`` (Radau, or BDF/LSODA) stepped here, on the Python physics; after each
    step the switching functions of :mod:`lumped.solver.switching` are checked and a crossing is located on the
    step's dense output (Brent's method), where the mode changes and the solver restarts."""

    name = "reference"

    def __init__(self, problem, rtol: float, atol: float, *, method: str = "Radau", max_steps: int | None = None,
                 **_ignored):
        self.problem = problem
        self.rtol = rtol
        self.scale = problem.scales
        self.atol = atol * self.scale
        self.n_dyn = problem.n_dyn
        self.n = problem.layout.n_states
        self.method = method
        self.max_steps = max_steps or 500_000
        # scalar valves only: Python lists index fastest; a valve of many DOFs is moved by numpy arrays
        self.scalar = problem.layout.one_dof

    def _rhs(self, t, y, mode):
        out = np.empty(self.n)
        evaluate(t, y.tolist() if self.scalar else y, self.plist, mode, out)
        return out

    def _jac(self, t, y, mode):
        """Forward differences over the dynamic states; the running totals (quadratures) feed back into
        nothing, so their columns are zero and cost no evaluations."""
        f0 = self._rhs(t, y, mode)
        jm = np.zeros((self.n, self.n))
        eps = math.sqrt(np.finfo(float).eps)
        for j in range(self.n_dyn):
            h = eps * max(abs(y[j]), self.scale[j])
            yy = y.copy()
            yy[j] += h
            h = yy[j] - y[j]
            jm[:, j] = (self._rhs(t, yy, mode) - f0) / h
        return jm

    def _g(self, t, y, mode) -> np.ndarray:
        g = np.empty(N_SWITCHES + self.n)          # switching functions, then scratch
        sw.switch_values(t, y, self.plist, mode, g)
        return g

    def _peaks(self, peaks, y) -> None:
        for v, o in enumerate(BLOCK_OFFSET):
            peaks[v] = max(peaks[v], float(opening(y, self.plist, o)[0]))

    def advance(self, t0, t1, y, mode):
        from threadpoolctl import threadpool_limits

        # list indexing is the fast path for CPython floats (arrays where a valve has many DOFs)
        self.plist = self.problem.p.tolist() if self.scalar else self.problem.p.copy()
        run = _RadauRun(self, t0, t1, np.array(y, dtype=float), np.array(mode, dtype=float))
        # one BLAS thread: Radau factorises small matrices at every step size change, where threads only add
        # their start-up and, on a shared machine, wait for each other (docs/models.md, "Numerical choices")
        with threadpool_limits(limits=1, user_api="blas"):
            while run.t < t1:
                run.segment()
        n = self.n
        pieces = run.pieces

        def sampler(ts):
            starts = [pc[0] for pc in pieces]
            ys = np.empty((len(ts), n))
            modes = np.empty((len(ts), N_MODE))
            for i, tt in enumerate(ts):
                pc = pieces[max(0, bisect.bisect_right(starts, tt) - 1)]
                ys[i] = pc[2](min(max(tt, pc[0]), pc[1]))
                modes[i] = pc[3]
            return ys, modes

        details = (run.events, run.states, tuple(run.peaks))
        return Span(t0, t1, run.y, run.mode, len(run.events), run.nfev, run.steps, sampler, lambda: details)


class _RadauRun:
    """One span of :class:`RadauStepper`: segments of constant mode, each integrated by a fresh scipy
    solver until a switching function crosses zero (located on the step's dense output by Brent's
    method), where the mode changes."""

    def __init__(self, stepper: RadauStepper, t0: float, t1: float, y: np.ndarray, mode: np.ndarray):
        self.st, self.t0, self.t1 = stepper, t0, t1
        self.t, self.y, self.mode = t0, y, mode
        self.pieces, self.events, self.states = [], [], []   # pieces: (t_start, t_end, interpolant, mode)
        self.peaks = [0.0] * N_VALVES
        stepper._peaks(self.peaks, y)
        self.nfev = self.steps = 0
        self.h = None

    def switch(self, k: int, te: float, y: np.ndarray) -> None:
        """Mode change k at time te (y is moved onto the surface), logged with the state before it."""
        before = y.copy()
        code = sw.apply_switch(k, y, self.st.plist, self.mode)
        self.events.append(event(te, code))
        self.states.append(before)
        if len(self.events) > MAX_EVENTS_PER_REV:
            raise IntegrationError(f"valve chatter: {len(self.events)} switches near t = {te:.6g} s; "
                                   "loosen the contact model or the tolerances")

    def segment(self) -> None:
        """Integrate from self.t in the current mode to the next switch (or the span's end)."""
        from scipy.integrate import BDF, LSODA, Radau

        st = self.st
        m_now = self.mode.copy()
        self.g_old = st._g(self.t, self.y, m_now)
        first = next((k for k in range(N_SWITCHES) if self.g_old[k] < 0.0), -1)
        if first >= 0:
            # a switching function already below zero where the mode starts (a valve arriving
            # on a contact while the force already pulls it away) switches at once
            self.switch(first, self.t, self.y)
            return
        kw = {} if st.method == "LSODA" else {"jac": lambda tt, yy: st._jac(tt, yy, m_now)}
        solver = {"Radau": Radau, "BDF": BDF, "LSODA": LSODA}[st.method](
            lambda tt, yy: st._rhs(tt, yy, m_now), self.t, self.y, self.t1, rtol=st.rtol, atol=st.atol,
            first_step=self.h, **kw)
        while not self._step(solver, m_now):
            pass
        self.nfev += solver.nfev

    def _step(self, solver, m_now) -> bool:
        """One solver step; True when the segment ends (a located switch, or the span's end)."""
        from scipy.optimize import brentq

        st = self.st
        msg = solver.step()
        self.steps += 1
        if solver.status == "failed":
            raise IntegrationError(f"integrator failed at t = {solver.t:.6g} s: {msg}")
        if self.steps > st.max_steps:
            raise IntegrationError(f"integrator needed more than {st.max_steps} steps (t = {solver.t:.6g} s)")
        t_prev, t_new = solver.t_old, solver.t
        sol = solver.dense_output()
        g_new = st._g(t_new, solver.y, m_now)
        crossing = [k for k in range(N_SWITCHES) if self.g_old[k] >= 0.0 > g_new[k]]
        if not crossing:
            self.pieces.append((t_prev, t_new, sol, m_now))
            st._peaks(self.peaks, solver.y)
            self.g_old = g_new
            if solver.status == "finished":
                self.t, self.y = self.t1, solver.y.copy()
                return True
            return False
        # the first crossing in the step, located on its dense output
        roots = []
        for k in crossing:
            def gk(tt, k=k):
                return st._g(tt, sol(tt), m_now)[k]
            roots.append((brentq(gk, t_prev, t_new, xtol=4 * np.finfo(float).eps * abs(t_new)), k))
        te = min(r for r, _ in roots)
        y = sol(te)
        self.pieces.append((t_prev, te, sol, m_now))
        st._peaks(self.peaks, y)
        for r, k in sorted(roots):
            if r <= te + 4 * np.finfo(float).eps * abs(te):
                self.switch(k, te, y)
        self.h = max(te - t_prev, 1e-12 * (self.t1 - self.t0))
        if te < self.t1:
            self.h = min(self.h, self.t1 - te)       # a crossing near the end: the first step must fit
        self.t, self.y = te, y
        return True


# --------------------------------------------------------------------------- fast: compiled Rodas4P/5P
def _build_rodas(one_dof: bool):
    """The compiled solver bound to the pump's compiled physics of a flavour (lumped.solver.compiled.physics),
    cached on disk by source digest; (solver, digest)."""
    import numba

    from lumped.solver import compiled, rodas

    digest = compiled.source_digest(__name__)
    flavour = f"pump{'1' if one_dof else 'n'}_{digest}"

    def jit(f):
        # numba names a compiled function's symbol by its qualified name and a per-process counter: a
        # solver loaded from the cache and one compiled here may then share a symbol for two different
        # closures (one-DOF and several-DOF), and the loader binds the wrong one (a modal reed then ran
        # one-DOF physics). The flavour and digest make it unique.
        f.__qualname__ = f"{f.__qualname__}__{flavour}"
        return numba.njit(error_model="numpy")(f)

    hooks = _pump_hooks(lambda module, name: compiled.function(module, name, one_dof), jit)
    _drop_stale_cache(digest)
    return rodas.specialize(hooks.pop("rhs"), flavour, **hooks), digest


def _pump_hooks(fn, jit) -> dict:
    """The pump's functions in the form lumped.solver.rodas.specialize takes them, each reading the mode the
    stepper keeps in the flat array (``fn(module, name)``: a compiled physics function; ``jit``: compiles)."""
    evaluate_c = fn("lumped.solver.rhs", "evaluate")
    switch_values = fn("lumped.solver.switching", "switch_values")
    apply_switch = fn("lumped.solver.switching", "apply_switch")
    redo = fn("lumped.solver.switching", "redo_at_crossing")
    jac_c = fn("lumped.solver.jacobian", "pump_jacobian")
    tols = fn("lumped.solver.layout", "valve_tolerances")
    tag = fn("lumped.solver.layout", "mode_tag")
    mode_c = fn("lumped.solver.layout", "mode_of")
    T, M, P = G.stash_t, G.stash_m, G.stash_p

    @jit
    def _rhs(t, y, p, dydt):
        """dy/dt of the pump (lumped.solver.rhs.evaluate) in the mode stored in p; keeps (t, m_cyl, P_cyl)."""
        r = evaluate_c(t, y, p, mode_c(p), dydt)
        p[T] = t
        p[M] = y[S_MCYL]
        p[P] = r.p_cyl

    @jit
    def _events(t, y, p, g):
        switch_values(t, y, p, mode_c(p), g)

    @jit
    def _apply(k, t, y, p):
        return apply_switch(k, y, p, mode_c(p))

    @jit
    def _retry(k, p):
        return redo(k, mode_c(p))

    @jit
    def _jac(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h):
        pc = p[P] if (p[T] == t and p[M] == y[S_MCYL]) else np.nan
        return jac_c(t, y, p, mode_c(p), pc, jac, ft, yp, fp, atol, rtol, n_dyn)

    @jit
    def _tolerances(p, atol):
        tols(p, mode_c(p), atol)

    @jit
    def _tag(p):
        return tag(mode_c(p))

    return {"rhs": _rhs, "events": _events, "apply": _apply, "tagger": _tag, "jac": _jac, "tolerances": _tolerances,
            "retry": _retry}


def _drop_stale_cache(digest: str) -> None:
    """Remove compiled solvers of earlier physics sources from numba's cache (they never load); not
    where NUMBA_CACHE_DIR sends the cache elsewhere (a process of its own, e.g. with a kind of its own)."""
    import os
    from pathlib import Path

    from lumped.solver import compiled

    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    folders = {Path(sys.modules[m].__file__).parent / "__pycache__" for m in ("lumped.solver.rodas", *compiled.physics_modules())}
    for folder in folders:
        for f in folder.glob("*.nb[ic]"):
            if any(t in f.name for t in ("__pump", "__py")) and digest not in f.name:
                try:
                    f.unlink()
                except OSError:  # another process's, or a read-only install: harmless
                    pass


_SOLVER: dict = {}


def compiled_solver(one_dof: bool = True):
    """The compiled solver of a flavour (lumped.solver.compiled.physics: ``one_dof`` for pumps whose valves have
    one DOF each), built (or loaded from numba's cache) on first use, per set of registered kinds; the
    compile time is recorded in ``_SOLVER[key]["seconds"]``."""
    from lumped.solver import compiled

    key = (one_dof, compiled.kinds_key())
    if key not in _SOLVER:
        t0 = _time.perf_counter()
        solver, digest = _build_rodas(one_dof)
        _SOLVER[key] = {"solver": solver, "digest": digest, "seconds": _time.perf_counter() - t0}
    return _SOLVER[key]["solver"]


#: accepted steps per Jacobian (a Rosenbrock method wants a fresh one)
JAC_REUSE = 1
#: free-flight opening tolerance, in units of atol x the stop gap
FREE_POSITION_ATOL = 1.0
#: the fast path steps with Rodas5P instead of Rodas4P (lumped.solver.rodas) where a valve's acceleration reads the
#: flow (a flow force) and rtol is at most this
RODAS5P_FLOW_RTOL = 1e-4


def rodas_order(rtol: float, flow_in_acceleration: bool = False) -> int:
    """The Rosenbrock method of the fast path: 5 (Rodas5P) where a valve's acceleration reads the flow and
    rtol <= RODAS5P_FLOW_RTOL, else 4 (Rodas4P).

    The transient flow force's d(dP)/dt term slaves the valve's velocity to the pressure (eigenvalues to
    -1e6 1/s), and Rodas4P's embedded estimate over-reads its error there: Rodas5P takes fewer steps where the
    tolerance is tight enough for that to matter; at looser tolerances, or without a flow force, it only costs
    more (the measurements: docs/models.md, "Numerical choices").
    """
    return 5 if flow_in_acceleration and rtol <= RODAS5P_FLOW_RTOL * (1.0 + 1e-9) else 4


class RodasStepper(Stepper):
    """The compiled Rodas4P or Rodas5P over a span; per-valve tolerances by contact state (see
    :func:`tolerance_table`).

    Options: ``contact_atol`` (velocity tolerance in contact, in units of atol x 1 m/s; default the
    kinds' own), ``record`` (keep the dense output), ``max_steps`` per span, ``order`` (4 or 5; default
    :func:`rodas_order`: 5 where a valve carries a flow force and rtol <= 1e-4).
    """

    name = "fast"

    def __init__(self, problem, rtol: float, atol: float, *, contact_atol: float | None = None, record: bool = True,
                 max_steps: int | None = None, order: int | None = None, **_ignored):
        self.solver = compiled_solver(problem.layout.one_dof)
        reads_flow = any(problem.p[o + VALVE.flow_in_acceleration] > 0.5 for o in BLOCK_OFFSET)
        self.order = rodas_order(rtol, reads_flow) if order is None else int(order)
        if self.order not in (4, 5):
            raise ValueError(f"order: 4 (Rodas4P) or 5 (Rodas5P), not {order}")
        self.problem = problem
        self.rtol = rtol
        self.atol = atol * problem.scales
        self.n_dyn = problem.n_dyn
        self.record = record
        self.table = tolerance_table(atol, self.atol, problem, contact_atol)
        self.q = problem.p.copy()
        self.h = None
        self.max_steps = max_steps or 2_000_000
        # first step after each kind of mode change (its event code), carried between revolutions
        from lumped.solver.layout import EVENT_CODES

        self.h_event = np.zeros(EVENT_CODES)

    def memory(self) -> dict:
        """The step-size memory carried between revolutions (a warm start hands it to the next run)."""
        return {"h": self.h, "h_event": self.h_event.copy(), "period": self.problem.period}

    def restore(self, memory: dict | None) -> None:
        """Start from another run's step-size memory (scaled by the ratio of the revolutions)."""
        if not memory or memory.get("h") is None or len(memory["h_event"]) != len(self.h_event):
            return
        ratio = self.problem.period / memory["period"]
        self.h = memory["h"] * ratio
        self.h_event[:] = memory["h_event"] * ratio

    def advance(self, t0, t1, y, mode):
        from lumped.solver import rodas

        q = self.q
        q[:] = self.problem.p                 # the driver may have changed p (needle valve tuning)
        q[TOL_AT:TOL_AT + N_TOL] = self.table
        q[MODE_AT:MODE_AT + N_MODE] = mode
        if self.h is None:
            self.h = 1e-4 * (t1 - t0)
        opts = rodas.Options(self.rtol, self.atol.copy(), self.h, t1 - t0, self.max_steps, self.n_dyn,
                             t0 if self.record else np.inf, N_SWITCHES, MAX_EVENTS_PER_REV, JAC_REUSE,
                             self.h_event, self.order)
        r = self.solver(t0, np.asarray(y, dtype=float), np.array([t1]), q, opts)
        if r.status != rodas.OK:
            raise IntegrationError(f"fast integrator failed ({rodas.STATUS_TEXT[int(r.status)]}, "
                                   f"t = {r.rec_t[-1] if len(r.rec_t) else t0:.6g} s)")
        self.h = r.h_next
        rec = (r.rec_t, r.rec_y, r.rec_q2, r.rec_q3, r.rec_q4, r.rec_tag)
        layout, p = self.problem.layout, self.problem.p

        def details():
            events = [event(t, int(c)) for t, c in zip(r.ev_t, r.ev_code)]
            return events, list(r.ev_y), _peaks(layout, p, r.rec_y, r.rec_q2, r.rec_q3, r.rec_q4)

        def sampler(ts):
            rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag = rec
            ys = rodas.interpolate(ts, rec_t, rec_y, rec_q2, rec_q3, rec_q4)
            return ys, rodas.sample_modes(ts, rec_t, rec_tag, N_MODE)

        sampler.step_times = r.rec_t          # the dense output's knots, for a caller that samples at the steps

        y_end = r.y_stops[-1].copy()
        mode_end = mode_of(q).copy()
        return Span(t0, t1, y_end, mode_end, len(r.ev_t), int(r.n_rhs), int(r.n_steps), sampler, details)


_QUARTERS = np.array([[0.25], [0.5], [0.75]])


def _peaks(layout, p, rec_y, rec_q2, rec_q3, rec_q4) -> tuple[float, ...]:
    """Largest opening [m] of each valve in the recorded steps, interpolant included (quarters)."""
    from lumped.solver import rodas

    if len(rec_y) == 0:
        return (0.0,) * N_VALVES
    best = []
    for v in range(N_VALVES):
        x = layout.openings(rec_y, p, v)[0]
        q2 = layout.openings(rec_q2, p, v)[0]
        q3 = layout.openings(rec_q3, p, v)[0]
        q4 = layout.openings(rec_q4, p, v)[0]
        b = float(x.max())
        if len(x) > 1:
            b = max(b, float(rodas.dense.py_func(_QUARTERS, x[:-1], x[1:], q2[1:], q3[1:], q4[1:]).max()))
        best.append(max(b, 0.0))
    return tuple(best)


def tolerance_table(atol: float, atol_v: np.ndarray, problem, contact_atol: float | None = None) -> np.ndarray:
    """atol of (positions, rates) of each valve on its seat, free, on its stop (lumped.solver.layout.tol_slot).

    Free flight: the reference's scales (atol times the stop gap times FREE_POSITION_ATOL;
    the kind's ``free_velocity_atol`` times atol times 1 m/s). In contact the valve sits a
    deflection F/k into its seat or stop, nanometres for a rigid seat, and crosses back out
    of it when the pressure force lets go: the opening or closing time is the time x needs
    to cover that deflection. So x in contact is measured against its own scale, the kind's
    ``contact_position_atol`` times atol times the deflection a load-pressure force would
    cause (P_load A / k; A = the kind's contact area), and u against atol times 1 m/s times
    the kind's ``contact_velocity_atol`` (or ``contact_atol``).
    """
    p, layout = problem.p, problem.layout
    by_id = {float(k.id): k for k in KINDS.values()}
    table = np.empty(N_TOL)
    for v, o in enumerate(BLOCK_OFFSET):
        area = p[o + VALVE.contact_area]
        kind = by_id[p[o + VALVE.kind_id]]
        x_free = atol_v[layout.positions(v).start] * FREE_POSITION_ATOL
        u_scale = atol_v[layout.rates(v).start]
        for c, k in ((SEAT, p[o + VALVE.seat_k]), (FREE, 0.0), (STOP, p[o + VALVE.stop_k])):
            deflection = p[G.load_pressure] * area / k if k > 0.0 else 0.0
            x_tol = x_free if k <= 0.0 else min(x_free, kind.contact_position_atol * atol * deflection)
            in_contact = kind.contact_velocity_atol if contact_atol is None else contact_atol
            u_tol = u_scale * (kind.free_velocity_atol if c == FREE else in_contact)
            i = tol_slot(v, c) - TOL_AT
            table[i] = x_tol
            table[i + 1] = u_tol
    return table


#: method name of :func:`lumped.run.simulate.simulate` -> stepper class (same constructor signature)
METHODS = {
    "fast": RodasStepper,
    "reference": RadauStepper,
    "Radau": partial(RadauStepper, method="Radau"),
    "BDF": partial(RadauStepper, method="BDF"),
    "LSODA": partial(RadauStepper, method="LSODA"),
}
#: default tolerances (rtol, atol in units of each state's scale) of the two stepper families: the fast
#: path's from benchmarks/pump_tolerance_study.py, the reference's from the convergence study (README.md)
DEFAULT_TOLERANCES = {"fast": (1e-3, 1e-5), "reference": (1e-6, 1e-6)}


def family(method: str) -> str:
    """"fast" for the compiled stepper, "reference" for the scipy ones."""
    return "fast" if method == "fast" else "reference"
