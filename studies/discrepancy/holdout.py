"""Fitting and held-out runs: runs grouped by operating condition, every third condition held out."""

from __future__ import annotations

from geometry.errors import InputError
from studies.discrepancy.measured import Run


def conditions(runs: list[Run], speed_tol=0.03, pressure_tol=0.15) -> list[list[Run]]:
    """Group runs by operating condition (speed within 3 %, load pressure within 15 %), sorted."""
    groups: list[list[Run]] = []
    for r in sorted(runs, key=lambda r: (r.speed_rpm, r.load_pressure_pa, r.name)):
        for g in groups:
            g0 = g[0]
            if (abs(r.speed_rpm - g0.speed_rpm) <= speed_tol * g0.speed_rpm
                    and abs(r.load_pressure_pa - g0.load_pressure_pa) <= pressure_tol * g0.load_pressure_pa):
                g.append(r)
                break
        else:
            groups.append([r])
    return groups


def split(runs: list[Run], holdout: tuple | None = None) -> tuple[list[Run], list[Run]]:
    """Fitting and held-out runs: every third operating condition (from the second) is held out.

    ``holdout`` names the held-out runs explicitly. With one condition nothing is held out.
    """
    if holdout:
        names = {r.name for r in runs}
        for h in holdout:
            if h not in names:
                raise InputError("--holdout", f"no run named {h!r} in the dataset (runs: {', '.join(sorted(names))})")
        held = [r for r in runs if r.name in holdout]
        fit = [r for r in runs if r.name not in holdout]
        if not fit:
            raise InputError("--holdout", "every run is held out; leave at least one to fit on")
        return fit, held
    groups = conditions(runs)
    if len(groups) < 2:
        return list(runs), []
    held = [r for i, g in enumerate(groups) if i % 3 == 1 for r in g]
    fit = [r for r in runs if r not in held]
    return fit, held
