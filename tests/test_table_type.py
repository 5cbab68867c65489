"""The one table type (studies.outputs.Table): the same rows as a frame, Markdown, text and files."""

import pandas as pd

from studies.outputs import Table
from studies.tables import registry


def test_table_round_trips_through_csv_and_keeps_column_order(tmp_path):
    t = Table.of({"rows": [{"case": "a", "omega": 3046.0}, {"case": "b", "kappa": 7.3454e6}], "notes": ["n1"]},
                 "Table X")
    assert t.columns == ["case", "omega", "kappa"]
    csv_path, md_path = t.write(tmp_path / "t")
    back = pd.read_csv(csv_path)
    assert list(back.columns) == t.columns and back["omega"][0] == 3046.0 and pd.isna(back["kappa"][0])
    assert t.to_frame().shape == (2, 3)
    md = md_path.read_text()
    assert md.startswith("# Table X") and "| case | omega | kappa |" in md and md.rstrip().endswith("- n1")
    assert t.to_text().splitlines()[0] == "Table X" and "note: n1" in t.to_text()


def test_every_registered_table_has_a_function_and_an_id():
    tables = registry()
    assert {"2.3", "3.3", "3.8", "5.4", "5.6", "B.2"} <= set(tables)
    assert all(callable(t.compute) and t.id == k for k, t in tables.items())
    assert [k for k, t in tables.items() if t.figure is not None] == ["3.8"]
