"""Writing results without overwriting anything a user wrote.

Files and folders valvelab creates carry a marker so a later run may replace them;
anything else that already exists is refused unless the user passes ``--force``.
"""

from __future__ import annotations

import csv
import math
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from geometry.errors import InputError

MARKER = ".valvelab-output"
#: the marker's first words, then the kind of output (``written by valvelab sweep; ...``)
_MARKER_HEAD = "written by valvelab"


def output_kind(folder: str | Path) -> str | None:
    """The kind of valvelab output a folder holds, from its marker.

    Parameters
    ----------
    folder : str or os.PathLike

    Returns
    -------
    str or None
        ``sweep``, ``dataset``, ``sensitivity``, ...; for an old marker that does not say, what the
        folder's files tell; None without a marker.
    """
    try:
        text = (Path(folder) / MARKER).read_text()
    except OSError:
        return None
    head = text.split(";", 1)[0].split()
    if len(head) == 4 and " ".join(head[:3]) == _MARKER_HEAD:
        return head[3]
    return _guess_kind(Path(folder))


#: a file or folder that only one kind of output holds: what an old marker (naming no kind) is taken for
_SIGNATURES = ((".sweep-digest", "sweep"), ("truth.toml", "dataset"), ("run.toml", "run"), ("ranking.csv", "report"),
               ("summary.json", "validate"))


def _guess_kind(folder: Path) -> str | None:
    """The kind of an output folder marked before markers named it (None when nothing tells)."""
    stamp = folder / ".design-digest"
    if stamp.is_file():
        words = stamp.read_text().split()
        return words[1] if len(words) > 1 else None
    for name, kind in _SIGNATURES:
        if (folder / name).exists():
            return kind
    return None


def _resolved(p) -> Path:
    return Path(p).expanduser().resolve()


def check_distinct(outputs: dict, inputs: dict | None = None) -> None:
    """Refuse two outputs of one command on the same path, or an output on one of its input files.

    Parameters
    ----------
    outputs : dict
        {flag: path} of the outputs (None paths are skipped).
    inputs : dict, optional
        {name: path} of the input files.

    Raises
    ------
    InputError
        Naming the output flag: one would replace or mix with the other.
    """
    outs = [(f, _resolved(p)) for f, p in outputs.items() if p is not None and str(p).strip()]
    ins = [(n, _resolved(p)) for n, p in (inputs or {}).items() if p is not None and str(p).strip()
           and Path(p).exists()]
    for i, (f1, p1) in enumerate(outs):
        for f2, p2 in outs[i + 1:]:
            if p1 == p2:
                raise InputError(f2, f"is the same path as {f1} ({p2}); give each output its own path")
        for n, q in ins:
            if p1 == q:
                raise InputError(f1, f"is the input {n} ({q}); an input is never replaced: choose another path")


def _probe(folder: Path) -> str | None:
    """Why nothing can be written in ``folder`` (None if a file can be): a real write, not os.access,
    which says yes to root in a read-only folder and knows nothing of read-only file systems."""
    try:
        fd, name = tempfile.mkstemp(prefix=".valvelab-probe-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    try:
        os.unlink(name)
    except OSError:
        pass
    return None


def duration(seconds: float) -> str:
    """A wall time as people say it: ``40 s``, ``12 min``, ``2.5 h``.

    Parameters
    ----------
    seconds : float

    Returns
    -------
    str

    >>> duration(42.4), duration(754), duration(9000)
    ('42 s', '13 min', '2.5 h')
    """
    if seconds < 90:
        return f"{max(seconds, 1):.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


#: a computation estimated to take less than this is not announced [s]
ANNOUNCE_ABOVE_S = 5.0


def announce(command: str, what: str, seconds: float | None = None, basis: str = "measured per-unit costs",
             always: bool = False) -> str:
    """Say on stderr, before a long computation starts, what it runs and about how long it takes.

    Nothing is said of one estimated under :data:`ANNOUNCE_ABOVE_S` (unless ``always``).

    Parameters
    ----------
    command : str
        The command (``check``), named first.
    what : str
        What runs (counts and units: ``6 runs ... 3 revolutions each``).
    seconds : float, optional
        The estimate [s] (None: no estimate).
    basis : str
        Where the estimate comes from.

    always : bool
        Say it whatever the estimate (a part of the work is not estimated).

    Returns
    -------
    str
        The line written ("" when nothing is said).
    """
    if seconds is not None and seconds < ANNOUNCE_ABOVE_S and not always:
        return ""
    line = f"valvelab {command}: {what}"
    if seconds is not None:
        line += f"; about {duration(seconds)} on two cores ({basis})"
    sys.stderr.write(line + "\n")
    sys.stderr.flush()
    return line


def finite_or_none(x) -> float | None:
    """A value for a table or JSON: a float, or None if it is missing, not a number or not finite.

    Parameters
    ----------
    x : object

    Returns
    -------
    float or None

    Examples
    --------
    >>> finite_or_none(2), finite_or_none(float("nan")), finite_or_none("x")
    (2.0, None, None)
    """
    if x is None:
        return None
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def check_inputs_outside(folder, field: str, inputs: dict, own: tuple[str, ...] = ()) -> None:
    """Refuse an output folder that holds one of the command's input files (its results would mix with them).

    Parameters
    ----------
    folder : str or os.PathLike
        The output folder.
    field : str
        Its flag, named by the refusal.
    inputs : dict
        {name: path} of the input files (None or missing paths are skipped).
    own : tuple of str
        File names in ``folder`` that a rerun reads back (a study's own spec copy) and may stay there.
    """
    o = _resolved(folder)
    for name, p in inputs.items():
        if p is None or not str(p).strip() or not Path(p).is_file():
            continue
        q = _resolved(p)
        if q.parent == o and q.name in own:
            continue
        if o in q.parents:
            raise InputError(field, f"{folder} holds the input {name} ({p}); the outputs would mix with it: "
                                    "choose another folder (or move the input out)")


def check_new_file(path: str | Path, field: str, force: bool = False, writable: bool = True) -> Path:
    """Check that an output file may be written, before any computation.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    field : str
        Its flag, named by a refusal.
    force : bool
        Replace an existing file.
    writable : bool
        Also check with a real write that its folder takes files.

    Returns
    -------
    pathlib.Path
        ``path``: its folder exists and is writable, it is not a folder, and nothing is there unless ``force``.
    """
    if not str(path).strip():
        raise InputError(field, "expected a file name, got an empty one")
    p = Path(path)
    if p.is_dir():
        raise InputError(field, f"{p} is a folder; expected a file name")
    if p.exists() and not force:
        raise InputError(field, f"{p} already exists; refusing to overwrite it (pass --force to replace it)")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.exists():
        raise InputError(field, f"folder {parent} does not exist")
    if not parent.is_dir():
        raise InputError(field, f"{parent} is not a folder")
    if writable:
        why = _probe(parent)
        if why is not None or (p.exists() and not os.access(p, os.W_OK)):
            raise InputError(field, f"{p} cannot be written ({why or 'no write permission'})")
    return p


def check_output_dir(path: str | Path, field: str, force: bool = False, kind: str | None = None) -> Path:
    """Check that a valvelab output folder may go at a path (nothing is created yet).

    Parameters
    ----------
    path : str or os.PathLike
        The folder.
    field : str
        Its flag, named by a refusal.
    force : bool
        Accept a non-empty folder valvelab did not make, or one of another kind.
    kind : str, optional
        The output's kind (``sweep``, ``dataset``, ...): a folder holding valvelab output of another
        kind is refused unless ``force`` (a sweep written into a dataset would mix with it).

    Returns
    -------
    pathlib.Path
    """
    if not str(path).strip():
        raise InputError(field, "expected a folder name, got an empty one")
    p = Path(path)
    if kind != "run":
        _outside_data(p, field)
    if p.exists():
        if not p.is_dir():
            raise InputError(field, f"{p} exists and is not a folder")
        if any(p.iterdir()) and not (p / MARKER).exists() and not force:
            raise InputError(
                field, f"{p} is a non-empty folder valvelab did not create; choose another (or pass --force)"
            )
        other = output_kind(p)
        if kind is not None and other is not None and other != kind and not force:
            raise InputError(field, f"{p} holds valvelab {other} output; choose another folder for the {kind} "
                                    "(or pass --force)")
        why = _probe(p)
        if why is not None:
            raise InputError(field, f"{p} cannot be written ({why})")
        return p
    anc = p.parent
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        raise InputError(field, f"{p} cannot be created: {anc} is not a folder")
    why = _probe(anc)
    if why is not None:
        raise InputError(field, f"{p} cannot be created: nothing can be written in {anc} ({why})")
    return p


#: output kinds that are a user's data: no other output goes inside them
DATA_KINDS = ("dataset", "run")


def _outside_data(p: Path, field: str) -> None:
    """Refuse an output folder inside a dataset or a run folder (a valvelab marker of a data kind, or a run.toml
    beside it): the output would mix with the measurements, even with ``--force``."""
    for anc in _resolved(p).parents:
        if output_kind(anc) in DATA_KINDS or (anc / "run.toml").is_file():
            raise InputError(field, f"{p} lies inside the dataset or run folder {anc}; outputs never go into a "
                                    "user's data: choose a folder outside it")


def prepare_output_dir(path: str | Path, field: str, force: bool = False, kind: str | None = None) -> Path:
    """Create (or reuse) a valvelab output folder, marked with its kind.

    Parameters
    ----------
    path : str or os.PathLike
        The folder.
    field : str
        Its flag, named by a refusal.
    force : bool
        See :func:`check_output_dir`.
    kind : str, optional
        The output's kind, written in the marker.

    Returns
    -------
    pathlib.Path
    """
    p = check_output_dir(path, field, force, kind)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(field, f"{p} cannot be created ({exc.strerror})") from None
    what = f"{_MARKER_HEAD} {kind}" if kind else _MARKER_HEAD
    (p / MARKER).write_text(f"{what}; files here may be replaced by the next run\n")
    return p


def format_cell(v, missing: str = "-") -> str:
    """One table cell as text: a float to 6 significant figures, None as ``missing``.

    Parameters
    ----------
    v : object
    missing : str

    Returns
    -------
    str

    Examples
    --------
    >>> format_cell(2.7612345e6), format_cell(None)
    ('2.76123e+06', '-')
    """
    if v is None:
        return missing
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def format_column(values, missing: str = "-") -> list[str]:
    """A table column's cells as text, every number of it to the same decimals.

    Each float keeps 6 significant figures (:func:`format_cell`); a column whose floats all print
    without an exponent gives every one of them the most decimals any needs, so that a value of
    the column is never shown to fewer digits than its neighbours (1.72600 beside 1.70637, not
    1.726). A column with a number in exponent form keeps :func:`format_cell`'s.

    Parameters
    ----------
    values : sequence
    missing : str

    Returns
    -------
    list of str

    Examples
    --------
    >>> format_column([1.726, 1.70637, None, 2.0])
    ['1.72600', '1.70637', '-', '2.00000']
    >>> format_column([2.76e6, 0.013, "inlet"])
    ['2.76e+06', '0.013', 'inlet']
    """
    cells = [format_cell(v, missing) for v in values]
    floats = [(i, c) for i, (v, c) in enumerate(zip(values, cells)) if isinstance(v, float) and math.isfinite(v)]
    if not floats or any("e" in c for _, c in floats):
        return cells
    decimals = max(len(c.split(".")[1]) if "." in c else 0 for _, c in floats)
    for i, _ in floats:
        cells[i] = f"{values[i]:.{decimals}f}"
    return cells


def _columns(rows, cols, missing: str) -> list[list[str]]:
    """The rows' cells as text, column by column (:func:`format_column`), back as rows."""
    by_col = [format_column([r.get(c) for r in rows], missing) for c in cols]
    return [list(cells) for cells in zip(*by_col)] if cols else [[] for _ in rows]


@dataclass(frozen=True)
class Table:
    """A table of rows (dicts, SI values) with notes: what ``valvelab table``, ``validate`` and the
    reports print and write. Columns are the keys in first-seen order."""

    title: str
    rows: tuple[dict, ...]
    notes: tuple[str, ...] = ()
    id: str | None = None

    @staticmethod
    def of(result, title: str, id: str | None = None) -> "Table":
        """A Table from a table function's result.

        Parameters
        ----------
        result : list of dict or dict
            The rows, or ``{"rows", "notes"}``.
        title : str
        id : str, optional
            The table's id (``5.4``).

        Returns
        -------
        Table
        """
        if isinstance(result, dict):
            return Table(title, tuple(result["rows"]), tuple(result.get("notes", ())), id)
        return Table(title, tuple(result), (), id)

    @property
    def columns(self) -> list[str]:
        """The columns: every row's keys, in first-seen order."""
        cols: list[str] = []
        for row in self.rows:
            cols += [k for k in row if k not in cols]
        return cols

    def to_frame(self):
        """The rows as a DataFrame.

        Returns
        -------
        pandas.DataFrame
            Missing cells NaN or None.
        """
        import pandas as pd

        return pd.DataFrame(list(self.rows), columns=self.columns)

    def to_markdown(self) -> str:
        """The table in Markdown.

        Returns
        -------
        str
            A ``#`` title, the table, the notes as a list after it.
        """
        cols = self.columns
        lines = [f"# {self.title}", "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
        lines += ["| " + " | ".join(cells) + " |" for cells in _columns(self.rows, cols, "")]
        if self.notes:
            lines += [""] + [f"- {n}" for n in self.notes]
        return "\n".join(lines) + "\n"

    def to_text(self) -> str:
        """The table as aligned plain-text columns (the command line's readable output).

        Returns
        -------
        str
        """
        cols = self.columns
        cells = _columns(self.rows, cols, "-")
        widths = [max(len(c), *(len(x[i]) for x in cells)) for i, c in enumerate(cols)]
        out = [self.title, "  ".join(c.ljust(w) for c, w in zip(cols, widths)), "  ".join("-" * w for w in widths)]
        out += ["  ".join(x.ljust(w) for x, w in zip(line, widths)) for line in cells]
        out += [f"note: {n}" for n in self.notes]
        return "\n".join(out)

    def write(self, stem: Path) -> list[Path]:
        """Write the table as CSV and Markdown.

        Parameters
        ----------
        stem : pathlib.Path
            The files' path without suffix.

        Returns
        -------
        list of pathlib.Path
            ``stem.csv`` and ``stem.md``.
        """
        cols = self.columns
        csv_path, md_path = Path(stem).with_suffix(".csv"), Path(stem).with_suffix(".md")
        with open(csv_path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=cols)
            w.writeheader()
            for cells in _columns(self.rows, cols, ""):
                w.writerow(dict(zip(cols, cells)))
        md_path.write_text(self.to_markdown())
        return [csv_path, md_path]
