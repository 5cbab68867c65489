"""What an FE run will cost before it runs: degrees of freedom and peak memory, refused when too large.

Every FE model estimates its DOFs and peak resident memory from the mesh (or, before
meshing, from the geometry) and calls :func:`check_memory`, which raises
:class:`geometry.errors.InputError` naming ``--mesh-size`` with the estimate when it
exceeds :data:`MEMORY_FRACTION` of the memory available now, so the command line exits 2
with one line instead of running out of memory.

The byte models are fits to measured peak RSS of this code (``benchmarks/bench_fea.py``
and the runs recorded in docs/fea.md) with a margin: the sparse LU of the solid (SuperLU,
MMD on A^T + A) dominates and grows like N^1.3 for the plate-like meshes of reeds.
The limit can be lowered with the environment variable ``VALVELAB_MEMORY_LIMIT`` (bytes,
or with a suffix K, M, G), e.g. to test the refusal or to share a machine.
"""

from __future__ import annotations

import os

from geometry.errors import InputError

#: share of the available memory an FE run may plan to use (the rest is left to others)
MEMORY_FRACTION = 0.7
#: the interpreter with numpy, scipy, scikit-fem and gmsh loaded [bytes]
BASE_BYTES = 150e6


def available_memory() -> float:
    """Memory available to a new process now [bytes]: psutil if installed, else /proc/meminfo MemAvailable."""
    try:
        import psutil

        return float(psutil.virtual_memory().available)
    except ImportError:  # pragma: no cover - psutil comes with dask.distributed
        pass
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:  # pragma: no cover
        pass
    return float("inf")  # pragma: no cover - unknown: do not refuse


def _parse_bytes(text: str) -> float:
    text = text.strip().upper().removesuffix("B")
    scale = {"K": 1e3, "M": 1e6, "G": 1e9, "T": 1e12}.get(text[-1:], 1.0)
    return float(text[:-1] if scale != 1.0 else text) * scale


def _limit_and_source() -> tuple[float, str]:
    limit = MEMORY_FRACTION * available_memory()
    source = f"{MEMORY_FRACTION:.0%} of the memory available now"
    env = os.environ.get("VALVELAB_MEMORY_LIMIT")
    if env:
        try:
            cap = _parse_bytes(env)
        except ValueError:
            raise InputError("VALVELAB_MEMORY_LIMIT", f"expected bytes such as 2e9 or 2G, got {env!r}") from None
        if cap < limit:
            limit, source = cap, "VALVELAB_MEMORY_LIMIT"
    return limit, source


def memory_limit() -> float:
    """Bytes an FE run may use: MEMORY_FRACTION of the available memory, or VALVELAB_MEMORY_LIMIT if smaller."""
    return _limit_and_source()[0]


def check_memory(what: str, dofs: float, nbytes: float, field: str = "--mesh-size") -> None:
    """InputError naming ``field`` when ``nbytes`` [bytes] exceeds :func:`memory_limit`; ``what`` names the model."""
    limit, source = _limit_and_source()
    if nbytes > limit:
        raise InputError(field, f"the {what} would have about {dofs:,.0f} DOFs and need about "
                         f"{nbytes / 1e9:.2g} GB, more than the {limit / 1e9:.2g} GB allowed ({source}); "
                         "choose a coarser mesh size")


# -- models ---------------------------------------------------------------------------------
def beam_bytes(dofs: float) -> float:
    """Peak bytes of the Hermite beam (sparse, banded): negligible beside the interpreter."""
    return BASE_BYTES + 4e3 * dofs


def plate_dofs(n_triangles: float) -> float:
    """Argyris DOFs of a triangle mesh: 6 per vertex (~n/2) + 1 per edge (~1.5 n)."""
    return 4.5 * n_triangles


def plate_bytes(dofs: float) -> float:
    """Peak bytes of the Argyris plate: the quadrature basis (21 functions with second derivatives at
    25 points per triangle, ~19 kB per DOF measured) dominates the LU of this 2-D problem."""
    return BASE_BYTES + 21e3 * dofs


def solid_lu_nonzeros(dofs: float) -> float:
    """Nonzeros of the sparse LU of the clamped Q2 solid stiffness (SuperLU, MMD on A^T + A): 100 N^1.22.

    Measured k = nnz / N^1.22 (the exponent of the thesis reeds' refinement, 20k-121k
    DOFs): 39 (10 x 100 mm strip), 47-60 (thesis reeds), 59-100 (square FV16 plate; 100 at
    its default mesh): MMD's fill is erratic, so the model takes the largest.
    """
    return 100.0 * dofs**1.22


def solid_bytes(dofs: float, hexes: float) -> float:
    """Peak bytes of the Q2 solid: basis (~22 kB per hexahedron), K, its clamped copy and its CSC
    form (~250 nonzeros per row, 12 B each), a chunk of element matrices (~120 MB) and the LU
    (15.6 B per nonzero with SuperLU's working arrays). Measured peak RSS / estimate:
    0.98 (FV16, 42k DOFs), 0.72 (FV16, 146k), 0.65 (stepped #2, 121k), 0.54 (10 x 100 mm strip, 95k)."""
    lu = 15.6 * solid_lu_nonzeros(dofs)
    matrices = 3 * 12.0 * 250.0 * dofs
    return BASE_BYTES + 120e6 + 22e3 * hexes + matrices + lu
