"""Measured (or simulated) pump runs on disk: read, validate, write (CONTRACT.md, "Measured data").

A run is a folder with ``run.toml`` and optionally ``trace.csv``; a dataset is a folder
of run folders (any names; other files are ignored) or a single run folder. Every
check names the file, the line and the field, so the command line exits 2 with one
line a user can act on ("trace.csv, line 17, valve_position_m: 2 m is not a valve
position ...").

Extension (documented in CONTRACT.md): ``measured_valve = "both"`` with the columns
``inlet_position_m`` and ``delivery_position_m`` in trace.csv (what a simulated run
written by valvelab carries), so both valves' positions can be used where measured.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd
import tomli_w

from geometry import validate
from geometry.errors import InputError
from lumped.run.trace import Trace

from studies.outputs import check_new_file, prepare_output_dir

MEASURED_VALVES = ("inlet", "delivery", "both")
POSITION_COLUMNS = {"inlet": "inlet_position_m", "delivery": "delivery_position_m"}
REQUIRED_RUN_KEYS = ("valve_type", "speed_rpm", "load_pressure_pa")
KNOWN_RUN_KEYS = {
    "valve_type", "measured_valve", "speed_rpm", "load_pressure_pa",
    "delivery_cc_per_rev", "air_content", "model",
    "delivery_uncertainty_cc", "position_uncertainty_rel",      # u_D, standard (CONTRACT.md)
}

# Plausibility limits that catch unit mistakes (a position in mm written as m, a
# pressure in MPa written as Pa); generous enough for any check valve in a pump.
MAX_POSITION_M = 0.02          # a check valve lift or seat compression is millimetres
MAX_PRESSURE_PA = 1.0e8        # 1000 bar
MIN_LOAD_PRESSURE_PA = 1.0e4   # below 0.1 bar absolute a pump cannot deliver
MAX_PRESSURE_TRACE_PA = 1.0e8
MIN_PRESSURE_PEAK_PA = 1.0e3   # a pump pressure trace peaking below 1 kPa is not in Pa
MAX_NOISE_BELOW_VACUUM_PA = 5.0e4   # a cavitating cylinder reads ~0 Pa absolute plus sensor noise;
                                    # a gauge trace would read down to -1e5 Pa
SPEED_RANGE_RPM = (10.0, 20000.0)
#: a stated standard uncertainty of the delivery at least this fraction of it says nothing (and is likely a slip)
MAX_DELIVERY_UNCERTAINTY_REL = 0.5
#: a pressure trace whose peak is below this fraction of the run's load pressure is in another unit (kPa, bar):
#: the cylinder reaches the load to deliver, the load line holds it
MIN_PEAK_TO_LOAD = 0.1
#: a measured valve whose largest |position| stays below this barely moves (possible: a valve that never
#: opens), or its positions are in km or 1000 times too small: a warning
MIN_POSITION_PEAK_M = 1e-5
MIN_SAMPLES_PER_REV = 90       # coarser than 4 crank degrees cannot time valve events
WHOLE_REV_TOLERANCE = 0.02     # fraction of a revolution (plus one sample)
UNIFORM_DT_TOLERANCE = 0.01    # relative deviation of a time step from the median


@dataclass(frozen=True)
class Run:
    """One pump run: operating condition, what was measured, optional trace."""

    name: str
    valve_type: str
    speed_rpm: float
    load_pressure_pa: float
    measured_valve: str | None = None
    delivery_cc_per_rev: float | None = None
    air_content: float | None = None
    trace: Trace | None = None
    path: Path | None = None
    extra: dict = field(default_factory=dict)  # other run.toml keys, kept when rewriting
    model: str | None = None                    # run.toml's model file (relative to the run folder)
    delivery_uncertainty_cc: float | None = None    # stated standard uncertainty of the delivery [cc/rev]
    position_uncertainty_rel: float | None = None   # stated standard uncertainty of positions, relative

    @property
    def period_s(self) -> float:
        """Duration of one revolution [s]."""
        return 60.0 / self.speed_rpm

    @property
    def delivery_m3_per_rev(self) -> float | None:
        """Measured delivery per revolution at atmospheric pressure [m^3]."""
        return None if self.delivery_cc_per_rev is None else self.delivery_cc_per_rev * 1e-6

    @property
    def measured_valves(self) -> tuple[str, ...]:
        """Valves whose position the trace holds."""
        return tuple(self.trace.positions) if self.trace is not None else ()


@cache
def swept_volume_m3() -> float:
    """Piston swept volume 2 A_p r [m^3] of the thesis pump (thesis-disc, Table 5.1)."""
    from lumped.model.model_file import load_model

    return load_model("thesis-disc").pump.displacement


def valve_types() -> tuple[str, ...]:
    """Accepted run.toml valve types: every registered kind, and mixed "<inlet>/<delivery>" labels."""
    from lumped.valves.kind import KINDS

    kinds = tuple(KINDS)
    return kinds + tuple(f"{a}/{b}" for a in kinds for b in kinds if a != b)


# --------------------------------------------------------------------------- reading


def _num(table: dict, key: str, where: str, required: bool) -> float | None:
    if key not in table:
        if required:
            raise InputError(f"{where}: {key}", "missing; expected a number in SI units")
        return None
    return validate.number(table[key], f"{where}: {key}")


def parse_run_toml(data: dict, where: str) -> dict:
    """Validated run.toml fields (SI); ``where`` names the file in messages."""
    out: dict = {}
    validate.keys(data, sorted(KNOWN_RUN_KEYS), where, sep=": ")
    vt = data.get("valve_type")
    if vt not in valve_types():
        raise InputError(f"{where}: valve_type", f"expected one of {', '.join(valve_types())}, got {vt!r}")
    out["valve_type"] = vt
    mv = data.get("measured_valve")
    if mv is not None and mv not in MEASURED_VALVES:
        raise InputError(f"{where}: measured_valve", f"expected one of {', '.join(MEASURED_VALVES)}, got {mv!r}")
    out["measured_valve"] = mv

    rpm = _num(data, "speed_rpm", where, True)
    if not SPEED_RANGE_RPM[0] <= rpm <= SPEED_RANGE_RPM[1]:
        hint = " (is it in rev/s or rad/s?)" if 0 < rpm < SPEED_RANGE_RPM[0] else ""
        raise InputError(
            f"{where}: speed_rpm",
            f"{rpm:g} rpm is not a pump speed; expected {SPEED_RANGE_RPM[0]:g}-{SPEED_RANGE_RPM[1]:g} rpm{hint}",
        )
    out["speed_rpm"] = rpm

    p = _num(data, "load_pressure_pa", where, True)
    if not MIN_LOAD_PRESSURE_PA <= p <= MAX_PRESSURE_PA:
        hint = " (is it in MPa or bar?)" if 0 < p < MIN_LOAD_PRESSURE_PA else ""
        raise InputError(
            f"{where}: load_pressure_pa",
            f"{p:g} Pa is not a load pressure; expected {MIN_LOAD_PRESSURE_PA:g}-{MAX_PRESSURE_PA:g} Pa{hint}",
        )
    out["load_pressure_pa"] = p

    out.update(_delivery_fields(data, where))
    out["extra"] = {}
    return out


def _delivery_fields(data: dict, where: str) -> dict:
    """run.toml's model, measured delivery [cc/rev], air content [-] and stated standard uncertainties, checked."""
    out: dict = {}
    d = _num(data, "delivery_cc_per_rev", where, False)
    model = data.get("model")
    if model is not None and not isinstance(model, str):
        raise InputError(f"{where}: model", f"expected a model file path (relative to the run folder), got {model!r}")
    out["model"] = model
    if d is not None:
        if model is None:                     # the thesis pump; a named model is checked when it is loaded
            check_delivery(d, swept_volume_m3(), f"{where}: delivery_cc_per_rev")
        elif not d > 0:
            raise InputError(f"{where}: delivery_cc_per_rev", f"must be positive, got {d:g}")
    out["delivery_cc_per_rev"] = d

    r = _num(data, "air_content", where, False)
    if r is not None and not 0.0 <= r < 0.5:
        hint = " (is it in percent?)" if r >= 0.5 else ""
        raise InputError(f"{where}: air_content", f"{r:g} is not a volume fraction of air; expected 0 <= R < 0.5{hint}")
    out["air_content"] = r
    # stated measurement uncertainties (standard; studies/validation/measurement.py)
    for key, hi in (("delivery_uncertainty_cc", math.inf), ("position_uncertainty_rel", 0.5)):
        u = _num(data, key, where, False)
        if u is not None and not 0.0 <= u < hi:
            what = "of 0 or more" if math.isinf(hi) else f"from 0 to below {hi:g}"
            raise InputError(f"{where}: {key}", f"expected a standard uncertainty {what}, got {u:g}"
                             + (" (is it in percent?)" if u >= hi else ""))
        out[key] = u
    u, d = out["delivery_uncertainty_cc"], out["delivery_cc_per_rev"]
    if u is not None and d is not None and not u < MAX_DELIVERY_UNCERTAINTY_REL * d:
        raise InputError(f"{where}: delivery_uncertainty_cc", f"{u:g} cc/rev is {u / d:.3g} times the measured "
                         f"delivery {d:g} cc/rev; a standard uncertainty is below {MAX_DELIVERY_UNCERTAINTY_REL:g} of "
                         "it (as for position_uncertainty_rel)")
    return out


def check_delivery(d_cc: float, swept_m3: float, field: str) -> None:
    """A measured delivery [cc/rev] must be 1-110 % of the pump's swept volume (catches unit slips)."""
    vmax = 1.1 * swept_m3 * 1e6
    if not 0.01 * vmax < d_cc <= vmax:
        hint = " (is it in m^3 or L?)" if 0 < d_cc < 1e-3 else ""
        raise InputError(field, f"{d_cc:g} cc/rev is not a delivery of this pump (swept volume "
                                f"{vmax / 1.1:.3g} cc/rev){hint}")


def _csv_line(row_index: int) -> int:
    """File line number of a data row (line 1 is the header)."""
    return int(row_index) + 2


#: the columns trace.csv may hold (CONTRACT.md); other columns are ignored unless they look like a typo of one
TRACE_COLUMNS = ("time_s", "valve_position_m", "cylinder_pressure_pa", "load_pressure_pa",
                 "inlet_position_m", "delivery_position_m")


def _check_header(text: str, where: str) -> None:
    """Refuse a duplicated column, and an extra column that is a near-miss of a known one (a typo
    would otherwise drop the data silently: CONTRACT.md ignores extra columns)."""
    import csv

    first = next(csv.reader([text.splitlines()[0] if text.strip() else ""]), [])
    names = validate.columns(first, where) if first else []
    for n in names:
        if n not in TRACE_COLUMNS:
            near = validate.closest(n, TRACE_COLUMNS, cutoff=0.85)
            if near and near not in names:
                raise InputError(f"{where}, {n}", f"unknown column (did you mean {near}?); expected some of "
                                                  + ", ".join(TRACE_COLUMNS))


def _read_table(path: Path, where: str) -> pd.DataFrame:
    """trace.csv as a table of strings with stripped column names and a time_s column (InputError otherwise)."""
    _check_header(validate.read_text(path, where), where)
    try:
        df = pd.read_csv(path, dtype=str, skipinitialspace=True, keep_default_na=False)
    except pd.errors.EmptyDataError:
        raise InputError(where, "empty file; expected a header row and data rows") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise InputError(where, f"not a comma-separated table ({str(exc).splitlines()[0]})") from None
    df.columns = [c.strip() for c in df.columns]
    if len(df) == 0:
        raise InputError(where, "no data rows below the header")
    if "time_s" not in df.columns:
        raise InputError(f"{where}: time_s", f"missing column; found columns {', '.join(df.columns)}")
    return df


def _position_columns(df: pd.DataFrame, path: Path, measured_valve: str | None) -> list[str]:
    """The position columns run.toml's ``measured_valve`` asks for, present in the table."""
    where = str(path)
    if measured_valve == "both":
        needed = list(POSITION_COLUMNS.values())
    elif measured_valve in POSITION_COLUMNS:
        needed = ["valve_position_m"]
        if "valve_position_m" not in df.columns and POSITION_COLUMNS[measured_valve] in df.columns:
            needed = [POSITION_COLUMNS[measured_valve]]
    else:
        raise InputError(
            f"{path.parent / 'run.toml'}: measured_valve",
            "missing; a run with trace.csv must say whose position it holds (inlet, delivery or both)",
        )
    for col in needed:
        if col not in df.columns:
            raise InputError(f"{where}: {col}", f"missing column; found columns {', '.join(df.columns)}")
    return needed


def _column(df: pd.DataFrame, name: str, where: str) -> np.ndarray:
    """A numeric column; InputError naming the line of the first empty or non-numeric cell."""
    raw = df[name]
    vals = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(vals))
    if bad.size:
        i = bad[0]
        text = raw.iloc[i]
        what = "empty" if text.strip() == "" else f"{text!r} is not a finite number"
        raise InputError(f"{where}, line {_csv_line(i)}, {name}", what)
    return vals


def _check_time(t: np.ndarray, where: str, speed_rpm: float) -> None:
    """Time increasing, uniformly sampled from top dead centre, at least MIN_SAMPLES_PER_REV per revolution, and
    whole revolutions at ``speed_rpm``."""
    if t.size < 3:
        raise InputError(f"{where}: time_s", f"only {t.size} rows; expected at least one revolution of samples")
    dt = np.diff(t)
    nonmono = np.flatnonzero(dt <= 0)
    if nonmono.size:
        i = nonmono[0] + 1
        raise InputError(f"{where}, line {_csv_line(i)}, time_s",
                         f"time {t[i]:.9g} s does not increase (previous row {t[i - 1]:.9g} s)")
    step = float(np.median(dt))
    if abs(t[0]) > 1.5 * step:
        raise InputError(f"{where}, line 2, time_s",
                         f"the trace starts at {t[0]:.6g} s; time zero is top dead centre (CONTRACT.md): "
                         "subtract the time of the first TDC")
    irregular = np.flatnonzero(np.abs(dt - step) > UNIFORM_DT_TOLERANCE * step)
    if irregular.size:
        i = irregular[0] + 1
        raise InputError(f"{where}, line {_csv_line(i)}, time_s",
                         f"non-uniform sampling: step {dt[i - 1]:.6g} s where the median step is {step:.6g} s "
                         "(resample to a uniform rate)")
    period = 60.0 / speed_rpm
    per_rev = period / step
    if per_rev < MIN_SAMPLES_PER_REV:
        raise InputError(f"{where}: time_s", f"{per_rev:.0f} samples per revolution at {speed_rpm:g} rpm; expected "
                                             f"at least {MIN_SAMPLES_PER_REV}")
    revs = (t.size * step) / period
    revs_closed = (t[-1] - t[0]) / period  # a file may repeat the first crank angle at its end
    whole = min(abs(revs - round(revs)), abs(revs_closed - round(revs_closed)))
    if round(revs) < 1 or whole > WHOLE_REV_TOLERANCE + 1.0 / per_rev:
        raise InputError(f"{where}: time_s",
                         f"covers {revs:.3f} revolutions at {speed_rpm:g} rpm; expected whole revolutions of cyclic "
                         "steady state (is speed_rpm right?)")


def _position(df: pd.DataFrame, col: str, where: str) -> np.ndarray:
    """A valve position column [m], refusing a value beyond MAX_POSITION_M (millimetres written as metres)."""
    x = _column(df, col, where)
    big = np.flatnonzero(np.abs(x) > MAX_POSITION_M)
    if big.size:
        i = big[0]
        hint = " (is it in mm?)" if abs(x[i]) < 50.0 else ""
        raise InputError(f"{where}, line {_csv_line(i)}, {col}",
                         f"{x[i]:g} m is not a valve position; expected |x| < {MAX_POSITION_M * 1e3:g} mm{hint}")
    return x


def _pressure(df: pd.DataFrame, col: str, where: str) -> np.ndarray | None:
    """An absolute pressure column [Pa] (None if absent), refusing MPa or bar written as Pa, a value beyond
    MAX_PRESSURE_TRACE_PA and a gauge pressure (below vacuum by more than sensor noise)."""
    if col not in df.columns:
        return None
    p = _column(df, col, where)
    big = np.flatnonzero(np.abs(p) > MAX_PRESSURE_TRACE_PA)
    if big.size:
        i = big[0]
        raise InputError(f"{where}, line {_csv_line(i)}, {col}",
                         f"{p[i]:g} Pa is above {MAX_PRESSURE_TRACE_PA:g} Pa; expected a pressure in Pa")
    i = int(np.argmax(np.abs(p)))
    if abs(p[i]) < MIN_PRESSURE_PEAK_PA:
        raise InputError(f"{where}, line {_csv_line(i)}, {col}",
                         f"the largest pressure is {p[i]:g} Pa; a pump pressure in Pa is ~1e6 (is it in MPa or bar?)")
    neg = np.flatnonzero(p < -MAX_NOISE_BELOW_VACUUM_PA)
    if neg.size:
        i = neg[0]
        raise InputError(f"{where}, line {_csv_line(i)}, {col}",
                         f"{p[i]:g} Pa is below vacuum by more than sensor noise; expected an absolute pressure in "
                         "Pa (a gauge pressure? add the atmospheric pressure)")
    return p


def read_trace(path: Path, measured_valve: str | None, speed_rpm: float,
               load_pressure_pa: float | None = None) -> tuple[Trace, str]:
    """Validated trace.csv; returns the trace and the measured valve(s) it holds. With the run's
    ``load_pressure_pa`` [Pa], a pressure column peaking below :data:`MIN_PEAK_TO_LOAD` of it is refused (kPa
    or bar)."""
    where = str(path)
    df = _read_table(path, where)
    needed = _position_columns(df, path, measured_valve)
    t = _column(df, "time_s", where)
    _check_time(t, where, speed_rpm)
    valves = ("inlet", "delivery") if measured_valve == "both" else (measured_valve,)
    positions = {valve: _position(df, col, where) for valve, col in zip(valves, needed)}
    cyl = _pressure(df, "cylinder_pressure_pa", where)
    load = _pressure(df, "load_pressure_pa", where)
    for col, p in (("cylinder_pressure_pa", cyl), ("load_pressure_pa", load)):
        if p is not None and load_pressure_pa is not None and np.max(p) < MIN_PEAK_TO_LOAD * load_pressure_pa:
            raise InputError(f"{where}: {col}", f"peaks at {np.max(p):g} Pa, {load_pressure_pa / np.max(p):.3g} "
                             f"times below the run's load pressure {load_pressure_pa:g} Pa (run.toml): a pump "
                             "pressure in Pa reaches the load (is it in kPa or bar?)")
    return Trace.measured(t, positions, cyl, load, speed_rpm), measured_valve


def read_run(folder: str | Path) -> Run:
    """One run folder (run.toml, optional trace.csv), validated."""
    folder = validate.path(folder, "folder")
    toml_path = folder / "run.toml"
    if not toml_path.is_file():
        raise InputError(str(folder), "not a run folder: no run.toml")
    data = validate.read_toml(toml_path, str(toml_path))
    fields = parse_run_toml(data, str(toml_path))
    trace = None
    csv = folder / "trace.csv"
    if os.path.lexists(csv) and not csv.exists():      # a link to nothing, or a loop: not "no trace"
        raise InputError(str(csv), "a symbolic link that leads to no file (dangling, or a loop); point it at the "
                                   "trace or remove it")
    if csv.exists():
        trace, _ = read_trace(csv, fields["measured_valve"], fields["speed_rpm"], fields["load_pressure_pa"])
    return Run(name=folder.name, trace=trace, path=folder, **fields)


def implausible(runs: list[Run]) -> list[dict]:
    """``implausible_input`` warnings ({"code", "message"}, lumped.validity) for measured data that is possible
    but likely a slip: a measured valve whose largest |position| stays below :data:`MIN_POSITION_PEAK_M` (a valve
    that never opens, or positions 1000 times too small)."""
    out = []
    for r in runs:
        for valve, x in (r.trace.positions.items() if r.trace is not None else ()):
            peak = float(np.max(np.abs(x))) if len(x) else 0.0
            if peak < MIN_POSITION_PEAK_M:
                out.append({"code": "implausible_input",
                            "message": f"{r.name}/trace.csv: the {valve} valve moves at most {peak * 1e6:.3g} um "
                                       f"(below {MIN_POSITION_PEAK_M * 1e6:g} um): it never opens, or the positions "
                                       "are not in m"})
    return out


def read_dataset(path: str | Path) -> list[Run]:
    """All runs of a dataset folder (or the one run of a run folder), sorted by folder name."""
    path = validate.path(path, "path")
    if not path.exists():
        raise InputError(str(path), "no such folder; expected a dataset folder of run folders or a run folder")
    if not path.is_dir():
        raise InputError(str(path), "not a folder; expected a dataset folder of run folders or a run folder")
    if (path / "run.toml").is_file():
        runs = [read_run(path)]
    else:
        runs = [read_run(p) for p in sorted(path.iterdir()) if p.is_dir() and (p / "run.toml").is_file()]
    if not runs:
        raise InputError(str(path), "no run folders (folders with run.toml) found")
    types = {r.valve_type for r in runs}
    if len(types) > 1:
        first = {t: next(r.name for r in runs if r.valve_type == t) for t in types}
        raise InputError(
            str(path),
            "mixes valve types (" + ", ".join(f"{t} in {n}" for t, n in sorted(first.items()))
            + "); a dataset holds one valve design",
        )
    return runs


# --------------------------------------------------------------------------- writing


def run_toml_dict(run: Run) -> dict:
    """The run.toml content of a run (None fields omitted; extra keys kept)."""
    d = {
        "valve_type": run.valve_type,
        "measured_valve": run.measured_valve,
        "speed_rpm": float(run.speed_rpm),
        "load_pressure_pa": float(run.load_pressure_pa),
        "delivery_cc_per_rev": None if run.delivery_cc_per_rev is None else float(run.delivery_cc_per_rev),
        "air_content": None if run.air_content is None else float(run.air_content),
        "model": run.model,
        "delivery_uncertainty_cc": run.delivery_uncertainty_cc,
        "position_uncertainty_rel": run.position_uncertainty_rel,
    }
    d = {k: v for k, v in d.items() if v is not None}
    d.update(run.extra)
    return d


def trace_frame(run: Run) -> pd.DataFrame:
    """trace.csv columns of a run: time_s, valve_position_m (or both positions), pressures."""
    tr = run.trace
    cols = {"time_s": tr.time_s}
    if run.measured_valve == "both":
        for valve, col in POSITION_COLUMNS.items():
            cols[col] = tr.positions[valve]
    else:
        cols["valve_position_m"] = tr.positions[run.measured_valve]
    if tr.cylinder_pressure_pa is not None:
        cols["cylinder_pressure_pa"] = tr.cylinder_pressure_pa
    if tr.load_pressure_pa is not None:
        cols["load_pressure_pa"] = tr.load_pressure_pa
    return pd.DataFrame(cols)


def write_run(folder: str | Path, run: Run, force: bool = False) -> Path:
    """Write a run folder (run.toml, trace.csv if the run has a trace); never over a user's files."""
    folder = prepare_output_dir(folder, str(folder), force=force, kind="run")
    (folder / "run.toml").write_text(tomli_w.dumps(run_toml_dict(run)))
    if run.trace is not None:
        if run.measured_valve is None:
            raise InputError(f"{folder}: measured_valve", "a run with a trace must name its measured valve")
        trace_frame(run).to_csv(folder / "trace.csv", index=False, float_format="%.9g")
    elif (folder / "trace.csv").exists():
        (folder / "trace.csv").unlink()
    return folder


def write_dataset(folder: str | Path, runs: list[Run], force: bool = False) -> Path:
    """Write runs as sub-folders named by ``Run.name`` of a dataset folder valvelab owns."""
    names = [r.name for r in runs]
    if len(set(names)) != len(names):
        raise InputError(str(folder), "run names must be unique")
    folder = prepare_output_dir(folder, str(folder), force=force, kind="dataset")
    for r in runs:
        write_run(folder / r.name, r, force=True)
    return folder


def with_trace(run: Run, trace: Trace | None) -> Run:
    """A copy of ``run`` with another trace."""
    return replace(run, trace=trace)


__all__ = [
    "Run", "Trace", "read_run", "read_dataset", "read_trace", "parse_run_toml",
    "write_run", "write_dataset", "run_toml_dict", "trace_frame", "swept_volume_m3",
    "check_new_file",
]
