"""``valvelab seat``: disc-valve seat and stop stiffness (FEA, section 2.4.3.2) and the reed stress check (3.1.1)."""

from __future__ import annotations

from geometry.errors import InputError
from studies.cli import flags

#: the reed stress check is linear: a tip opening beyond this fraction of the length is not small
MAX_OPENING_TO_LENGTH = 0.3

HELP = "k_seat, k_stop and critical damping of the disc valve (FEA); reed stress at maximum opening and on its seat"


def configure(p):
    """Add the arguments of ``valvelab seat`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("--reed", default="prototype",
                   help="reed for the stress check: preset or reed TOML (default: prototype)")
    p.add_argument("--x-stop-mm", type=flags.number("mm", (1e-3, 1e4), positive=True), default=None,
                   help="reed tip opening at the stop [mm] (default: 1.9 mm, thesis-reed's stop.gap)")
    p.add_argument("--reverse-pressure-mpa", type=flags.number("MPa", (1e-4, 100.0), positive=True), default=None,
                   help="reverse pressure difference on the closed reed [MPa] (default: geometry/data/seat_stop.toml)")
    p.add_argument("--mesh-size", type=flags.number("m", (1e-7, 1.0), positive=True), default=None, help="element size [m] of the reed solid")
    p.add_argument("--skip-disc", action="store_true", help="only the reed stress check")
    p.add_argument("--skip-reed", action="store_true", help="only the disc valve's seat and stop")


def run(args) -> dict:
    """Run ``valvelab seat``: the disc valve's seat and stop stiffness and damping (FEA), the reed's stress (the JSON
    of ``--json``; :mod:`studies.cli`)."""
    from studies.tables.thesis import thesis_values

    if args.skip_disc and args.skip_reed:
        raise InputError("--skip-disc/--skip-reed", "skipping both leaves nothing to compute")
    tv = thesis_values()
    out: dict = {}
    if not args.skip_reed:       # the reed and its opening checked before any FEA
        from geometry import load_reed

        reed = load_reed(args.reed)
        if args.x_stop_mm is not None and args.x_stop_mm * 1e-3 > MAX_OPENING_TO_LENGTH * reed.length:
            raise InputError("--x-stop-mm", f"{args.x_stop_mm:g} mm is more than {MAX_OPENING_TO_LENGTH:g} of the "
                                            f"reed's length ({reed.length * 1e3:g} mm): the linear stress model "
                                            "holds for small deflections only")
        if args.mesh_size is not None:          # a mesh out of reach is refused before the disc's FEA runs
            from fea.mesh import check_size
            from fea.mesh import check_face_mesh

            check_size(reed, args.mesh_size)
            check_face_mesh(reed, args.mesh_size, quad=True)
    if not args.skip_disc:
        from fea.seat_stop import seat_and_stop

        t23 = tv["table_2_3"]
        ss = seat_and_stop()
        ss["seat"].update(thesis_stiffness=t23["k_seat_rigid"], thesis_damping=t23["c_seat_rigid"])
        ss["stop"].update(thesis_stiffness=t23["k_stop"], thesis_damping=t23["c_stop"])
        out["disc_valve"] = ss
    if not args.skip_reed:
        import sys

        from fea.reed_stress import max_opening_stress, seat_reverse_stress

        x = None if args.x_stop_mm is None else args.x_stop_mm * 1e-3
        pr = None if args.reverse_pressure_mpa is None else args.reverse_pressure_mpa * 1e6
        print(f"reed stress: {reed.name} at maximum opening", file=sys.stderr, flush=True)
        a = max_opening_stress(reed, x_stop=x, mesh_size=args.mesh_size).as_dict()
        a["thesis_max_von_mises"] = tv["table_3_13"]["von_mises_max"]
        print(f"reed stress: {reed.name} on its slotted seat", file=sys.stderr, flush=True)
        b = seat_reverse_stress(reed, pressure=pr, mesh_size=args.mesh_size).as_dict()
        out["reed"] = {"geometry": args.reed, "max_opening": a, "seat_reverse": b}
    return out


def render(r: dict) -> str:
    """The result of ``valvelab seat`` as readable text."""
    lines = []
    if "disc_valve" in r:
        lines.append("disc valve contact stiffness (3-D FEA, P2 tetrahedra)")
        for part in ("seat", "stop"):
            d = r["disc_valve"][part]
            lines.append(
                f"  k_{part} = {d['stiffness']:.3e} N/m (thesis {d['thesis_stiffness']:.3e}), "
                f"c_{part} = {d['damping']:.0f} N s/m (thesis {d['thesis_damping']:.0f}); "
                f"{d['load']:.0f} N -> {d['mean_displacement'] * 1e3:.3e} mm, {d['dofs']} dofs")
    if "reed" in r:
        rr = r["reed"]
        a, b = rr["max_opening"], rr["seat_reverse"]
        lines.append(f"reed {rr['geometry']} stress check (yield {a['yield_stress'] / 1e6:.1f} MPa)")
        lines.append(
            f"  maximum opening {a['tip_deflection'] * 1e3:.2f} mm (p = {a['pressure'] / 1e3:.2f} kPa): "
            f"von Mises {a['max_von_mises_away_from_clamp'] / 1e6:.1f} MPa away from the clamp, "
            f"{a['max_von_mises'] / 1e6:.1f} MPa at the clamp edge (singular), beam theory "
            f"{a['beam_root_stress'] / 1e6:.1f} MPa; thesis {a['thesis_max_von_mises'] / 1e6:.1f} MPa")
        lines.append(
            f"  reverse pressure {b['pressure'] / 1e6:.2f} MPa on the slotted seat: von Mises "
            f"{b['max_von_mises'] / 1e6:.1f} MPa (safety factor {b['safety_factor']:.2f})")
    return "\n".join(lines)
