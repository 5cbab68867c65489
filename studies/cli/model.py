"""``valvelab model show|check``: print a complete pump model, or validate one and report what follows from it."""

from __future__ import annotations

from geometry.errors import InputError

HELP = "show a pump model (every key with unit and source) or check a model file and report derived quantities"


def configure(p):
    """Add the arguments of ``valvelab model`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("action", choices=("show", "check"), help="show: the complete resolved model; check: "
                                                              "validate and report derived quantities")
    p.add_argument("model", help="a shipped model (thesis-disc, thesis-reed) or a model TOML file")
    p.add_argument("--toml", action="store_true", help="show: print the model as a model file (units and sources "
                                                        "as comments) to copy and edit")
    p.add_argument("--no-fea", action="store_true",
                   help="check: skip the FEA check of reed valves that name a geometry")


def run(args) -> dict:
    """Run ``valvelab model``: show a pump model (every key with unit and source) or check a model file and report
    derived quantities (the JSON of ``--json``; :mod:`studies.cli`)."""
    from lumped.model.model_file import describe, file_keys, key_paths, load_model, model_table, to_toml

    model = load_model(args.model, field="model")
    if args.action == "show":
        origins = file_keys(model)          # a key the user's file sets is the file's, not its declared source
        out = {"model": model.name, "source": model.source, "table": _plain(model_table(model)),
               "keys": key_paths(model, origins)}
        if args.toml:
            out["toml"] = to_toml(model, origins=origins)
        return out
    if args.toml:
        raise InputError("--toml", "applies to model show")
    from lumped.model.uncertainty import check_reach

    check_reach(model)              # every draw of a declared uncertainty inside its key's range
    out = describe(model)
    from lumped.model.plausible import input_warnings

    out["warnings"] = [w.to_dict() for w in input_warnings(model)]      # possible, but likely a slip
    out["uncertainties"] = [dict(key=u.key, **u.as_table()) for u in model.uncertainties]
    out["valid"] = True
    if not args.no_fea:
        out["fea_check"] = _fea_checks(model)
    return out


def _fea_checks(model) -> dict:
    """The multi-fidelity check (valvelab check) of each reed valve that names a geometry: its flags."""
    from studies.validation.reed_check import check_as_json, multi_fidelity_check

    out = {}
    done = {}
    for pos in ("inlet", "delivery"):
        v = model.valve(pos)
        reed = getattr(v, "reed", None)
        if reed is None:
            continue
        key = (reed, v.fidelity)
        if key not in done:
            fids = tuple(dict.fromkeys(("analytic", v.fidelity or "analytic", "solid")))
            chk = multi_fidelity_check(reed, fidelities=fids, progress=True)
            j = check_as_json(chk)
            done[key] = {"geometry": v.geometry, "fidelity": v.fidelity, "reference": j["reference"],
                         "flagged": j["flagged"], "rows": j["rows"]}
        out[pos] = done[key]
    return out


def _plain(d):
    """The model table as JSON-able values (TOML scalars are already)."""
    if isinstance(d, dict):
        return {k: _plain(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_plain(v) for v in d]
    return d


def render(r: dict) -> str:
    """The result of ``valvelab model`` as readable text."""
    if "toml" in r:
        return r["toml"].rstrip("\n")
    if "keys" in r:
        lines = [f"model {r['model']} ({r['source']}): {len(r['keys'])} numeric keys"]
        for k in r["keys"]:
            lines.append(f"  {k['path']:48s} {k['value']:<14.6g} {k['unit']:8s} {k['source']}")
        return "\n".join(lines)
    lines = [f"model {r['model']} is valid ({r['source'] or 'shipped'})",
             f"  swept volume        {r['swept_volume_m3'] * 1e6:.4f} cc, dead volume {r['dead_volume_m3'] * 1e6:.3f} cc,"
             f" compression ratio {r['compression_ratio']:.4g}",
             f"  circuit             {r['circuit']}; effects: {', '.join(r['effects']) or 'none'}"]
    for pos in ("inlet", "delivery"):
        v = r[pos]
        z = ", ".join(f"{k} {x:.3g}" for k, x in v["damping_ratios"].items())
        lines.append(f"  {pos:8s} {v['kind']:5s} natural frequency {v['natural_frequency_rad_s']:.1f} rad/s; "
                     f"damping ratios {z}")
        if "reed_parameters" in v:
            rp = v["reed_parameters"]
            lines.append(f"           kappa {rp['kappa'] / 1e6:.4g} MPa/m, gamma1..3 {rp['gamma1']:.4f} {rp['gamma2']:.4f} "
                         f"{rp['gamma3']:.4f}, h_eff {rp['h_eff'] * 1e3:.4f} mm ({rp['source']})")
    if r.get("uncertainties"):
        lines.append(f"  input uncertainties {', '.join(u['key'] for u in r['uncertainties'])}")
    for pos, c in r.get("fea_check", {}).items():
        lines.append(f"  FEA check ({pos}, {c['geometry']}): flagged {', '.join(c['flagged']) or 'nothing'} "
                     f"against {c['reference']}")
    return "\n".join(lines)
