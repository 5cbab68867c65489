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


def multi_fidelity_check(reed: Reed, fidelities=("analytic", "beam", "plate", "solid"),
                         tolerance_pct: float = DEFAULT_TOLERANCE_PCT, mesh_size=None,
                         progress: bool = True, modes: int = 0) -> dict:
    """Run ``fidelities`` on ``reed`` and compare them (see the module docstring).

    Returns a dict with ``rows`` (one per fidelity: the Table 3.4 values, ``dofs``,
    ``mesh_size``, ``seconds``, ``deviation_pct`` per quantity vs the reference and
    ``flags``), ``reference``, ``tolerance_pct``, ``flagged`` (list of "fidelity.quantity")
    and ``selected``: ``{"fidelity", "reason",
    "properties": ReedProperties}``. ``mesh_size`` None uses each FEA fidelity's converged
    default. Progress goes to stderr. ``modes`` > 0 adds each row's ``frequencies`` [rad/s],
    ``mode_kinds`` and ``mode_deviation_pct`` (see the module docstring) and a top-level
    ``modes`` summary ``{"count", "labels"}``.
    """
    results: dict[str, ReedProperties] = {}
    mode_sets: dict[str, tuple] = {}
    seconds: dict[str, float] = {}
    for k, fid in enumerate(fidelities):
        if progress:
            print(f"check {reed.name}: {fid} ({k + 1}/{len(fidelities)})", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        results[fid], mode_sets[fid] = _run(fid, reed, mesh_size, modes)
        seconds[fid] = time.perf_counter() - t0
    ran = list(results)
    reference = next((f for f in REFERENCE_ORDER if f in results), ran[0])
    ref = results[reference]
    rows, flagged = [], []
    for fid in ran:
        p = results[fid]
        dev = {q: (getattr(p, q) - getattr(ref, q)) / getattr(ref, q) * 100.0 for q in QUANTITIES}
        flags = [q for q in QUANTITIES if abs(dev[q]) > tolerance_pct]
        flagged += [f"{fid}.{q}" for q in flags]
        row = {"fidelity": fid}
        row.update({q: float(getattr(p, q)) for q in QUANTITIES})
        row.update({
            "h_eff": float(p.h_eff), "dofs": p.dofs, "mesh_size": p.mesh_size,
            "seconds": round(seconds[fid], 3), "deviation_pct": dev, "flags": flags,
        })
        if modes:
            freqs, kinds = mode_sets[fid]
            ref_f, ref_k = mode_sets[reference]
            ref_by = {}
            for w, lab in zip(ref_f, ref_k):
                ref_by.setdefault(lab, w)
            row["frequencies"] = freqs
            row["mode_kinds"] = kinds
            row["mode_deviation_pct"] = {
                lab: (None if lab not in ref_by else (w - ref_by[lab]) / ref_by[lab] * 100.0)
                for w, lab in zip(freqs, kinds)}
        rows.append(row)
    selected, reason = reference, f"{reference} is the reference"
    for fid in EB_ORDER:
        if fid in results and fid != reference:
            row = next(r for r in rows if r["fidelity"] == fid)
            if not row["flags"]:
                selected = fid
                reason = (f"{fid} (Euler-Bernoulli) agrees with {reference} within {tolerance_pct:g} % "
                          "on omega_n, kappa and gamma1..3")
            else:
                reason = (f"{fid} deviates from {reference} by more than {tolerance_pct:g} % in "
                          + ", ".join(row["flags"]) + f"; the {reference} values are used")
            break
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
    """The check as plain JSON types (the selected ReedProperties as its contract object)."""
    out = {k: v for k, v in check.items() if k != "selected"}
    sel = check["selected"]
    out["selected"] = {
        "fidelity": sel["fidelity"], "reason": sel["reason"],
        "properties": sel["properties"].as_contract(check["geometry"]),
    }
    return out


def render_check(c: dict) -> str:
    """Readable table of a (JSON) check: values and % deviations from the reference."""
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
