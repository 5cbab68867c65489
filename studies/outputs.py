"""Writing results without overwriting anything a user wrote.

Files and folders valvelab creates carry a marker so a later run may replace them;
anything else that already exists is refused unless the user passes ``--force``.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from geometry.errors import InputError

MARKER = ".valvelab-output"
#: the marker's first words, then the kind of output (``written by valvelab sweep; ...``)
_MARKER_HEAD = "written by valvelab"


def output_kind(folder: str | Path) -> str | None:
    """The kind of valvelab output a folder holds (``sweep``, ``dataset``, ...), from its marker; None if it has
    no marker or an old one that does not say."""
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
    """InputError when two outputs of one command are the same path ({flag: path}), or an output is one of
    the command's input files ({name: path}): one would replace or mix with the other. None paths are skipped."""
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


def finite_or_none(x) -> float | None:
    """``x`` as a float for a table or JSON, None if it is missing, not a number or not finite."""
    if x is None:
        return None
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def check_inputs_outside(folder, field: str, inputs: dict, own: tuple[str, ...] = ()) -> None:
    """InputError when an input file ({name: path}) lies in the output ``folder`` (its results would mix with
    the command's inputs, or replace them); ``own``: file names in ``folder`` that a rerun reads back (the
    study's own spec copy) and may stay there."""
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
    """``path`` as a Path, after checking it may be written: its folder exists and is writable, it is
    not a folder, and no user file is there (unless ``force``). Call it before any computation."""
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
    """``path`` as a Path after checking a valvelab output folder may go there (nothing created yet).

    ``kind`` (``sweep``, ``dataset``, ...): a folder holding valvelab output of another kind is refused
    unless ``force`` (a sweep written into a dataset would mix with it)."""
    if not str(path).strip():
        raise InputError(field, "expected a folder name, got an empty one")
    p = Path(path)
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


def prepare_output_dir(path: str | Path, field: str, force: bool = False, kind: str | None = None) -> Path:
    """Create (or reuse) a valvelab output folder; refuse a non-empty folder valvelab did not make (or one of
    another ``kind``, see :func:`check_output_dir`). The marker names the kind."""
    p = check_output_dir(path, field, force, kind)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(field, f"{p} cannot be created ({exc.strerror})") from None
    what = f"{_MARKER_HEAD} {kind}" if kind else _MARKER_HEAD
    (p / MARKER).write_text(f"{what}; files here may be replaced by the next run\n")
    return p


def format_cell(v, missing: str = "-") -> str:
    """One table cell: floats to 6 significant figures, None as ``missing``."""
    if v is None:
        return missing
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


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
        """A Table from a table function's result: a list of rows or ``{"rows", "notes"}``."""
        if isinstance(result, dict):
            return Table(title, tuple(result["rows"]), tuple(result.get("notes", ())), id)
        return Table(title, tuple(result), (), id)

    @property
    def columns(self) -> list[str]:
        cols: list[str] = []
        for row in self.rows:
            cols += [k for k in row if k not in cols]
        return cols

    def to_frame(self):
        """pandas DataFrame of the rows (missing cells NaN/None)."""
        import pandas as pd

        return pd.DataFrame(list(self.rows), columns=self.columns)

    def to_markdown(self) -> str:
        """A Markdown table under a ``#`` title, the notes as a list after it."""
        cols = self.columns
        lines = [f"# {self.title}", "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
        lines += ["| " + " | ".join(format_cell(r.get(k), missing="") for k in cols) + " |" for r in self.rows]
        if self.notes:
            lines += [""] + [f"- {n}" for n in self.notes]
        return "\n".join(lines) + "\n"

    def to_text(self) -> str:
        """Aligned plain-text columns (the command line's readable output)."""
        cols = self.columns
        cells = [[format_cell(row.get(c)) for c in cols] for row in self.rows]
        widths = [max(len(c), *(len(x[i]) for x in cells)) for i, c in enumerate(cols)]
        out = [self.title, "  ".join(c.ljust(w) for c, w in zip(cols, widths)), "  ".join("-" * w for w in widths)]
        out += ["  ".join(x.ljust(w) for x, w in zip(line, widths)) for line in cells]
        out += [f"note: {n}" for n in self.notes]
        return "\n".join(out)

    def write(self, stem: Path) -> list[Path]:
        """Write ``stem.csv`` and ``stem.md``; returns both paths."""
        cols = self.columns
        csv_path, md_path = Path(stem).with_suffix(".csv"), Path(stem).with_suffix(".md")
        with open(csv_path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=cols)
            w.writeheader()
            for r in self.rows:
                w.writerow({k: format_cell(r.get(k), missing="") for k in cols})
        md_path.write_text(self.to_markdown())
        return [csv_path, md_path]
