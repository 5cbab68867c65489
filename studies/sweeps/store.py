"""Where a sweep's results go: one row per design, streamed to Parquet part files or appended CSV rows.

A sweep folder holds ``spec.toml``, the designs (``designs.parquet``, sampled once so that a
resume sees the very same list) and the results: Parquet part files under ``parts/`` (one per
finished batch, written hidden and renamed, so a kill leaves no half part) merged into
``results.parquet`` at the end, or ``results.csv`` flushed after each batch (a kill's partial
last line is cut off when the file is next read). Either store reads back as one pandas
DataFrame keyed and sorted by ``design_id``.
"""

from __future__ import annotations

import os
import shutil
import time
import uuid
from pathlib import Path

from geometry.errors import InputError
from studies.sweeps.schema import META_COLUMNS, value_kind
from studies.sweeps.sweep_spec import SweepSpec, load_model, load_spec

FORMATS = ("parquet", "csv")
SPEC_FILE = "spec.toml"
DESIGNS_FILE = "designs.parquet"
PARTS_DIR = "parts"


def _arrow_type(kind: str):
    """The pyarrow type of a column kind (``float64``, ``int64``, ``bool``, ``string``)."""
    import pyarrow as pa

    return {"float64": pa.float64(), "int64": pa.int64(), "bool": pa.bool_(), "string": pa.string()}[kind]


def table_schema(spec: SweepSpec, model):
    """The arrow schema of a sweep's results table.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    model : module
        Its sweep model (``OUTPUTS``: output column -> kind).

    Returns
    -------
    pyarrow.Schema
        ``design_id``, the inputs (factors then fixed), the outputs, ``status``, ``error``, ``eval_seconds``.
    """
    import pyarrow as pa

    cols = [("design_id", "int64")]
    for f in spec.factors:
        if f.is_range:
            kind = "int64" if f.integer else "float64"
        else:
            kinds = {value_kind(v) for v in f.values}
            kind = "float64" if kinds == {"int64", "float64"} else kinds.pop()
        cols.append((f.name, kind))
    cols += [(k, value_kind(v)) for k, v in spec.fixed]
    cols += list(model.OUTPUTS.items())
    cols += [(k, META_COLUMNS[k]) for k in ("status", "error", "eval_seconds")]
    return pa.schema([(n, _arrow_type(k)) for n, k in cols])


class ParquetStore:
    """Results as Parquet part files (one per finished batch), compacted into one file at the end.

    Parameters
    ----------
    folder : pathlib.Path
        The sweep folder.
    schema : pyarrow.Schema
        The results table's schema (:func:`table_schema`).
    """

    def __init__(self, folder: Path, schema):
        self.folder, self.schema = folder, schema
        self.final = folder / "results.parquet"
        self.parts = folder / PARTS_DIR

    def _tables(self):
        """The finished file and every part, read with the schema."""
        import pyarrow.parquet as pq

        files = sorted(self.parts.glob("*.parquet")) if self.parts.is_dir() else []
        if self.final.is_file():
            files = [self.final, *files]
        return [pq.read_table(f, schema=self.schema) for f in files]

    def read(self):
        """All rows recorded so far.

        Returns
        -------
        pandas.DataFrame
            One row per ``design_id``, sorted.
        """
        import pyarrow as pa

        tables = self._tables()
        df = (pa.concat_tables(tables) if tables else self.schema.empty_table()).to_pandas()
        return df.drop_duplicates("design_id").sort_values("design_id").reset_index(drop=True)

    def append(self, rows: list[dict]) -> None:
        """Write one finished batch as a part file.

        Parameters
        ----------
        rows : list of dict
            The batch's rows (:func:`studies.sweeps.sweep.evaluate_batch`).
        """
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.parts.mkdir(exist_ok=True)
        table = pa.Table.from_pylist(rows, schema=self.schema)
        name = f"part-{time.time_ns():020d}-{uuid.uuid4().hex[:8]}"
        # hidden while written: a kill leaves at most a dot-file, which pyarrow's folder reading
        # (pd.read_parquet("parts")) skips, and the rename makes the part appear whole
        tmp = self.parts / f".{name}.tmp"
        pq.write_table(table, tmp)
        os.replace(tmp, self.parts / f"{name}.parquet")

    def finish(self) -> Path:
        """Merge the parts into ``results.parquet`` (atomically) and remove them.

        Returns
        -------
        pathlib.Path
            ``results.parquet``.
        """
        import pyarrow as pa
        import pyarrow.parquet as pq

        df = self.read()
        tmp = self.folder / "results.parquet.tmp"
        pq.write_table(pa.Table.from_pandas(df, schema=self.schema, preserve_index=False), tmp)
        os.replace(tmp, self.final)
        if self.parts.is_dir():
            shutil.rmtree(self.parts)
        return self.final

    def clear(self) -> None:
        """Remove every result (a sweep started over)."""
        self.final.unlink(missing_ok=True)
        if self.parts.is_dir():
            shutil.rmtree(self.parts)
        for tmp in self.folder.glob("*.tmp"):
            tmp.unlink()


class CsvStore:
    """Results appended to ``results.csv`` row by row (flushed after each batch).

    Parameters
    ----------
    folder : pathlib.Path
        The sweep folder.
    schema : pyarrow.Schema
        The results table's schema (:func:`table_schema`): the columns and their types.
    """

    def __init__(self, folder: Path, schema):
        self.folder, self.schema = folder, schema
        self.final = folder / "results.csv"

    def _repair(self) -> None:
        """Cut off a partial last line (a kill during a write)."""
        if not self.final.is_file():
            return
        data = self.final.read_bytes()
        if data and not data.endswith(b"\n"):
            with open(self.final, "r+b") as fh:
                fh.truncate(data.rfind(b"\n") + 1)

    def read(self):
        """All rows recorded so far.

        Returns
        -------
        pandas.DataFrame
            One row per ``design_id``, sorted, typed by the schema (nullable integers and booleans).
        """
        import pandas as pd

        self._repair()
        names = self.schema.names
        if not self.final.is_file() or self.final.stat().st_size == 0:
            return pd.DataFrame({n: pd.Series(dtype=object) for n in names})
        dtypes = {}
        for fld in self.schema:
            dtypes[fld.name] = {"int64": "Int64", "double": "float64", "bool": "boolean"}.get(str(fld.type), "string")
        df = pd.read_csv(self.final, dtype=dtypes, keep_default_na=False, na_values=[""])
        return df.drop_duplicates("design_id").sort_values("design_id").reset_index(drop=True)

    def append(self, rows: list[dict]) -> None:
        """Append one finished batch and flush it to disk.

        Parameters
        ----------
        rows : list of dict
            The batch's rows (None written as an empty cell).
        """
        import csv

        self._repair()
        new = not self.final.is_file() or self.final.stat().st_size == 0
        with open(self.final, "a", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=self.schema.names, extrasaction="ignore")
            if new:
                w.writeheader()
            w.writerows([{k: ("" if v is None else v) for k, v in r.items()} for r in rows])
            fh.flush()
            os.fsync(fh.fileno())

    def finish(self) -> Path:
        """The results file (already complete: rows are appended as they come).

        Returns
        -------
        pathlib.Path
            ``results.csv``.
        """
        return self.final

    def clear(self) -> None:
        """Remove every result (a sweep started over)."""
        self.final.unlink(missing_ok=True)


def status_counts(df) -> dict:
    """How many rows of a results table have each status.

    Parameters
    ----------
    df : pandas.DataFrame or None
        A results table (a ``status`` column).

    Returns
    -------
    dict
        {status: count} ({} for an empty table).
    """
    if df is None or not len(df):
        return {}
    return {str(k): int(v) for k, v in df["status"].value_counts().items()}


def open_store(folder: Path, spec: SweepSpec, model, fmt: str):
    """The results store of a sweep folder.

    Parameters
    ----------
    folder : pathlib.Path
        The sweep folder.
    spec : SweepSpec
        The sweep.
    model : module
        Its sweep model.
    fmt : str
        ``parquet`` or ``csv``.

    Returns
    -------
    ParquetStore or CsvStore
    """
    if fmt not in FORMATS:
        raise InputError("--format", f"expected one of {', '.join(FORMATS)}, got {fmt!r}")
    schema = table_schema(spec, model)
    return (ParquetStore if fmt == "parquet" else CsvStore)(folder, schema)


def read_results(folder: str | Path):
    """The results of a sweep folder (finished or not), and its spec.

    Parameters
    ----------
    folder : str or os.PathLike
        A sweep folder (with its ``spec.toml``).

    Returns
    -------
    results : pandas.DataFrame
        One row per recorded design.
    spec : SweepSpec
    """
    folder = Path(folder)
    if not (folder / SPEC_FILE).is_file():
        raise InputError(str(folder), f"not a sweep folder (no {SPEC_FILE})")
    spec = load_spec(folder / SPEC_FILE)
    model = load_model(spec.model)
    fmt = "csv" if (folder / "results.csv").is_file() else "parquet"
    return open_store(folder, spec, model, fmt).read(), spec
