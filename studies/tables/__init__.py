"""The thesis's tables regenerated: computed values beside the printed ones.

:func:`registry` is the typed list of tables (id -> :class:`ThesisTable`); a table function
takes no arguments and returns a list of row dicts (the thesis's value of ``field`` in
``thesis_field``, from ``studies/data/thesis_values.toml``) or a dict with ``rows`` and
``notes``. Adding a table: a function in the module of its chapter and one line below.
The modules are imported when the registry is asked for (the FEA ones import scikit-fem).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from studies.outputs import Table

__all__ = ["Table", "ThesisTable", "registry"]


@dataclass(frozen=True)
class ThesisTable:
    """A thesis table: its id, the function computing its rows and, optionally, its figure."""

    id: str
    compute: Callable[[], list[dict] | dict]
    #: draws the figure that goes with the table to a path, returns the path
    figure: Callable[[Path], Path] | None = None


def registry() -> dict[str, ThesisTable]:
    """Every table valvelab regenerates, in the thesis's order.

    Returns
    -------
    dict of str to ThesisTable
        By id (``2.3``, ``3.13``, ``5.4``, ...).
    """
    from studies import plots
    from studies.tables import fea, lts, pump, reed

    tables = [
        ThesisTable("2.3", pump.table_2_3),
        ThesisTable("3.3", fea.table_3_3),
        ThesisTable("3.8", reed.table_3_8, figure=plots.figure_3_12),
        ThesisTable("3.9", fea.table_3_9),
        ThesisTable("3.11", fea.table_3_11),
        ThesisTable("3.12", reed.table_3_12),
        ThesisTable("3.13", reed.table_3_13),
        ThesisTable("5.2", lts.table_5_2),
        ThesisTable("5.4", pump.table_5_4),
        ThesisTable("5.6", pump.table_5_6),
        ThesisTable("B.2", lts.table_b_2),
    ]
    return {t.id: t for t in tables}
