"""Model files: the user's pump, oil and valves in one TOML file (CONTRACT.md, "Model file").

Every key is declared once (geometry.declare.param); the bad-value tests below are generated
from those declarations, not written per key. A different pump described only by a model
file is checked against numbers computed by hand (swept volume, compressibility loss,
ideal-valve limit) and against the mass balance.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import pytest

from geometry.declare import param, specs
from geometry.errors import InputError
from lumped.valves import kind as V
from lumped.run.simulate import simulate
from lumped.valves import disc as dv
from lumped.valves.disc import DiscValve, disc_acceleration
from lumped.model.effect_library import resolve
from lumped.solver.layout import pack
from lumped.model.pump_model import Operating
from lumped.model.model_file import SHIPPED, describe, key_paths, load_model, model_table, parse_model, to_toml, with_values
from lumped.fluid.oil import Oil
from lumped.solver.layout import OFF_IN
from lumped.model.pump import Circuit, Pump
from studies.cli import main

MY_PUMP = """
name = "my-pump"
[pump]                      # bore 20 mm, crank radius 7 mm, rod 100 mm
piston_diameter = 20e-3
crank_radius = 7e-3
rod_length = 100e-3
dead_volume = 3e-5
[operating]
speed_rpm = 900
load_pressure = 4e6
[valves.inlet]
kind = "disc"               # the thesis's disc valves
[valves.delivery]
kind = "disc"
"""

#: near-ideal check valves: light, stiff, critically damped reeds with wide orifices and no
#: displacement flow (as tests/test_pump.py's ideal-valve limit)
IDEAL_REEDS = """
base = "{base}"
name = "ideal-reeds"
[valves]
kind = "reed"
structure.density = 10.0
structure.effective_thickness = 1e-4     # modal mass 1e-3 kg/m^2
structure.stiffness = 1e6
seat.preload = 0.0
damping.internal = 58.9                  # 2 M omega_n / gamma1: critical
flow.orifice_length = 0.097              # 5 x the prototype's
flow.area_min = 0.0
flow.area_max = 0.0
stop.gap = 1e-2
"""


def _run_cli(argv, capsys):
    try:
        rc = main(argv)
    except SystemExit as e:
        rc = e.code
    out, err = capsys.readouterr()
    return rc, out, err


# --------------------------------------------------------------------------- shipped models
@pytest.mark.parametrize("name", list(SHIPPED))
def test_shipped_models_round_trip_through_model_show(name, tmp_path):
    """model show --toml prints a complete model file that loads back to the same model."""
    m = load_model(name)
    text = to_toml(m)
    f = tmp_path / "copy.toml"
    f.write_text(text)
    back = load_model(f)
    assert resolve(back) == replace(resolve(m), name=back.name, source=back.source)
    # every declared key is in the printout with its unit and source
    for k in key_paths(m):
        leaf = k["path"].split(".")[-1]
        assert leaf in text
    assert "Table 5.1" in text and "# m^3," in text or "m^3" in text


ROOT = Path(__file__).resolve().parents[1]
#: the example pumps of the docs and the tests' own (model files, not specs)
EXAMPLE_MODELS = [ROOT / "docs" / "examples" / "disc_20mm_pump.toml", ROOT / "docs" / "examples" / "reed_stiff_pump.toml",
                  ROOT / "tests" / "data" / "bench-pump.toml"]


@pytest.mark.parametrize("path", EXAMPLE_MODELS, ids=lambda p: p.stem)
def test_example_models_round_trip_through_model_show_and_check(path, tmp_path, capsys):
    """model show --toml of an example pump is a file that model check accepts and that loads back the same."""
    m = load_model(path)
    f = tmp_path / "copy.toml"
    f.write_text(to_toml(m))
    rc, out, err = _run_cli(["model", "check", str(f), "--no-fea"], capsys)
    assert rc == 0, err
    back = load_model(f)
    assert resolve(back) == replace(resolve(m), name=back.name, source=back.source)


def test_thesis_models_are_the_thesis_configurations():
    disc, reed = resolve(load_model("thesis-disc")), resolve(load_model("thesis-reed"))
    assert disc.label == "disc" and reed.label == "reed"
    # the delivery disc valve's O-ring (section 2.4.3.2): the seat_compliance effect at its prior
    assert disc.delivery.seat_stiffness == pytest.approx(1.5e6) and disc.inlet.seat_stiffness == pytest.approx(3.02e9)
    assert disc.delivery.seat_damping_value == pytest.approx(2 * math.sqrt(1.5e6 * 3.9e-3))   # eq 2.23
    # reed: c = c_c + c_f = 1727.5 Pa s/m (eq 3.81); the manifolds' inferred dead volume (docs/errata.md)
    assert reed.inlet.damping == pytest.approx(1727.5) and reed.pump.dead_volume == pytest.approx(4.0e-5)
    assert reed.delivery.preload == pytest.approx(-0.18e-3) and reed.inlet.preload == 0.0


def test_pump_cli_takes_a_shipped_model_and_a_file(capsys, tmp_path):
    rc, out, err = _run_cli(["pump", "--model", "thesis-disc", "--revolutions", "2", "--json"], capsys)
    assert rc == 0, err
    obj = json.loads(out)
    assert obj["model"] == "thesis-disc" and obj["speed_rpm"] == 593.0       # the model's [operating]
    assert obj["delivery_cc_per_rev"] == pytest.approx(1.731, rel=0.01)       # Table 5.4, baseline
    f = tmp_path / "mine.toml"
    f.write_text(MY_PUMP)
    rc, out, err = _run_cli(["pump", "--model", str(f), "--revolutions", "3", "--json"], capsys)
    assert rc == 0, err
    obj = json.loads(out)
    assert obj["model"] == str(f) and obj["valve"] == "disc" and obj["speed_rpm"] == 900.0


# --------------------------------------------------------------------------- a different pump
def _ideal_delivery(m):
    """Geometric delivery less the compressibility of the dead volume, by hand (eqs 4.2, 4.11, 4.17)."""
    o, p = m.oil, m.pump
    lp = m.operating.load_pressure
    swept = 2 * math.pi / 4 * p.piston_diameter**2 * p.crank_radius
    return swept - (o.density_at(lp) / o.density_at(p.tank_pressure) - 1) * p.dead_volume


def test_a_pump_described_only_by_a_model_file(tmp_path):
    f = tmp_path / "my_pump.toml"
    f.write_text(MY_PUMP)
    m = load_model(f)
    assert m.pump.displacement == pytest.approx(2 * math.pi / 4 * 0.02**2 * 0.007)
    assert m.oil.air_content == pytest.approx(0.013)            # left out: the thesis oil
    ideal = _ideal_delivery(m)
    r = simulate(m, revolutions=5, max_revolutions=30)
    assert r.cyclic_steady and r.mass_balance_error < 1e-9
    # real valves lose by lag and backflow, but not a fifth of the stroke
    assert 0.85 * ideal < r.delivery_per_rev < ideal
    # the same pump with near-ideal valves reaches the hand-computed limit
    g = tmp_path / "ideal.toml"
    g.write_text(IDEAL_REEDS.format(base=f.name))
    mi = load_model(g)
    ri = simulate(mi, revolutions=3, max_revolutions=10)
    assert ri.mass_balance_error < 1e-9
    assert ri.delivery_per_rev == pytest.approx(ideal, rel=1e-3)
    # and the loss to compressibility is what the hand calculation says: less air, less loss
    less_air = simulate(with_values(mi, {"oil.air_content": 0.0}), revolutions=3, max_revolutions=10)
    assert less_air.delivery_per_rev == pytest.approx(_ideal_delivery(with_values(mi, {"oil.air_content": 0.0})),
                                                      rel=1e-3)


def test_mixed_disc_inlet_reed_delivery_on_both_integrators(tmp_path):
    f = tmp_path / "mixed.toml"
    f.write_text('[valves.inlet]\nkind = "disc"\n[valves.delivery]\nkind = "reed"\n'
                 '[operating]\nspeed_rpm = 700\nload_pressure = 3e6\n')
    m = load_model(f)
    assert m.label == "disc/reed"
    a = simulate(m, revolutions=4, method="fast")
    b = simulate(m, revolutions=4, method="reference")
    assert a.delivery_per_rev == pytest.approx(b.delivery_per_rev, rel=1e-3)
    assert a.inlet.kind == "disc" and a.delivery.kind == "reed"


# --------------------------------------------------------------------------- every key, generated
def _declared_keys():
    """(section path, key, kind of value, spec) of every declared file key of the model file."""
    out = []
    for sec, cls in (("pump", Pump), ("oil", Oil), ("circuit", Circuit), ("operating", Operating)):
        out += [(sec, s.key, cls, n, s) for n, s in specs(cls) if s.key]
    for kind in V.KINDS.values():
        out += [(f"valves.delivery#{kind.name}", s.key, kind.params, n, s) for n, s in specs(kind.params) if s.key]
    return out


def _bad_values(cls, name, spec):
    """Values that must be refused: wrong type, beyond the plausible range, NaN."""
    ann = {f.name: f.type for f in cls.__dataclass_fields__.values()}[name]
    if ann.startswith("bool"):
        return ["yes", 1.5]
    if ann.startswith("str"):
        return [3.0] + (["not-a-choice"] if spec.choices else [])
    bad = ["abc", float("nan")]
    if spec.bounds:
        lo, hi = spec.bounds
        bad.append(hi * 10 + 1)
        if lo > -1e30:
            bad.append(lo - abs(lo) - 1 if lo != 0 else -1.0)
    elif spec.positive:
        bad.append(-1.0)
    return bad


KEYS = _declared_keys()


def _table_with(section, key, value):
    if section.startswith("valves."):
        pos, kind = section.split("#")
        table = {"valves": {pos.split(".")[1]: {"kind": kind}}}
        if kind == "reed" and key.startswith("structure."):
            table["valves"]["delivery"]["kind"] = "reed"
        d = table["valves"][pos.split(".")[1]]
    else:
        table = {section: {}}
        d = table[section]
    parts = key.split(".")
    for p_ in parts[:-1]:
        d = d.setdefault(p_, {})
    d[parts[-1]] = value
    return table


@pytest.mark.parametrize("section, key, cls, name, spec", KEYS, ids=[f"{s}.{k}" for s, k, *_ in KEYS])
def test_every_key_refuses_a_bad_value_naming_its_path(section, key, cls, name, spec):
    path = f"{section.split('#')[0]}.{key}"
    for bad in _bad_values(cls, name, spec):
        with pytest.raises(InputError) as e:
            parse_model(_table_with(section, key, bad))
        assert e.value.field.startswith(path) or path in str(e.value), (path, bad, str(e.value))


@pytest.mark.parametrize("section, key, cls, name, spec", KEYS[::7], ids=[f"{s}.{k}" for s, k, *_ in KEYS[::7]])
def test_bad_model_file_exits_2_with_the_key_path(section, key, cls, name, spec, tmp_path, capsys):
    """The same through the command line (a sample of keys): exit 2, one line, the key path."""
    import tomli_w

    bad = _bad_values(cls, name, spec)[0]
    f = tmp_path / "bad.toml"
    f.write_text(tomli_w.dumps(_table_with(section, key, bad)))
    rc, out, err = _run_cli(["model", "check", str(f), "--no-fea", "--json"], capsys)
    path = f"{section.split('#')[0]}.{key}"
    assert rc == 2 and out == "" and path in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


@pytest.mark.parametrize("table, field", [
    ({"pump": {"piston_diamter": 0.02}}, "pump.piston_diamter"),                          # misspelt
    ({"valves": {"delivery": {"kind": "disc", "spring": {"stifness": 300.0}}}}, "valves.delivery.spring.stifness"),
    ({"oil": {"air_contnet": 0.01}}, "oil.air_contnet"),
    ({"bogus": {}}, "bogus"),
    ({"effects": {"warp": {}}}, "effects.warp"),
    ({"effects": {"seat_compliance": {"k_seat": 1e6}}}, "effects.seat_compliance"),       # a valve effect
    ({"effects": {"seat_compliance": {"delivery": {"k_sea": 1e6}}}}, "effects.seat_compliance.delivery.k_sea"),
    ({"effects": {"seat_compliance": {"delivery": {"k_seat": -5.0}}}}, "effects.seat_compliance.delivery.k_seat"),
    ({"effects": {"fluid_damping": {}}}, "effects.fluid_damping"),                       # reed effect on discs
    ({"valves": {"inlet": {"kind": "poppet"}}}, "valves.inlet.kind"),
    ({"valves": {"inlet": {"kind": "reed", "geometry": "nosuch"}}}, "valves.inlet.geometry"),
    ({"valves": {"inlet": {"kind": "reed", "geometry": "prototype", "fidelity": "fancy"}}}, "valves.inlet.fidelity"),
    ({"valves": {"inlet": {"kind": "reed", "geometry": "prototype", "structure": {"stiffness": 1e7}}}},
     "valves.inlet.structure.stiffness"),                                                 # derived from the geometry
    ({"valves": {"inlet": {"kind": "disc", "port": {"diameter": 14e-3}}}}, "valves.inlet.port.diameter"),
    ({"valves": {"inlet": {"kind": "disc", "seat": {"inner_radius": 8e-3}}}}, "valves.inlet.seat.inner_radius"),
    ({"pump": {"rod_length": 5e-3}}, "pump.rod_length"),                                  # shorter than the crank
    ({"pump": {"dead_volume": 1.0}}, "pump.dead_volume"),                                 # nothing left to pump
    ({"pump": {"tank_pressure": 1.0}}, "pump.tank_pressure"),                             # MPa typed as Pa
    ({"oil": {"air_content": 0.013}, "effects": {"entrained_air": {"R": 0.02}}}, "effects.entrained_air.R"),
])
def test_unknown_inconsistent_and_implausible_keys_are_named(table, field):
    with pytest.raises(InputError) as e:
        parse_model(table)
    assert e.value.field == field, str(e.value)


def test_unit_slips_get_a_hint():
    with pytest.raises(InputError, match="did you mean 101325 Pa"):
        parse_model({"pump": {"tank_pressure": 0.101325}})
    with pytest.raises(InputError, match="looks like a value in mm"):
        parse_model({"pump": {"piston_diameter": 20.0}})


# --------------------------------------------------------------------------- key paths
def test_key_paths_change_one_key():
    m = load_model("thesis-disc")
    w = with_values(m, {"pump.dead_volume": 3e-5, "valves.inlet.spring.stiffness": 300.0,
                        "valves.mass.disc": 3e-3, "effects.seat_compliance.delivery.k_seat": 2e6})
    assert w.pump.dead_volume == 3e-5 and w.inlet.spring_stiffness == 300.0 and w.delivery.spring_stiffness == 213.0
    assert w.inlet.disc_mass == 3e-3 and w.delivery.disc_mass == 3e-3          # valves.* = both valves
    assert resolve(w).delivery.seat_stiffness == 2e6
    off = with_values(m, {"effects.seat_compliance": False})
    assert off.effects == () and resolve(off).delivery.seat_stiffness == pytest.approx(3.02e9)
    with pytest.raises(InputError, match="valves.inlet.spring.stiffness"):
        with_values(m, {"valves.inlet.spring.stiffness": -1.0})
    # a reed's geometry, by path: a thinner reed is softer (kappa ~ h^3, eq 3.40)
    r = with_values(load_model("thesis-reed"), {"valves.geometry": "prototype", "valves.fidelity": "analytic"})
    thin = with_values(r, {"valves.delivery.geometry.thickness": 1.2e-3})
    assert thin.delivery.stiffness / r.delivery.stiffness == pytest.approx((1.2 / 1.35) ** 3, rel=0.05)
    assert thin.inlet.stiffness == r.inlet.stiffness


def test_model_check_reports_derived_quantities(capsys):
    rc, out, err = _run_cli(["model", "check", "thesis-disc", "--json"], capsys)
    assert rc == 0, err
    d = json.loads(out)
    assert d["swept_volume_m3"] == pytest.approx(2.218e-6, rel=1e-3)         # Table 5.1: 2.22 cc
    assert d["compression_ratio"] == pytest.approx((2.17e-5 + 2.218e-6) / 2.17e-5, rel=1e-3)
    # the disc on its spring: sqrt(k / (m_disc + m_s/3)) (eq 2.3)
    assert d["inlet"]["natural_frequency_rad_s"] == pytest.approx(math.sqrt(213.0 / 2.7e-3), rel=1e-9)
    # eq 2.23 with the thesis's 3.9 g: the real 2.7 g moving mass makes the rigid seat 1.2x critical
    assert d["inlet"]["damping_ratios"]["seat"] == pytest.approx(6860 / (2 * math.sqrt(3.02e9 * 2.7e-3)), rel=1e-9)
    assert describe(load_model("thesis-reed"))["delivery"]["reed_parameters"]["kappa"] == pytest.approx(7.709e6)


def test_model_show_prints_every_key(capsys):
    rc, out, err = _run_cli(["model", "show", "thesis-reed", "--json"], capsys)
    assert rc == 0, err
    d = json.loads(out)
    paths = {k["path"] for k in d["keys"]}
    assert {"pump.dead_volume", "oil.viscosity", "valves.delivery.seat.preload",
            "effects.fluid_damping.c_f"} <= paths
    rc, out, err = _run_cli(["model", "show", "thesis-reed", "--toml"], capsys)
    assert rc == 0 and "[valves.delivery]" in out and "Pa s/m" in out


# --------------------------------------------------------------------------- adding a parameter
@dataclass(frozen=True)
class WobblyDisc(DiscValve):
    """A disc valve with one more parameter: a single declaration, nothing else."""

    wobble_damping: float = param("wobble.damping", "N s/m", "test: one new declaration", bounds=(0.0, 100.0),
                                  packed=True, default=0.0)


def _wobbly_acceleration(x, u, f, p, o, contact, regime):
    a = disc_acceleration(x, u, f, p, o, contact, regime)
    return a - p[o + WOBBLY.wobble_damping] * u / p[o + WOBBLY.moving_mass]


WOBBLY = V.kind_block(WobblyDisc)


@pytest.fixture
def wobbly_kind():
    kind = V.register(V.ValveKind(name="wobbly", params=WobblyDisc, acceleration=_wobbly_acceleration, block=WOBBLY,
                                  default_model="thesis-disc"))
    yield kind
    del V.KINDS["wobbly"]
    V._build_dispatch()


def test_a_new_parameter_is_one_declaration_plus_its_value(wobbly_kind, tmp_path):
    f = tmp_path / "wobbly.toml"
    f.write_text('[valves.inlet]\nkind = "wobbly"\nwobble.damping = 2.5   # N s/m\n')
    m = load_model(f)
    assert m.inlet.wobble_damping == 2.5                                        # the loader
    p = pack(m, 600.0, 2.8e6)
    assert p[OFF_IN + WOBBLY.wobble_damping] == 2.5                             # the flat array layout
    assert "wobble.damping = 2.5" in to_toml(m) and "N s/m" in to_toml(m)        # model show
    assert with_values(m, {"valves.inlet.wobble.damping": 4.0}).inlet.wobble_damping == 4.0   # sweep variable
    assert any(k["path"] == "valves.inlet.wobble.damping" for k in key_paths(m))
    with pytest.raises(InputError, match="valves.inlet.wobble.damping"):       # validation
        with_values(m, {"valves.inlet.wobble.damping": 1e6})
    assert model_table(m)["valves"]["inlet"]["wobble"]["damping"] == 2.5


def test_model_show_labels_the_keys_a_model_file_sets(tmp_path, capsys):
    """A key the user's model file sets is labelled as that file's, also through a base chain; a key inherited
    from a shipped model keeps its declared source (a 20 mm bore is not Table 5.1's)."""
    (tmp_path / "bigger.toml").write_text('base = "thesis-disc"\n[pump]\ndead_volume = 3.4e-5\n')
    (tmp_path / "mine.toml").write_text('base = "bigger.toml"\n[pump]\npiston_diameter = 20.0e-3\n'
                                        '[valves]\nspring.stiffness = 300.0\n[valves.inlet]\nflow.f1 = 0.8\n')
    rc, out, err = _run_cli(["model", "show", str(tmp_path / "mine.toml"), "--json"], capsys)
    assert rc == 0, err
    src = {k["path"]: k["source"] for k in json.loads(out)["keys"]}
    assert "model file mine.toml" in src["pump.piston_diameter"] and "Table 5.1" not in src["pump.piston_diameter"]
    assert "model file bigger.toml" in src["pump.dead_volume"] and "Table 5.1" not in src["pump.dead_volume"]
    assert src["pump.crank_radius"] == "r (Table 5.1)"                          # inherited: the shipped source
    assert all("model file mine.toml" in src[f"valves.{p}.spring.stiffness"] for p in ("inlet", "delivery"))
    assert "model file mine.toml" in src["valves.inlet.flow.f1"]
    assert "model file" not in src["valves.delivery.flow.f1"]
    rc, out, err = _run_cli(["model", "show", str(tmp_path / "mine.toml"), "--toml"], capsys)
    assert rc == 0, err
    line = next(s for s in out.splitlines() if s.startswith("piston_diameter"))
    assert "model file mine.toml" in line and "Table 5.1" not in line
    assert next(s for s in out.splitlines() if s.startswith("crank_radius")).endswith("(Table 5.1)")
    # a shipped model: every key keeps its declared source
    rc, out, err = _run_cli(["model", "show", "thesis-disc", "--json"], capsys)
    assert not any("model file" in k["source"] for k in json.loads(out)["keys"])
