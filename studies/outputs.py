"""Writing results without overwriting anything a user wrote.

Files and folders valvelab creates carry a marker so a later run may replace them;
anything else that already exists is refused unless the user passes ``--force``.
"""

from __future__ import annotations

from pathlib import Path

from geometry.errors import InputError

MARKER = ".valvelab-output"


def check_new_file(path: str | Path, field: str, force: bool = False) -> Path:
    """``path`` as a Path, after checking it may be written (its folder exists, no user file there)."""
    p = Path(path)
    if p.exists() and not force:
        raise InputError(field, f"{p} already exists; refusing to overwrite it (pass --force to replace it)")
    if not p.parent.exists():
        raise InputError(field, f"folder {p.parent} does not exist")
    return p


def prepare_output_dir(path: str | Path, field: str, force: bool = False) -> Path:
    """Create (or reuse) a valvelab output folder; refuse a non-empty folder valvelab did not make."""
    p = Path(path)
    if p.exists():
        if not p.is_dir():
            raise InputError(field, f"{p} exists and is not a folder")
        if any(p.iterdir()) and not (p / MARKER).exists() and not force:
            raise InputError(
                field, f"{p} is a non-empty folder valvelab did not create; choose another (or pass --force)"
            )
    p.mkdir(parents=True, exist_ok=True)
    (p / MARKER).write_text("written by valvelab; files here may be replaced by the next run\n")
    return p


def format_cell(v, missing: str = "-") -> str:
    """One table cell: floats to 6 significant figures, None as ``missing``."""
    if v is None:
        return missing
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
