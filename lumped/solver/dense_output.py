"""Sampling a recorded dense output: the states and modes of an integration at any times inside it.

:func:`lumped.solver.rodas.solve` records every accepted step (its end state, its interpolant's coefficients and
the tag of the mode it ran in); the post-processors sample revolutions from these records at many points, so
the sampling is compiled too.
"""

from __future__ import annotations

import numba
import numpy as np

from lumped.solver.rosenbrock import dense


def interpolate(t, rec_t, rec_y, rec_q2, rec_q3, rec_q4):
    """States at times ``t`` (array, inside the recorded span) from the dense output."""
    return _interpolate(np.asarray(t, dtype=float), rec_t, rec_y, rec_q2, rec_q3, rec_q4)


@numba.njit(cache=True, error_model="numpy")
def sample_modes(t, rec_t, rec_tag, n_mode):
    """The modes (rows, floats) of the recorded steps the times ``t`` fall in, decoded from their tags
    (lumped.solver.layout.mode_tag: base 3, the first mode slot the lowest digit)."""
    # compiled: every revolution is sampled at ENERGY_SAMPLES points (lumped.run.postprocess), where numpy's
    # element-wise integer division would cost a sizeable share of a sweep design (docs/performance.md)
    last = len(rec_t) - 1
    out = np.empty((len(t), n_mode))
    for k in range(len(t)):
        tag = rec_tag[min(max(np.searchsorted(rec_t, t[k]), 1), last)]
        for i in range(n_mode):
            out[k, i] = tag % 3
            tag //= 3
    return out


@numba.njit(cache=True, error_model="numpy")
def _interpolate(t, rec_t, rec_y, rec_q2, rec_q3, rec_q4):
    """States at times t from the recorded steps (see :func:`interpolate`); compiled: every revolution is
    sampled at many points by the post-processors."""
    n, m, last = len(t), rec_y.shape[1], len(rec_t) - 1
    out = np.empty((n, m))
    for k in range(n):
        i = min(max(np.searchsorted(rec_t, t[k]), 1), last)
        s = (t[k] - rec_t[i - 1]) / (rec_t[i] - rec_t[i - 1])
        for j in range(m):
            out[k, j] = dense(s, rec_y[i - 1, j], rec_y[i, j], rec_q2[i, j], rec_q3[i, j], rec_q4[i, j])
    return out
