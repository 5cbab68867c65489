"""Input uncertainties a model file declares: ``[uncertainty."KEY.PATH"]`` (CONTRACT.md, "Validation uncertainty").

One declaration per model key that carries an uncertainty (ASME V&V 20-2009 calls their
effect on a result u_input):

- ``standard`` (in the key's units) or ``relative`` (to the key's value): the *standard*
  uncertainty, i.e. the standard deviation of the distribution; for ``uniform`` the
  half-width is sqrt(3) times it (GUM 4.3.7);
- ``distribution``: ``normal`` or ``uniform``;
- ``source``: where the number comes from (a thesis section, a datasheet, a stated assumption);
- ``scales`` (optional): other keys that follow this one as a power law, ``{KEY = exponent}``:
  one cause moving several keys together (a reed thicker than nominal has a larger h_eff and,
  identified from its measured frequency by eq 3.73, a larger kappa: exponent 1).

A key path is any numeric key of the model (``oil.air_content``,
``valves.delivery.spring.stiffness``, ``valves.spring.stiffness`` for both valves, drawn
together, ``valves.delivery.geometry.thickness`` for a reed with a geometry,
``effects.seat_compliance.delivery.k_seat``). :func:`parse_uncertainties` checks every field
and names the bad one (``uncertainty."oil.air_content".standard``); :func:`check_reach` checks
that the draws stay inside each key's plausible range (``valvelab model check``, and before a
Monte Carlo run). :func:`sample_values` turns standard scores into key values.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass

from geometry import validate
from geometry.declare import check_value, field_for_key, flatten, spec_of
from geometry.errors import InputError

DISTRIBUTIONS = ("normal", "uniform")
FIELDS = ("standard", "relative", "distribution", "source", "scales")
#: a normal draw is cut at this many standard deviations (scrambled Sobol points never reach 0 or 1,
#: and a key's plausible range must hold every draw: check_reach)
NORMAL_CUT = 4.0
#: the largest excursion of a draw in standard uncertainties
REACH = {"normal": NORMAL_CUT, "uniform": math.sqrt(3.0)}


@dataclass(frozen=True)
class Uncertainty:
    """One declared input uncertainty (see the module docstring); SI units of its key."""

    key: str
    distribution: str
    source: str
    standard: float | None = None
    relative: float | None = None
    scales: tuple[tuple[str, float], ...] = ()

    @property
    def where(self) -> str:
        """How messages name this declaration: ``uncertainty."KEY"``."""
        return f'uncertainty."{self.key}"'

    def standard_of(self, nominal: float) -> float:
        """The standard uncertainty [key units] of a key whose value is ``nominal``."""
        return float(self.standard) if self.standard is not None else abs(float(self.relative) * nominal)

    def value_at(self, nominal: float, z: float) -> float:
        """The key's value ``z`` standard uncertainties from ``nominal``."""
        return nominal + z * self.standard_of(nominal)

    def as_table(self) -> dict:
        """The declaration as a model file writes it."""
        out = {"standard": self.standard} if self.standard is not None else {"relative": self.relative}
        out.update(distribution=self.distribution, source=self.source)
        if self.scales:
            out["scales"] = dict(self.scales)
        return out


# --------------------------------------------------------------------------- the model's keys
#: the model file's key listing, ``key_paths(model) -> [{"path", "value", ...}]``: lumped.model.model_file
#: registers it when it loads (it calls this module, so this module does not import it)
KEY_PATHS: dict = {}


def numeric_keys(model) -> dict[str, float]:
    """{key path: value} of every numeric key of ``model`` (with a reed geometry's keys)."""
    from lumped.model.pump_model import POSITIONS

    out = {k["path"]: float(k["value"]) for k in KEY_PATHS["key_paths"](model)}
    for pos in POSITIONS:
        reed = getattr(model.valve(pos), "reed", None)
        if reed is None:
            continue
        from geometry.reed_io import reed_to_toml

        for k, v in flatten(tomllib.loads(reed_to_toml(reed))["reed"]).items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                out[f"valves.{pos}.geometry.{k}"] = float(v)
    return out


def _component(model, path: str):
    """(component or None, its file key) that declares ``path``."""
    from lumped.model.pump_model import POSITIONS

    parts = path.split(".")
    if parts[0] in ("pump", "oil", "circuit", "operating") and len(parts) > 1:
        return getattr(model, parts[0]), ".".join(parts[1:])
    if parts[0] == "valves" and len(parts) > 2 and parts[1] in POSITIONS:
        return model.valve(parts[1]), ".".join(parts[2:])
    return None, None


def _why_not_numeric(model, path: str) -> str | None:
    """Why a declared key is not a numeric key of the model (None if it is not a declared key at all)."""
    comp, key = _component(model, path)
    if comp is None:
        return None
    name = field_for_key(comp, key)
    if name is None:
        return None
    value = getattr(comp, name)
    if value is None:
        return "has no value in this model (it is derived from other keys); declare the uncertainty on a key that has one"
    if getattr(comp, "reed", None) is not None and key in getattr(type(comp), "FROM_GEOMETRY", ()):
        return (f"is derived from the reed geometry {getattr(comp, 'geometry', '')!r} in this model; declare the "
                f"geometry's key instead (e.g. {'.'.join(path.split('.')[:2])}.geometry.thickness)")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"is not a number ({value!r}); only numeric keys carry an uncertainty"
    return "is derived in this model, not one of its keys; declare the uncertainty on a key the model file gives"


def targets(model, key: str, where: str, keys: dict | None = None) -> list[tuple[str, float]]:
    """(path, nominal value) of every key ``key`` stands for: itself, or both valves' for ``valves.<key>``."""
    from lumped.model.pump_model import POSITIONS

    keys = numeric_keys(model) if keys is None else keys
    if key in keys:
        return [(key, keys[key])]
    parts = key.split(".")
    if parts[0] == "valves" and len(parts) > 1 and parts[1] not in POSITIONS:
        both = [f"valves.{pos}.{'.'.join(parts[1:])}" for pos in POSITIONS]
        if all(p in keys for p in both):
            return [(p, keys[p]) for p in both]
        key = next((p for p in both if p not in keys), both[0])
    why = _why_not_numeric(model, key)
    if why is not None:
        raise InputError(where, why)
    near = validate.closest(key, keys, cutoff=0.75)
    hint = f" (did you mean {near}?)" if near else ""
    raise InputError(where, f"no numeric key {key!r} in this model{hint}; `valvelab model show` lists its keys")


# --------------------------------------------------------------------------- reading
def _number(value, where: str) -> float:
    """A standard uncertainty: a finite number, zero or more."""
    try:
        x = validate.number(value, where)
    except InputError:
        raise InputError(where, f"expected a non-negative number, got {value!r}") from None
    if x < 0.0:
        raise InputError(where, f"expected a non-negative number (a standard uncertainty), got {x:g}")
    return x


def parse_one(key: str, body, model, keys: dict | None = None) -> Uncertainty:
    """One declaration ``[uncertainty."KEY"]``, every field checked against ``model``."""
    where = f'uncertainty."{key}"'
    if not isinstance(body, dict):
        raise InputError(where, "expected a table with standard or relative, distribution and source")
    validate.keys(body, FIELDS, where)
    keys = numeric_keys(model) if keys is None else keys
    tg = targets(model, key, where, keys)
    given = [f for f in ("standard", "relative") if f in body]
    if len(given) != 1:
        raise InputError(f"{where}.standard", "give one of standard (in the key's units) or relative (to its value)"
                         + (", not both" if len(given) == 2 else ""))
    std = _number(body["standard"], f"{where}.standard") if "standard" in body else None
    rel = _number(body["relative"], f"{where}.relative") if "relative" in body else None
    if rel is not None:
        if rel >= 1.0:
            raise InputError(f"{where}.relative", f"expected a fraction of the key's value below 1, got {rel:g} "
                                                  "(is it in percent?)")
        zero = [p for p, v in tg if v == 0.0]
        if zero and rel > 0.0:
            raise InputError(f"{where}.relative", f"{zero[0]} is 0 in this model: a relative uncertainty of it is "
                                                  "0; give standard")
    dist = body.get("distribution")
    if dist is None:
        raise InputError(f"{where}.distribution", f"missing; expected one of {', '.join(DISTRIBUTIONS)}")
    if not isinstance(dist, str):
        raise InputError(f"{where}.distribution", f"expected one of {', '.join(DISTRIBUTIONS)}, got {dist!r}")
    validate.choice(dist, f"{where}.distribution", DISTRIBUTIONS)
    source = body.get("source")
    if not isinstance(source, str) or not source.strip():
        raise InputError(f"{where}.source", "missing; say where the number comes from (a section, a datasheet, "
                                            "an assumption)")
    scales = body.get("scales", {})
    if not isinstance(scales, dict):
        raise InputError(f"{where}.scales", "expected a table {KEY = exponent} of keys that follow this one")
    follow = []
    for k, e in flatten(scales).items():
        w = f"{where}.scales.\"{k}\""
        if k == key:
            raise InputError(w, "a key cannot follow itself")
        targets(model, k, w, keys)
        follow.append((k, validate.number(e, w, bounds=(-10.0, 10.0))))
    return Uncertainty(key=key, distribution=dist, source=source.strip(), standard=std, relative=rel,
                       scales=tuple(follow))


def parse_uncertainties(table, model, inherited: tuple = ()) -> tuple[Uncertainty, ...]:
    """The declarations of a model file's ``[uncertainty]`` table over ``inherited`` ones (a ``base``'s).

    ``[uncertainty."oil.air_content"]`` and ``[uncertainty.oil.air_content]`` are the same
    key. A declaration replaces an inherited one of the same key. An inherited declaration
    that no longer applies to ``model`` (its key is derived now, as a reed's kappa once the
    reed names a geometry) is dropped: nobody could delete it otherwise. InputError names the
    declaration and field of the file's own.
    """
    if table is None:
        table = {}
    if not isinstance(table, dict):
        raise InputError("uncertainty", 'expected tables [uncertainty."KEY.PATH"]')
    flat = flatten(table, leaf_keys=frozenset(FIELDS))
    keys = numeric_keys(model) if (flat or inherited) else {}
    own = {k: parse_one(k, body, model, keys) for k, body in flat.items()}
    out = []
    for u in inherited:
        if u.key in own:
            out.append(own.pop(u.key))
            continue
        try:
            out.append(parse_one(u.key, u.as_table(), model, keys))
        except InputError:
            continue
    out += list(own.values())
    shared = {}
    for u in out:
        for p, _ in targets(model, u.key, u.where, keys):
            if p in shared:
                raise InputError(u.where, f"{p} is also declared by uncertainty.\"{shared[p]}\"; declare it once")
            shared[p] = u.key
    return tuple(out)


def uncertainty_table(decls) -> dict:
    """{key: table} of the declarations, as ``[uncertainty]`` of a model file."""
    return {u.key: u.as_table() for u in decls}


# --------------------------------------------------------------------------- drawing
def standard_scores(decls, unit) -> "numpy.ndarray":  # noqa: F821
    """Standard scores z (mean 0, standard deviation 1) of points ``unit`` in [0, 1)^d, one column per
    declaration: the inverse CDF of its distribution (normal cut at :data:`NORMAL_CUT`; uniform
    sqrt(3) (2u - 1))."""
    import numpy as np
    from scipy.stats import norm

    u = np.atleast_2d(np.asarray(unit, dtype=float))
    z = np.empty_like(u)
    for j, d in enumerate(decls):
        if d.distribution == "normal":
            z[:, j] = np.clip(norm.ppf(np.clip(u[:, j], 1e-12, 1 - 1e-12)), -NORMAL_CUT, NORMAL_CUT)
        else:
            z[:, j] = math.sqrt(3.0) * (2.0 * u[:, j] - 1.0)
    return z


def sample_values(model, decls, z, keys: dict | None = None) -> dict[str, float]:
    """{key path: value} of one draw: declaration j at ``z[j]`` standard uncertainties, its followers
    scaled by (value / nominal)^exponent (the ratio of its first key for a both-valves key)."""
    keys = numeric_keys(model) if keys is None else keys
    out: dict[str, float] = {}
    factors: dict[str, float] = {}
    for d, zj in zip(decls, z):
        tg = targets(model, d.key, d.where, keys)
        ratio = None
        for path, nominal in tg:
            out[path] = d.value_at(nominal, float(zj))
            if ratio is None and nominal != 0.0:
                ratio = out[path] / nominal
        for k, e in d.scales:
            for path, _ in targets(model, k, d.where, keys):
                factors[path] = factors.get(path, 1.0) * (ratio if ratio is not None else 1.0) ** e
    for path, f in factors.items():
        out[path] = out.get(path, keys[path]) * f
    return out


def check_reach(model, decls=None) -> None:
    """Every draw of every declaration (the nominal +- its reach in standard uncertainties, followers
    included) inside the plausible range its key declares; InputError naming the declaration's
    ``standard`` or ``relative`` otherwise."""
    decls = model.uncertainties if decls is None else decls
    keys = numeric_keys(model)
    for d in decls:
        field = f"{d.where}.{'standard' if d.standard is not None else 'relative'}"
        for zsign in (-1.0, 1.0):
            z = [0.0] * len(decls)
            z[list(decls).index(d)] = zsign * REACH[d.distribution]
            for path, value in sample_values(model, decls, z, keys).items():
                _check_range(model, path, value, keys[path], field, d)


def _check_range(model, path: str, value: float, nominal: float, field: str, d: Uncertainty) -> None:
    comp, key = _component(model, path)
    spec = None
    if comp is not None:
        name = field_for_key(comp, key)
        spec = None if name is None else spec_of(type(comp), name)
    try:
        if spec is not None:
            check_value(value, spec, path)
        elif nominal > 0.0 and not value > 0.0:    # an effect's or a reed geometry's key: keep its sign
            raise InputError(path, f"expected a positive number, got {value:g}")
    except InputError as exc:
        raise InputError(field, f"a {d.distribution} draw {REACH[d.distribution]:g} standard uncertainties out "
                                f"gives {exc.field} = {value:g}, outside its plausible range ({exc.message}); "
                                "make the uncertainty smaller or the distribution uniform") from None
