"""The multi-fidelity check of a reed: analytic vs beam, plate and solid FEA, side by side.

:func:`multi_fidelity_check` is the stable entry point (``valvelab check`` and the pump
validation call it). It runs each fidelity, expresses omega_n, kappa and gamma1..3 as %
deviations from the reference (the highest fidelity run: solid > plate > beam), flags
every deviation above ``tolerance_pct`` and selects the values that feed the pump model:

- the cheapest Euler-Bernoulli result (analytic, else beam FE) when all its deviations
  from the reference are within tolerance (the lumped model is built on that theory and
  the check has just confirmed it for this reed);
- otherwise the reference itself (the FEA has shown E-B theory is not good enough here).

The default tolerance, 4 %, is the thesis's own statement of the E-B model's accuracy
for reed stiffness (section 3.5.1: "valid for estimating reed stiffness within ~4 %").

With ``modes = N`` each fidelity also gives its first N natural frequencies named by nodal
pattern (``bending 2``, ``torsion 1``, ...); each is compared with the reference's mode of
the same name (``mode_deviation_pct``, null where the reference has no such mode among its
first N, e.g. torsion for the beam). Mode deviations are reported, not flagged: they do not
feed the pump model.
"""

from __future__ import annotations

import sys
import time

from geometry.reed import Reed
from lumped.reed.mode_function import ReedProperties

#: quantities compared, in table order
QUANTITIES = ("omega_n", "kappa", "gamma1", "gamma2", "gamma3")
#: reference preference: the most complete physics first
REFERENCE_ORDER = ("solid", "plate", "beam", "analytic")
#: Euler-Bernoulli fidelities, cheapest first, eligible to feed the pump model
EB_ORDER = ("analytic", "beam")
#: the deviation [%] beyond which a quantity is flagged (section 3.5.1: E-B reed stiffness "within ~4 %")
DEFAULT_TOLERANCE_PCT = 4.0


def _run(fidelity: str, reed: Reed, mesh_size, modes: int = 0):
    """(ReedProperties, (frequencies, labels) or None) of one fidelity."""
    from fea.fidelities import get

    size = None if fidelity == "analytic" else mesh_size
    if not modes:     # through lumped's cache: a design study reuses a front design's FEA in its later stages
        from lumped.reed.fidelities import reed_properties

        return reed_properties(reed, fidelity, mesh_size=size), None
    props, result = get(fidelity).properties_and_modes(reed, modes, mesh_size=size)
    return props, result.first(modes)


def _run_all(reed: Reed, fidelities, mesh_size, progress: bool, modes: int) -> tuple[dict, dict, dict]:
    """Each fidelity's properties, modes and run time (progress on stderr)."""
    results: dict[str, ReedProperties] = {}
    mode_sets: dict[str, tuple] = {}
    seconds: dict[str, float] = {}
    for k, fid in enumerate(fidelities):
        if progress:
            print(f"check {reed.name}: {fid} ({k + 1}/{len(fidelities)})", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        results[fid], mode_sets[fid] = _run(fid, reed, mesh_size, modes)
        seconds[fid] = time.perf_counter() - t0
    return results, mode_sets, seconds


def _mode_deviations(mode_set: tuple, reference_set: tuple) -> dict:
    """A fidelity's frequencies and mode names, and each mode's % deviation from the reference's mode of the
    same name (None where the reference has none)."""
    freqs, kinds = mode_set
    ref_by = {}
    for w, lab in zip(*reference_set):
        ref_by.setdefault(lab, w)
    return {"frequencies": freqs, "mode_kinds": kinds,
            "mode_deviation_pct": {lab: (None if lab not in ref_by else (w - ref_by[lab]) / ref_by[lab] * 100.0)
                                   for w, lab in zip(freqs, kinds)}}


def _row(fid: str, p: ReedProperties, ref: ReedProperties, tolerance_pct: float, seconds: float) -> dict:
    """One fidelity's row: the Table 3.4 values, % deviations from the reference, flags beyond tolerance."""
    dev = {q: (getattr(p, q) - getattr(ref, q)) / getattr(ref, q) * 100.0 for q in QUANTITIES}
    row = {"fidelity": fid}
    row.update({q: float(getattr(p, q)) for q in QUANTITIES})
    row.update({"h_eff": float(p.h_eff), "dofs": p.dofs, "mesh_size": p.mesh_size, "seconds": round(seconds, 3),
                "deviation_pct": dev, "flags": [q for q in QUANTITIES if abs(dev[q]) > tolerance_pct]})
    return row


def _select(rows: list, reference: str, tolerance_pct: float) -> tuple[str, str]:
    """The fidelity that feeds the pump model, and why (see the module docstring)."""
    for fid in EB_ORDER:
        row = next((r for r in rows if r["fidelity"] == fid), None)
        if row is None or fid == reference:
            continue
        if not row["flags"]:
            return fid, (f"{fid} (Euler-Bernoulli) agrees with {reference} within {tolerance_pct:g} % "
                         "on omega_n, kappa and gamma1..3")
        return reference, (f"{fid} deviates from {reference} by more than {tolerance_pct:g} % in "
                           + ", ".join(row["flags"]) + f"; the {reference} values are used")
    return reference, f"{reference} is the reference"


def multi_fidelity_check(reed: Reed, fidelities=("analytic", "beam", "plate", "solid"),
                         tolerance_pct: float = DEFAULT_TOLERANCE_PCT, mesh_size=None,
                         progress: bool = True, modes: int = 0) -> dict:
    """Run several fidelities on a reed and compare them (see the module docstring).

    Parameters
    ----------
    reed : geometry.reed.Reed
        The reed.
    fidelities : sequence of str
        Among ``analytic``, ``beam``, ``plate``, ``solid``.
    tolerance_pct : float
        Deviation [%] from the reference beyond which a quantity is flagged (default 4 %, the
        thesis's accuracy of E-B reed stiffness, section 3.5.1).
    mesh_size : float, optional
        FEA element size [m]; None uses each FEA fidelity's converged default.
    progress : bool
        Progress on stderr.
    modes : int
        With N > 0, each fidelity's first N natural frequencies named by nodal pattern.

    Returns
    -------
    dict
        ``rows`` (one per fidelity: omega_n [rad/s], kappa [Pa/m], gamma1..3, h_eff [m],
        ``dofs``, ``mesh_size``, ``seconds``, ``deviation_pct`` per quantity vs the reference
        and ``flags``), ``reference``, ``tolerance_pct``, ``flagged`` (list of
        "fidelity.quantity") and ``selected``: ``{"fidelity", "reason", "properties":
        ReedProperties}``. With ``modes``, each row's ``frequencies`` [rad/s], ``mode_kinds`` and
        ``mode_deviation_pct``, and a top-level ``modes`` summary ``{"count", "labels"}``.

    References
    ----------
    Knutson (2016), section 3.5.1 and Table 3.4 (the mode-function parameters gamma1..3).
    """
    results, mode_sets, seconds = _run_all(reed, fidelities, mesh_size, progress, modes)
    ran = list(results)
    reference = next((f for f in REFERENCE_ORDER if f in results), ran[0])
    rows = []
    for fid in ran:
        row = _row(fid, results[fid], results[reference], tolerance_pct, seconds[fid])
        if modes:
            row.update(_mode_deviations(mode_sets[fid], mode_sets[reference]))
        rows.append(row)
    flagged = [f"{r['fidelity']}.{q}" for r in rows for q in r["flags"]]
    selected, reason = _select(rows, reference, tolerance_pct)
    out = {
        "geometry": reed.name, "reference": reference, "tolerance_pct": float(tolerance_pct),
        "rows": rows, "flagged": flagged,
        "selected": {"fidelity": selected, "reason": reason, "properties": results[selected]},
    }
    if modes:
        labels = []
        for fid in [reference] + [f for f in ran if f != reference]:
            labels += [lab for lab in mode_sets[fid][1] if lab not in labels]
        out["modes"] = {"count": int(modes), "labels": labels}
    return out


def check_as_json(check: dict) -> dict:
    """The check as plain JSON types.

    Parameters
    ----------
    check : dict
        :func:`multi_fidelity_check`'s result.

    Returns
    -------
    dict
        The selected ReedProperties as its contract object (SI).
    """
    out = {k: v for k, v in check.items() if k != "selected"}
    sel = check["selected"]
    out["selected"] = {
        "fidelity": sel["fidelity"], "reason": sel["reason"],
        "properties": sel["properties"].as_contract(check["geometry"]),
    }
    return out


def render_check(c: dict) -> str:
    """A readable table of a check: values and % deviations from the reference.

    Parameters
    ----------
    c : dict
        :func:`check_as_json`'s result.

    Returns
    -------
    str
        omega_n [rad/s], kappa [MPa/m], gamma1..3, dofs, seconds per fidelity; the modes, the flags and the selection.
    """
    head = f"{'fidelity':<9} {'omega_n':>9} {'kappa':>9} {'gamma1':>7} {'gamma2':>7} {'gamma3':>7} {'dofs':>7} {'s':>6}"
    lines = [f"reed {c['geometry']}: multi-fidelity check (reference {c['reference']}, "
             f"tolerance {c['tolerance_pct']:g} %)", head,
             f"{'':<9} {'rad/s':>9} {'MPa/m':>9}"]
    for r in c["rows"]:
        lines.append(
            f"{r['fidelity']:<9} {r['omega_n']:9.6g} {r['kappa'] / 1e6:9.5g} {r['gamma1']:7.4f} "
            f"{r['gamma2']:7.4f} {r['gamma3']:7.4f} {r['dofs'] if r['dofs'] is not None else '-':>7} "
            f"{r['seconds']:6.1f}")
        d = r["deviation_pct"]
        mark = lambda q: "!" if q in r["flags"] else " "  # noqa: E731
        lines.append(
            f"{'  dev %':<9} {d['omega_n']:+8.2f}{mark('omega_n')} {d['kappa']:+8.2f}{mark('kappa')} "
            f"{d['gamma1']:+6.2f}{mark('gamma1')} {d['gamma2']:+6.2f}{mark('gamma2')} {d['gamma3']:+6.2f}{mark('gamma3')}")
    if c.get("modes"):
        fids = [r["fidelity"] for r in c["rows"]]
        lines.append(f"first {c['modes']['count']} modes [rad/s] (% from {c['reference']}, same nodal pattern):")
        lines.append(f"{'mode':<22}" + "".join(f"{f:>20}" for f in fids))
        for lab in c["modes"]["labels"]:
            cells = []
            for r in c["rows"]:
                k = r["mode_kinds"].index(lab) if lab in r["mode_kinds"] else None
                if k is None:
                    cells.append(f"{'-':>20}")
                    continue
                d = r["mode_deviation_pct"].get(lab)
                cells.append(f"{r['frequencies'][k]:>11.6g}" + (f" ({d:+6.2f})" if d is not None else " " * 9))
            lines.append(f"{lab:<22}" + "".join(cells))
    if c["flagged"]:
        lines.append("FLAGGED (beyond tolerance): " + ", ".join(c["flagged"]))
    else:
        lines.append("no deviation beyond tolerance")
    sel = c["selected"]
    lines.append(f"feeds the pump model: {sel['fidelity']} ({sel['reason']})")
    return "\n".join(lines)
