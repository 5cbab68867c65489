"""Two steppers behind one small interface: the reference (scipy Radau) and the fast (compiled Rodas4P).

The pump driver (:mod:`lumped.cycle`) owns everything around the integration; a stepper
only advances the state over a span of time (a revolution), switching the mode at the
located crossings of the switching functions (:mod:`lumped.switching`, defined once),
and returns a :class:`Span`: the end state and mode, the events, and a dense output from
which the driver samples traces. In the style of scipy's ``OdeSolver``: construct it
for a problem (packed parameters, tolerances), then call :meth:`Stepper.advance`.

- :class:`RadauStepper`: scipy's ``solve_ivp`` (Radau, or BDF/LSODA) on the *Python*
  physics, each mode change a terminal event built from ``switch_values`` (the
  reference; independent of numba);
- :class:`RodasStepper`: the compiled Rodas4P of :mod:`lumped.rodas` on the compiled
  copies of the same functions (:mod:`lumped.compiled`), events located on its dense
  output, the analytic Jacobian of :mod:`lumped.jacobian`, per-state tolerances.
"""

from __future__ import annotations

import bisect
import math
import sys
import time as _time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from geometry.errors import ModelFailure
from lumped import switching as sw
from lumped.pump import (
    G, N_MODE, N_STATES, NP, OFF_DEL, OFF_IN, QUADRATURES, S_MLOAD, S_UDEL, S_UIN, S_XDEL, S_XIN, evaluate,
    rates_to_derivative,
)
from lumped.valve import FREE, SEAT, STOP, VALVE, KINDS

#: events per revolution before a run is called chatter
MAX_EVENTS_PER_REV = 20_000


class IntegrationError(ModelFailure):
    """A stepper gave up: the integrator failed, ran out of its step budget, or the valves chatter."""


@dataclass
class Span:
    """What a stepper returns for [t0, t1]: end state and mode, events, dense output.

    ``events``: (t, slot, old, new) per mode change (slot as in lumped.pump's mode); ``event_states``:
    the state just before each; ``peaks``: the largest opening of each valve; ``sample(ts)`` ->
    (states, modes) at sorted times in the span. The driver reads events and peaks of the last
    revolution only, so a stepper may hand them over as ``details()`` -> (events, event_states,
    peaks), computed on first access.
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
    """Interface: ``advance(t0, t1, y, mode) -> Span``; ``p`` the packed parameters (may be changed between spans)."""

    name = "abstract"
    p: np.ndarray

    def advance(self, t0: float, t1: float, y: np.ndarray, mode: np.ndarray) -> Span:  # pragma: no cover
        raise NotImplementedError


def state_scales(p: np.ndarray, m_rev: float) -> np.ndarray:
    """Characteristic scale of each state: stop gap, 1 m/s, mass pumped per revolution."""
    sc = np.ones(N_STATES)
    sc[0] = m_rev
    sc[S_XIN] = p[OFF_IN + VALVE.stop_gap]
    sc[S_XDEL] = p[OFF_DEL + VALVE.stop_gap]
    sc[S_UIN] = sc[S_UDEL] = 1.0
    sc[S_MLOAD] = m_rev
    for q in QUADRATURES:
        sc[q] = m_rev
    return sc


# --------------------------------------------------------------------------- reference: scipy
class RadauStepper(Stepper):
    """scipy's implicit ``OdeSolver`` (Radau, or BDF/LSODA) stepped here, on the Python physics; after each
    step the switching functions of :mod:`lumped.switching` are checked and a crossing is located on the
    step's dense output (Brent's method), where the mode changes and the solver restarts."""

    name = "reference"

    def __init__(self, p: np.ndarray, rtol: float, atol: np.ndarray, n_dyn: int, scales: np.ndarray,
                 method: str = "Radau", max_steps: int = 500_000):
        self.p = p
        self.rtol = rtol
        self.atol = atol
        self.n_dyn = n_dyn
        self.method = method
        self.scale = scales
        self.max_steps = max_steps

    def _rhs(self, t, y, mode):
        out = np.empty(N_STATES)
        rates_to_derivative(evaluate(t, y.tolist(), self.plist, mode), out)
        return out

    def _jac(self, t, y, mode):
        """Forward differences over the dynamic states; the running totals (quadratures) feed back into
        nothing, so their columns are zero and cost no evaluations."""
        f0 = self._rhs(t, y, mode)
        jm = np.zeros((N_STATES, N_STATES))
        eps = math.sqrt(np.finfo(float).eps)
        for j in range(self.n_dyn):
            h = eps * max(abs(y[j]), self.scale[j])
            yy = y.copy()
            yy[j] += h
            h = yy[j] - y[j]
            jm[:, j] = (self._rhs(t, yy, mode) - f0) / h
        return jm

    def _g(self, t, y, mode) -> np.ndarray:
        g = np.empty(sw.N_SWITCHES)
        sw.switch_values(t, y, self.plist, mode, g)
        return g

    def advance(self, t0, t1, y, mode):
        from scipy.integrate import BDF, LSODA, Radau
        from scipy.optimize import brentq

        solver_class = {"Radau": Radau, "BDF": BDF, "LSODA": LSODA}[self.method]
        self.plist = self.p.tolist()          # list indexing is the fast path for CPython floats
        t = t0
        y = np.array(y, dtype=float)
        mode = np.array(mode, dtype=float)
        pieces, events, states = [], [], []   # pieces: (t_start, t_end, interpolant, mode)
        peaks = [max(y[S_XIN], 0.0), max(y[S_XDEL], 0.0)]
        nfev = steps = 0
        h = None

        def switch(k, te, y):
            """Mode change k at time te (y is moved onto the surface), logged with the state before it."""
            before = y.copy()
            code = sw.apply_switch(k, y, self.plist, mode)
            events.append((te,) + sw.decode(code))
            states.append(before)

        def chatter(te):
            if len(events) > MAX_EVENTS_PER_REV:
                raise IntegrationError(f"valve chatter: {len(events)} switches near t = {te:.6g} s; "
                                       "loosen the contact model or the tolerances")

        while t < t1:
            m_now = mode.copy()
            g_old = self._g(t, y, m_now)
            first = next((k for k in range(sw.N_SWITCHES) if g_old[k] < 0.0), -1)
            if first >= 0:
                # a switching function already below zero where the mode starts (a valve arriving
                # on a contact while the force already pulls it away) switches at once
                switch(first, t, y)
                chatter(t)
                continue
            kw = {} if self.method == "LSODA" else {"jac": lambda tt, yy: self._jac(tt, yy, m_now)}
            solver = solver_class(lambda tt, yy: self._rhs(tt, yy, m_now), t, y, t1, rtol=self.rtol,
                                  atol=self.atol, first_step=h, **kw)
            while True:
                msg = solver.step()
                steps += 1
                if solver.status == "failed":
                    raise IntegrationError(f"integrator failed at t = {solver.t:.6g} s: {msg}")
                if steps > self.max_steps:
                    raise IntegrationError(f"integrator needed more than {self.max_steps} steps "
                                       f"(t = {solver.t:.6g} s)")
                t_prev, t_new = solver.t_old, solver.t
                sol = solver.dense_output()
                g_new = self._g(t_new, solver.y, m_now)
                crossing = [k for k in range(sw.N_SWITCHES) if g_old[k] >= 0.0 > g_new[k]]
                if not crossing:
                    pieces.append((t_prev, t_new, sol, m_now))
                    peaks[0] = max(peaks[0], float(solver.y[S_XIN]))
                    peaks[1] = max(peaks[1], float(solver.y[S_XDEL]))
                    g_old = g_new
                    if solver.status == "finished":
                        t, y = t1, solver.y.copy()
                        break
                    continue
                # the first crossing in the step, located on its dense output
                roots = []
                for k in crossing:
                    def gk(tt, k=k):
                        return self._g(tt, sol(tt), m_now)[k]
                    roots.append((brentq(gk, t_prev, t_new, xtol=4 * np.finfo(float).eps * abs(t_new)), k))
                te = min(r for r, _ in roots)
                y = sol(te)
                pieces.append((t_prev, te, sol, m_now))
                peaks[0] = max(peaks[0], float(y[S_XIN]))
                peaks[1] = max(peaks[1], float(y[S_XDEL]))
                for r, k in sorted(roots):
                    if r <= te + 4 * np.finfo(float).eps * abs(te):
                        switch(k, te, y)
                chatter(te)
                h = max(te - t_prev, 1e-12 * (t1 - t0))
                if te < t1:
                    h = min(h, t1 - te)       # a crossing near the end: the first step must fit
                t = te
                break
            nfev += solver.nfev

        def sampler(ts):
            starts = [pc[0] for pc in pieces]
            ys = np.empty((len(ts), N_STATES))
            modes = np.empty((len(ts), N_MODE))
            for i, tt in enumerate(ts):
                pc = pieces[max(0, bisect.bisect_right(starts, tt) - 1)]
                ys[i] = pc[2](min(max(tt, pc[0]), pc[1]))
                modes[i] = pc[3]
            return ys, modes

        details = (events, states, tuple(peaks))
        return Span(t0, t1, y, mode, len(events), nfev, steps, sampler, lambda: details)


# --------------------------------------------------------------------------- fast: compiled Rodas4P
def _build_rodas():
    """The compiled solver bound to the pump's compiled physics (cached on disk by source digest)."""
    import numba

    from lumped import compiled, rodas

    evaluate_c = compiled.function("lumped.pump", "evaluate")
    to_deriv = compiled.function("lumped.pump", "rates_to_derivative")
    switch_values = compiled.function("lumped.switching", "switch_values")
    apply_switch = compiled.function("lumped.switching", "apply_switch")
    redo = compiled.function("lumped.switching", "redo_at_crossing")
    jac_c = compiled.function("lumped.jacobian", "pump_jacobian")
    MODE, TOL, STASH = NP_EXT_MODE, NP_EXT_TOL, NP_EXT_STASH

    @numba.njit(error_model="numpy")
    def _rhs(t, y, p, dydt):
        """dy/dt of the pump (lumped.pump.evaluate) in the mode stored in p; keeps (t, m_cyl, P_cyl)."""
        r = evaluate_c(t, y, p, p[MODE:MODE + N_MODE])
        p[STASH] = t
        p[STASH + 1] = y[0]
        p[STASH + 2] = r.p_cyl
        to_deriv(r, dydt)

    @numba.njit(error_model="numpy")
    def _events(t, y, p, g):
        switch_values(t, y, p, p[MODE:MODE + N_MODE], g)

    @numba.njit(error_model="numpy")
    def _apply(k, t, y, p):
        return apply_switch(k, y, p, p[MODE:MODE + N_MODE])

    @numba.njit(error_model="numpy")
    def _retry(k, p):
        return redo(k, p[MODE:MODE + N_MODE])

    @numba.njit(error_model="numpy")
    def _jac(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h):
        pc = p[STASH + 2] if (p[STASH] == t and p[STASH + 1] == y[0]) else np.nan
        return jac_c(t, y, p, p[MODE:MODE + N_MODE], pc, jac, ft, yp, fp, atol, rtol, n_dyn)

    @numba.njit(error_model="numpy")
    def _tolerances(p, atol):
        for v in range(2):
            c = int(p[MODE + 2 * v])
            atol[1 + 2 * v] = p[TOL + 2 * (3 * v + c)]
            atol[2 + 2 * v] = p[TOL + 2 * (3 * v + c) + 1]

    @numba.njit(error_model="numpy")
    def _tag(p):
        t = 0
        for i in range(N_MODE):
            t = t * 3 + int(p[MODE + N_MODE - 1 - i])
        return t

    digest = compiled.source_digest(__name__)
    _drop_stale_cache(digest)
    solver = rodas.specialize(_rhs, f"pump_{digest}", events=_events, apply=_apply, tagger=_tag, jac=_jac,
                              tolerances=_tolerances, retry=_retry)
    return solver, digest


def _drop_stale_cache(digest: str) -> None:
    """Remove compiled solvers of earlier physics sources from numba's cache (they never load)."""
    from pathlib import Path

    from lumped import compiled

    folders = {Path(sys.modules[m].__file__).parent / "__pycache__" for m in ("lumped.rodas", *compiled.physics_modules())}
    for folder in folders:
        for f in folder.glob("*.nb[ic]"):
            if ("__pump_" in f.name or "__py_" in f.name) and digest not in f.name:
                try:
                    f.unlink()
                except OSError:  # another process's, or a read-only install: harmless
                    pass


# extended parameter array of the compiled stepper: the packed parameters, then the mode, the
# valve tolerance table (atol of (x, u) of each valve on its seat, free, on its stop) and a stash
# of (t, m_cyl, P_cyl) of the last rhs call, so the Jacobian right after needs no pressure inversion
NP_EXT_MODE = NP
NP_EXT_TOL = NP + N_MODE
NP_EXT_STASH = NP_EXT_TOL + 12
NP_EXT = NP_EXT_STASH + 3
_SOLVER: dict = {}


def compiled_solver():
    """(solver, digest), compiled (or loaded from numba's cache) on first use; the compile time is
    recorded in :data:`COMPILE_SECONDS`."""
    if "solver" not in _SOLVER:
        t0 = _time.perf_counter()
        _SOLVER["solver"], _SOLVER["digest"] = _build_rodas()
        _SOLVER["warm"] = False
        _SOLVER["seconds"] = _time.perf_counter() - t0
    return _SOLVER["solver"]


#: accepted steps per Jacobian (a Rosenbrock method wants a fresh one)
JAC_REUSE = 1
#: free-flight opening tolerance, in units of atol x the stop gap
FREE_POSITION_ATOL = 1.0


class RodasStepper(Stepper):
    """The compiled Rodas4P over a span; per-valve tolerances by contact state (see :func:`tolerance_table`)."""

    name = "fast"

    def __init__(self, p: np.ndarray, rtol: float, atol: np.ndarray, n_dyn: int, atol_scalar: float,
                 contact_atol: float | None = None, record: bool = True, max_steps: int = 2_000_000):
        self.solver = compiled_solver()
        self.p = p
        self.rtol = rtol
        self.atol = atol
        self.n_dyn = n_dyn
        self.record = record
        self.q = np.zeros(NP_EXT)
        self.q[:NP] = p
        self.q[NP_EXT_TOL:NP_EXT_TOL + 12] = tolerance_table(atol_scalar, atol, p, contact_atol)
        self.h = None
        self.max_steps = max_steps
        # first step after each kind of mode change (apply_switch code), carried between revolutions
        self.h_event = np.zeros(N_MODE * 100)

    def advance(self, t0, t1, y, mode):
        from lumped import rodas

        q = self.q
        q[:NP] = self.p                       # the driver may have changed p (needle valve tuning)
        q[NP_EXT_MODE:NP_EXT_MODE + N_MODE] = mode
        if self.h is None:
            self.h = 1e-4 * (t1 - t0)
        opts = rodas.Options(self.rtol, self.atol.copy(), self.h, t1 - t0, self.max_steps, self.n_dyn,
                             t0 if self.record else np.inf, sw.N_SWITCHES, MAX_EVENTS_PER_REV, JAC_REUSE,
                             self.h_event)
        r = self.solver(t0, np.asarray(y, dtype=float), np.array([t1]), q, opts)
        if r.status != rodas.OK:
            raise IntegrationError(f"fast integrator failed ({rodas.STATUS_TEXT[int(r.status)]}, "
                               f"t = {r.rec_t[-1] if len(r.rec_t) else t0:.6g} s)")
        self.h = r.h_next
        rec = (r.rec_t, r.rec_y, r.rec_q2, r.rec_q3, r.rec_tag)

        def details():
            events = [(float(t),) + sw.decode(int(c)) for t, c in zip(r.ev_t, r.ev_code)]
            return events, list(r.ev_y), _peaks(r.rec_y, r.rec_q2, r.rec_q3)

        def sampler(ts):
            rec_t, rec_y, rec_q2, rec_q3, rec_tag = rec
            ys = rodas.interpolate(ts, rec_t, rec_y, rec_q2, rec_q3)
            i = np.clip(np.searchsorted(rec_t, ts, side="left"), 1, len(rec_t) - 1)
            tags = rec_tag[i]
            modes = np.empty((len(ts), N_MODE))
            for j in range(N_MODE):
                modes[:, j] = (tags // 3**j) % 3
            return ys, modes

        y_end = r.y_stops[-1].copy()
        mode_end = q[NP_EXT_MODE:NP_EXT_MODE + N_MODE].copy()
        return Span(t0, t1, y_end, mode_end, len(r.ev_t), int(r.n_rhs), int(r.n_steps), sampler, details)


def _peaks(rec_y, rec_q2, rec_q3) -> tuple[float, float]:
    """Largest inlet and delivery openings [m] in the recorded steps, interpolant included (quarters)."""
    if len(rec_y) == 0:
        return 0.0, 0.0
    best = []
    for xi in (S_XIN, S_XDEL):
        b = float(rec_y[:, xi].max())
        y0, y1, q2, q3 = rec_y[:-1, xi], rec_y[1:, xi], rec_q2[1:, xi], rec_q3[1:, xi]
        for s in (0.25, 0.5, 0.75):
            v = y0 * (1 - s) + s * (y1 + (1 - s) * (q2 + s * q3))
            if len(v):
                b = max(b, float(v.max()))
        best.append(max(b, 0.0))
    return best[0], best[1]


def tolerance_table(atol: float, atol_v: np.ndarray, p: np.ndarray, contact_atol: float | None = None) -> np.ndarray:
    """atol of (x, u) of each valve on its seat, free, on its stop (the order of the stepper's table).

    Free flight: the reference's scales (atol times the stop gap times FREE_POSITION_ATOL;
    the kind's ``free_velocity_atol`` times atol times 1 m/s). In contact the valve sits a
    deflection F/k into its seat or stop, nanometres for a rigid seat, and crosses back out
    of it when the pressure force lets go: the opening or closing time is the time x needs
    to cover that deflection. So x in contact is measured against its own scale, the kind's
    ``contact_position_atol`` times atol times the deflection a load-pressure force would
    cause (P_load A / k; A = the kind's contact area), and u against atol times 1 m/s times
    the kind's ``contact_velocity_atol`` (or ``contact_atol``).
    """
    by_id = {float(k.id): k for k in KINDS.values()}
    table = np.empty(12)
    for v, (o, xi) in enumerate(((OFF_IN, S_XIN), (OFF_DEL, S_XDEL))):
        area = p[o + VALVE.contact_area]
        kind = by_id[p[o + VALVE.kind_id]]
        for c, k in ((SEAT, p[o + VALVE.seat_k]), (FREE, 0.0), (STOP, p[o + VALVE.stop_k])):
            x_free = atol_v[xi] * FREE_POSITION_ATOL
            deflection = p[G.load_pressure] * area / k if k > 0.0 else 0.0
            x_tol = x_free if k <= 0.0 else min(x_free, kind.contact_position_atol * atol * deflection)
            in_contact = kind.contact_velocity_atol if contact_atol is None else contact_atol
            u_tol = atol_v[xi + 1] * (kind.free_velocity_atol if c == FREE else in_contact)
            table[2 * (3 * v + c)] = x_tol
            table[2 * (3 * v + c) + 1] = u_tol
    return table
