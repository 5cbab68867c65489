"""Read and validate reed geometry files (TOML, see CONTRACT.md) and the presets.

Every field is checked and a bad one raises :class:`~geometry.errors.InputError`
naming it (``reed.grooves[1].depth``), so the command line can exit 2 with one line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dataclasses import replace

from . import validate
from .data_files import package_names, package_toml
from .declare import check_field, describe_range, spec_of
from .errors import InputError
from .reed import GROOVE_KINDS, Groove, Material, Reed, Section

def _presets() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(every preset, the thesis's): the packaged files ``geometry/data/reed_<name>.toml``, in the order their
    ``[preset]`` tables give (``order``; then by name), those marked ``thesis = true`` the thesis's reeds."""
    names = [n[len("reed_"):] for n in package_names("geometry") if n.startswith("reed_")]
    meta = {n: package_toml("geometry", f"reed_{n}.toml").get("preset", {}) for n in names}
    names.sort(key=lambda n: (meta[n].get("order", float("inf")), n))
    return tuple(names), tuple(n for n in names if meta[n].get("thesis", False))


#: The reed presets: every packaged file ``geometry/data/reed_<name>.toml`` (a new preset is one such file), and
#: the four of the thesis (Table 3.1: uniform, stepped #1, stepped #2, prototype), which its tables are made of.
PRESETS, THESIS_PRESETS = _presets()

_REED_KEYS = {
    "length", "thickness", "width_root", "width_tip", "step_fraction", "tip_radius",
    "material", "grooves", "name", "sections",
}
_SECTION_KEYS = {"s_end", "width", "thickness", "taper_to", "thickness_to"}
#: the one-step fields that ``[[reed.sections]]`` replaces
_ONE_STEP_KEYS = ("width_root", "width_tip", "step_fraction")
_MATERIAL_KEYS = {"youngs_modulus", "density", "poisson_ratio"}


def load_reed(spec: str | Path) -> Reed:
    """A reed from a preset name (:data:`PRESETS`) or a reed TOML file.

    Parameters
    ----------
    spec : str or Path
        The preset or the file.

    Returns
    -------
    geometry.Reed
        Validated; InputError naming ``spec`` or the bad key otherwise.
    """
    spec_str = str(spec)
    if spec_str in PRESETS:
        return parse_reed(package_toml("geometry", f"reed_{spec_str}.toml"), source=spec_str)
    path = Path(spec_str)
    if not path.exists():
        raise InputError(
            spec_str,
            "no such file; expected a preset (" + ", ".join(PRESETS) + ") or a reed TOML file",
        )
    data = validate.read_toml(path, spec_str)
    return parse_reed(data, source=path.stem)


def _read(cls, table: dict, key: str, where: str, *, required: bool = True, default=None):
    """Field ``key`` of ``table`` checked against ``cls``'s declaration (geometry.reed), or ``default``."""
    if key not in table:
        if required:
            raise InputError(f"{where}.{key}", f"missing; expected {describe_range(spec_of(cls, key))}")
        return default
    return check_field(cls, key, table[key], f"{where}.{key}")


def _check_keys(table: dict, allowed: set[str], where: str) -> None:
    validate.keys(table, sorted(allowed), where)


#: a reed is a plate: at most this thick for its length (Kirchhoff, Euler-Bernoulli), at least
#: this thick (a foil 10^4 times longer than thick does not carry a pressure as a reed does)
MAX_THICKNESS_TO_LENGTH = 0.25
MIN_THICKNESS_TO_LENGTH = 1e-4
#: and at most this wide for its length (a cantilever, not a hinged flap along its long edge)
MAX_WIDTH_TO_LENGTH = 10.0


def _proportions(reed: Reed) -> None:
    """InputError naming the field when the reed's proportions are not a reed's (mm typed as m)."""
    L = reed.length
    thick = [("reed.thickness", reed.thickness)] + [
        (f"reed.sections[{i}].{k}", getattr(sec, k)) for i, sec in enumerate(reed.sections)
        for k in ("thickness", "thickness_to") if getattr(sec, k) is not None]
    for where, h in thick:
        if h > MAX_THICKNESS_TO_LENGTH * L:
            raise InputError(where, f"{h:g} m is {h / L:.3g} times the length {L:g} m; a reed is at most "
                                    f"{MAX_THICKNESS_TO_LENGTH:g} of its length thick{_mm_hint(h)}")
        if h < MIN_THICKNESS_TO_LENGTH * L:
            raise InputError(where, f"{h:g} m is {h / L:.2g} of the length {L:g} m; a reed is at least "
                                    f"{MIN_THICKNESS_TO_LENGTH:g} of its length thick (is reed.length in mm?)")
    widths = [("reed.width_root", reed.width_root), ("reed.width_tip", reed.width_tip)] if not reed.sections else [
        (f"reed.sections[{i}].{k}", getattr(sec, k)) for i, sec in enumerate(reed.sections)
        for k in ("width", "taper_to") if getattr(sec, k) is not None]
    for where, w in widths:
        if w > MAX_WIDTH_TO_LENGTH * L:
            raise InputError(where, f"{w:g} m is {w / L:.3g} times the length {L:g} m; a reed is at most "
                                    f"{MAX_WIDTH_TO_LENGTH:g} times as wide as long{_mm_hint(w)}")


def check_reed(reed: Reed, where: str = "reed") -> Reed:
    """A Reed built in Python checked as a reed file would be (declared ranges, proportions).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    where : str
        Key prefix of the errors.

    Returns
    -------
    geometry.Reed
        The same reed; InputError naming the field otherwise.
    """
    from .declare import specs

    for obj, at in [(reed, where), (reed.material, f"{where}.material")] + \
            [(sec, f"{where}.sections[{i}]") for i, sec in enumerate(reed.sections)] + \
            [(g, f"{where}.grooves[{i}]") for i, g in enumerate(reed.grooves)]:
        for name, spec in specs(obj):
            v = getattr(obj, name)
            unused = isinstance(obj, Groove) and name not in ("kind", "depth", *obj.shape.keys)
            if not (spec.optional and v is None) and not unused:
                check_field(obj, name, v, f"{at}.{name}")
    _proportions(reed)
    return reed


def _mm_hint(v: float) -> str:
    return f" (did you mean {v * 1e-3:g} m? {v:g} looks like a value in mm)"


def parse_reed(data: dict, source: str = "custom") -> Reed:
    """A validated reed from the parsed TOML mapping of a reed file (top-level table ``[reed]``, CONTRACT.md).

    Parameters
    ----------
    data : dict
        The parsed file.
    source : str
        Its name (the reed's name when the file gives none).

    Returns
    -------
    geometry.Reed
        InputError naming the key of a bad value.

    Notes
    -----
    The outline is either the one-step form (``width_root``, ``width_tip``,
    ``step_fraction``) or a list of ``[[reed.sections]]`` (CONTRACT.md, "Multi-section
    reeds"); giving both is an error.
    """
    if "reed" not in data:
        raise InputError("reed", "missing [reed] table")
    for k in data:                 # every table of the file: a misspelt or stray one is never ignored
        if k not in ("reed", "preset"):
            raise InputError(k, "unknown table or key of a reed file; expected [reed] (and [preset] in a "
                                "packaged preset)")
    if "preset" in data:
        validate.keys(data["preset"], ("order", "thesis"), "preset")
    r = data["reed"]
    _check_keys(r, _REED_KEYS, "reed")
    length = _read(Reed, r, "length", "reed")
    material = _parse_material(r)
    name = r.get("name", source)
    if not isinstance(name, str):
        raise InputError("reed.name", f"expected a string, got {name!r}")
    if "sections" in r:
        reed = _parse_sectioned(r, length, material, name)
    else:
        reed = _parse_one_step(r, length, material, name)
    _proportions(reed)
    grooves_raw = r.get("grooves", [])
    if not isinstance(grooves_raw, list):
        raise InputError("reed.grooves", "expected an array of tables [[reed.grooves]]")
    grooves = tuple(_parse_groove(g, f"reed.grooves[{i}]", reed) for i, g in enumerate(grooves_raw))
    return replace(reed, grooves=grooves)


def _parse_material(r: dict) -> Material:
    if "material" not in r:
        raise InputError("reed.material", "missing [reed.material] table")
    m = r["material"]
    _check_keys(m, _MATERIAL_KEYS, "reed.material")
    material = Material(
        youngs_modulus=_read(Material, m, "youngs_modulus", "reed.material"),
        density=_read(Material, m, "density", "reed.material"),
        poisson_ratio=_read(Material, m, "poisson_ratio", "reed.material"),
    )
    return material                    # nu in [0, 0.5) by its declared range


def _parse_one_step(r: dict, length: float, material: Material, name: str) -> Reed:
    """The thesis's form: width_root up to step_fraction * length, then width_tip (Table 3.1)."""
    thickness = _read(Reed, r, "thickness", "reed")
    width_tip = _read(Reed, r, "width_tip", "reed")
    step_fraction = _read(Reed, r, "step_fraction", "reed", required=False, default=0.0)
    if step_fraction > 0.0:
        width_root = _read(Reed, r, "width_root", "reed")
    else:
        width_root = _read(Reed, r, "width_root", "reed", required=False, default=width_tip)
    tip_radius = _tip_radius(r, width_tip, "width_tip", step_fraction * length, length)
    return Reed(
        length=length, thickness=thickness, width_root=width_root, width_tip=width_tip,
        step_fraction=step_fraction, tip_radius=tip_radius, material=material, name=name,
    )


def _tip_radius(r: dict, w_tip: float, w_name: str, start_last: float, length: float) -> float:
    """reed.tip_radius [m]: at most half the width at the tip (``w_name``) and within the last piece
    (from ``start_last`` [m], the step or the last section's start, to the tip)."""
    tip_radius = _read(Reed, r, "tip_radius", "reed", required=False, default=0.0)
    if tip_radius > w_tip / 2 * (1 + 1e-12):
        raise InputError("reed.tip_radius", f"{tip_radius:g} m is wider than the reed at its tip: at most "
                         f"half the width there ({w_name}), {w_tip / 2:g} m")
    tip_radius = min(tip_radius, w_tip / 2)
    if tip_radius > length - start_last:
        raise InputError("reed.tip_radius", f"{tip_radius:g} m reaches past the start of the last piece at "
                         f"{start_last:g} m; expected tip_radius <= {length - start_last:g} m")
    return tip_radius


def _parse_sectioned(r: dict, length: float, material: Material, name: str) -> Reed:
    """``[[reed.sections]]``: pieces from the clamp to the tip (CONTRACT.md, "Multi-section reeds")."""
    for k in _ONE_STEP_KEYS:
        if k in r:
            raise InputError(f"reed.{k}", "not allowed together with [[reed.sections]]: the sections "
                             "replace width_root, width_tip and step_fraction")
    raw = r["sections"]
    if not isinstance(raw, list) or not raw:
        raise InputError("reed.sections", "expected a non-empty array of tables [[reed.sections]]")
    for i, sec in enumerate(raw):
        _check_keys(sec, _SECTION_KEYS, f"reed.sections[{i}]")
    if "thickness" in r or not all("thickness" in sec for sec in raw):
        thickness = _read(Reed, r, "thickness", "reed")
    else:  # every section has its own: the reed-level default is the root's
        thickness = None
    sections, prev = [], 0.0
    for i, sec in enumerate(raw):
        where = f"reed.sections[{i}]"
        s_end = _read(Section, sec, "s_end", where)
        if s_end <= prev:
            raise InputError(f"{where}.s_end", f"{s_end:g} m must exceed the previous section's end "
                             f"({prev:g} m): sections run from the clamp to the tip in order")
        if i < len(raw) - 1 and s_end >= length * (1 - 1e-12):
            raise InputError(f"{where}.s_end", f"{s_end:g} m reaches the tip at reed.length = {length:g} m "
                             f"but {len(raw) - 1 - i} more section(s) follow")
        width = _read(Section, sec, "width", where)
        h = _read(Section, sec, "thickness", where, required=False, default=None)
        taper = _read(Section, sec, "taper_to", where, required=False, default=None)
        h_to = _read(Section, sec, "thickness_to", where, required=False, default=None)
        sections.append(Section(s_end=s_end, width=width, thickness=h, taper_to=taper, thickness_to=h_to))
        prev = s_end
    last = len(raw) - 1
    if abs(sections[-1].s_end - length) > 1e-9 * length:
        raise InputError(f"reed.sections[{last}].s_end", f"the last section must end at the tip, "
                         f"reed.length = {length:g} m; got {sections[-1].s_end:g} m")
    sections[-1] = replace(sections[-1], s_end=length)
    if thickness is None:
        thickness = sections[0].thickness
    end = sections[-1]
    w_end = end.width if end.taper_to is None else end.taper_to
    start_last = sections[-2].s_end if len(sections) > 1 else 0.0
    tip_radius = _tip_radius(r, w_end, f"reed.sections[{last}]", start_last, length)
    reed = Reed.from_sections(length, sections, thickness, tip_radius, material, name=name)
    # a tapered last section with a rounded tip: the outline must keep a positive width
    s = np.linspace(0.0, length, 2001)[:-1]
    if np.any(reed.width(s) <= 0.0):
        k = int(np.argmax(reed.width(s) <= 0.0))
        raise InputError(f"reed.sections[{int(reed._piece_index(s[k]))}].taper_to",
                         f"the outline closes before the tip (width <= 0 at s = {s[k]:g} m)")
    return reed


def _parse_groove(g: dict, where: str, reed: Reed) -> Groove:
    """One ``[[reed.grooves]]`` table: its kind (:data:`geometry.reed.GROOVE_KINDS`), depth and the kind's keys,
    each checked, then the kind's own check that the pocket fits the reed and the depth against the thinnest
    piece it crosses."""
    if not isinstance(g, dict):
        raise InputError(where, "expected a table")
    kind = g.get("kind", "rect")
    if kind not in GROOVE_KINDS:
        raise InputError(f"{where}.kind", f"expected one of {', '.join(map(repr, GROOVE_KINDS))}, got {kind!r}")
    shape = GROOVE_KINDS[kind]
    depth = _read(Groove, g, "depth", where)
    if depth >= reed.max_thickness:
        raise InputError(
            f"{where}.depth", f"{depth:g} m is not shallower than the reed thickness {reed.max_thickness:g} m"
        )
    _check_keys(g, {"kind", "depth", *shape.keys}, where)
    groove = Groove(depth=depth, kind=kind, **{k: _read(Groove, g, k, where) for k in shape.keys})
    shape.check(groove, reed, where)
    a, b = groove.s_range()
    thinnest = min(p.h_min for p in reed.pieces() if p.s0 < b and p.s1 > a)
    if depth >= thinnest:
        k = next(i for i, p in enumerate(reed.pieces()) if p.s0 < b and p.s1 > a and p.h_min == thinnest)
        raise InputError(f"{where}.depth", f"{depth:g} m is not shallower than the local thickness "
                         f"{thinnest:g} m (reed.sections[{k}]) over s = {a:g}..{b:g} m")
    return groove


def reed_to_toml(reed: Reed) -> str:
    """A reed as a TOML document in the reed-file format (round-trips through :func:`parse_reed`).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).

    Returns
    -------
    str
        One-step reeds with width_root, width_tip, step_fraction; multi-section reeds with their sections.
    """
    m = reed.material
    lines = ["[reed]", f'name = "{reed.name}"', f"length = {reed.length!r}", f"thickness = {reed.thickness!r}"]
    if not reed.is_sectioned:
        lines += [f"width_root = {reed.width_root!r}", f"width_tip = {reed.width_tip!r}",
                  f"step_fraction = {reed.step_fraction!r}"]
    lines += [
        f"tip_radius = {reed.tip_radius!r}",
        "",
        "[reed.material]",
        f"youngs_modulus = {m.youngs_modulus!r}",
        f"density = {m.density!r}",
        f"poisson_ratio = {m.poisson_ratio!r}",
    ]
    for sec in reed.sections:
        lines += ["", "[[reed.sections]]", f"s_end = {sec.s_end!r}", f"width = {sec.width!r}"]
        if sec.thickness is not None:
            lines.append(f"thickness = {sec.thickness!r}")
        if sec.taper_to is not None:
            lines.append(f"taper_to = {sec.taper_to!r}")
        if sec.thickness_to is not None:
            lines.append(f"thickness_to = {sec.thickness_to!r}")
    for g in reed.grooves:
        lines += ["", "[[reed.grooves]]", f'kind = "{g.kind}"']
        lines += [f"{k} = {getattr(g, k)!r}" for k in g.shape.keys]
        lines.append(f"depth = {g.depth!r}")
    return "\n".join(lines) + "\n"
