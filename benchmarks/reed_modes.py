"""The modal reed against the whole FE reed, structural side: the tables of docs/reed_dynamics.md.

    python benchmarks/reed_modes.py [--markdown] [--no-plate] [--no-solid]

Prints one JSON object (or, with --markdown, the tables of docs/reed_dynamics.md):

- ``frequencies``: the uniform cantilever's first six omega from the exact E-B model and
  from the Hermite beam at L/4..L/64 against the closed form beta_n L (Blevins 1979, to 10
  digits), with the beam's observed order of convergence;
- ``static``: the modal static deflection (tip and opening) with N = 1..6 modes against the
  FE reed's K^-1 f, same fidelity and mesh: the prototype reed (whole face and an off-axis
  port), a reed twice as long and half as thick, beam and plate;
- ``release``: the free reed released from that static deflection, max tip and opening
  error over 20 periods of mode 1 against the FE reed, per N;
- ``timings``: seconds per six-mode basis per fidelity at its default mesh (uncached), and
  per whole FE reed.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from geometry import load_reed  # noqa: E402
from geometry.reed_port import ReedPort  # noqa: E402
from lumped.reed import modal_basis as rm  # noqa: E402

#: beta_n L of the clamped-free uniform beam, roots of cos x cosh x = -1 (Blevins 1979, Table 8-1)
BETA_L = (1.875104069, 4.694091133, 7.854757438, 10.99554073, 14.13716839, 17.27875953)
#: the off-axis port: 5 mm wide, its centre 3.5 mm off the axis, from 8 to 20 mm (prototype)
OFF_AXIS = ReedPort(s_start=8.0e-3, s_end=20.0e-3, width=5.0e-3, y_center=3.5e-3)


def cases() -> dict:
    """The reeds and ports of the tables: name -> (reed, port)."""
    proto = load_reed("prototype")
    return {"prototype": (proto, None),
            "prototype, off-axis port": (proto, OFF_AXIS),
            "twice as long, half as thick": (proto.scaled(2.0, 0.5, name="long-thin"), None)}


def closed_form_omega(reed, n: int = 6) -> np.ndarray:
    """omega_n = (beta_n L)^2 sqrt(E I / (rho A L^4)) [rad/s] of a uniform cantilever."""
    A, I = reed.section(0.5 * reed.length)
    m = reed.material
    return np.array(BETA_L[:n]) ** 2 * np.sqrt(m.youngs_modulus * I / (m.density * A * reed.length**4))


def frequencies() -> dict:
    """Exact E-B and Hermite-beam omega of the uniform reed against the closed form."""
    from fea import beam

    reed = load_reed("uniform")
    exact = closed_form_omega(reed)
    out = {"closed_form": exact.tolist(),
           "analytic_error": (rm.modal_basis(reed, "analytic", 6).omega / exact - 1).tolist(), "beam": []}
    for k in (4, 8, 16, 32, 64):
        b = beam.modal_basis(reed, mesh_size=reed.length / k)
        out["beam"].append({"elements": k, "dofs": b.dofs, "error": (b.omega / exact - 1).tolist()})
    errs = [np.abs(r["error"]) for r in out["beam"]]
    out["beam_order"] = [np.log2(errs[-3][j] / errs[-2][j]) for j in range(6)]  # L/16 -> L/32
    return out


def static_and_release(fidelities=("beam", "plate")) -> tuple[list, list]:
    """Static convergence and release rows for every case and fidelity with an FE reed."""
    static, release = [], []
    for name, (reed, port) in cases().items():
        for fid in fidelities:
            if fid == "plate" and name.startswith("twice"):
                continue  # the plate adds nothing to a reed scaled along its axis
            fe = rm.fe_reed(reed, port, fid)
            basis = rm.modal_basis(reed, fid, 6, port=port, mesh_size=fe.mesh_size)
            s = rm.static_convergence(basis, fe)
            static.append({"case": name, "fidelity": fid, "fe_dofs": fe.n_dof, "mesh_size": fe.mesh_size,
                           "kinds": list(basis.kinds), **s})
            r = rm.release_errors(basis, fe)
            release.append({"case": name, "fidelity": fid, **r})
    return static, release


def timings(fidelities=("analytic", "beam", "plate", "solid")) -> list:
    """Seconds per six-mode basis (uncached, default mesh) and per whole FE reed, prototype reed."""
    reed = load_reed("prototype")
    rm.names()
    out = []
    for fid in fidelities:
        rm.FIDELITIES[fid](reed, port=None, mesh_size=None, n_modes=6)   # warm up imports
        t0 = time.perf_counter()
        b = rm.FIDELITIES[fid](reed, port=None, mesh_size=None, n_modes=6)
        row = {"fidelity": fid, "basis_s": time.perf_counter() - t0, "dofs": b.dofs, "mesh_size": b.mesh_size}
        if fid in rm.fe_names():
            t0 = time.perf_counter()
            fe = rm.FE_FIDELITIES[fid](reed, port=None, mesh_size=None)
            row.update(fe_reed_s=time.perf_counter() - t0, fe_dofs=fe.n_dof, fe_mesh_size=fe.mesh_size)
            t0 = time.perf_counter()
            fe.modes()
            row["fe_dense_eigen_s"] = time.perf_counter() - t0
        out.append(row)
    return out


def markdown(res: dict) -> str:
    """The tables of docs/reed_dynamics.md."""
    lines = ["Frequencies of the uniform reed against the closed form (relative error):", "",
             "| model | " + " | ".join(f"mode {k + 1}" for k in range(6)) + " |",
             "|---" * 7 + "|",
             "| exact E-B | " + " | ".join(f"{e:.1e}" for e in res["frequencies"]["analytic_error"]) + " |"]
    for r in res["frequencies"]["beam"]:
        lines.append(f"| beam, L/{r['elements']} ({r['dofs']} DOFs) | " + " | ".join(f"{e:.1e}" for e in r["error"]) + " |")
    lines += ["", "Observed order of the beam (L/16 to L/32): "
              + ", ".join(f"{o:.2f}" for o in res["frequencies"]["beam_order"]), ""]
    for s in res["static"]:
        lines += [f"Static, {s['case']}, {s['fidelity']} ({s['fe_dofs']} DOFs; modes: {', '.join(s['kinds'])}); "
                  f"FE tip {s['fe']['tip'] * 1e9:.4g} nm/Pa, opening {s['fe']['opening'] * 1e9:.4g} nm/Pa:", "",
                  "| N | tip error | opening error |", "|---|---|---|"]
        lines += [f"| {r['modes']} | {r['tip_error']:+.2e} | {r['opening_error']:+.2e} |" for r in s["rows"]]
        lines.append("")
    for s in res["release"]:
        lines += [f"Release over {s['periods']:g} periods, {s['case']}, {s['fidelity']} ({s['fe_dofs']} DOFs):", "",
                  "| N | max tip error | max opening error | bound (tip) |", "|---|---|---|---|"]
        lines += [f"| {r['modes']} | {r['tip_error']:.2e} | {r['opening_error']:.2e} | "
                  f"{'-' if r['bound'] is None else format(r['bound'], '.2e')} |" for r in s["rows"]]
        lines.append("")
    if res.get("timings"):
        lines += ["Cost on the prototype reed (seconds, 2 shared cores):", "",
                  "| fidelity | six-mode basis | DOFs | whole FE reed | FE DOFs | its dense eigh |", "|---|---|---|---|---|---|"]
        for t in res["timings"]:
            lines.append(f"| {t['fidelity']} | {t['basis_s']:.2f} | {t['dofs'] or '-'} | "
                         f"{format(t['fe_reed_s'], '.2f') if 'fe_reed_s' in t else '-'} | {t.get('fe_dofs', '-')} | "
                         f"{format(t['fe_dense_eigen_s'], '.2f') if 'fe_dense_eigen_s' in t else '-'} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", action="store_true", help="print the docs tables instead of JSON")
    ap.add_argument("--no-plate", action="store_true", help="beam only in the static and release tables")
    ap.add_argument("--no-solid", action="store_true", help="leave the solid out of the timings")
    args = ap.parse_args(argv)
    fids = ("beam",) if args.no_plate else ("beam", "plate")
    static, release = static_and_release(fids)
    timing_fids = tuple(f for f in ("analytic", "beam", "plate", "solid")
                        if not (f == "solid" and args.no_solid) and not (f == "plate" and args.no_plate))
    res = {"frequencies": frequencies(), "static": static, "release": release, "timings": timings(timing_fids)}
    print(markdown(res) if args.markdown else json.dumps(res, indent=1, default=float))


if __name__ == "__main__":
    main()
