"""The documentation site: it builds with every warning an error and every cross-reference to
valvelab's own objects resolved; the user documents say what valvelab does, not how it was
built; the README stays a five-minute read; and every command line and Python block of the
user guide's pages runs as written.

Blocks are taken from the pages themselves (not copied here): a page's command lines and
``python`` blocks (a fragment that is not meant to run is marked ``py``) run in page order in one scratch folder (a later block may read what an
earlier one wrote), with ``docs/`` linked there so the pages' ``docs/examples/...`` paths hold.
Lines that take minutes run with ``pytest -m slow``. The gallery's examples are run by
tests/test_examples.py (one runner): the build here renders them without running them.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
BIN = Path(sys.executable).parent
#: the pages a user reads: the README, the contract and the docs site's Markdown
USER_DOCUMENTS = [ROOT / "README.md", ROOT / "CONTRACT.md", *sorted(DOCS.glob("*.md")),
                  *sorted((DOCS / "examples").glob("*.py")), *sorted((DOCS / "examples").glob("*.toml"))]
#: words about how the project was built, which belong to no user document
HISTORY = re.compile(r"\bsessions?\b|\bissue \d{1,2}\b|closing note|\bhelpers?\b", re.I)
#: command lines that take minutes (as tests/test_readme.py's)
SLOW = re.compile(r"^valvelab (validate|check|modes|seat|table [35]\.|discrepancy|synth|sensitivity|optimize)|"
                  r"--fidelity solid|--fidelity axisymmetric|^python benchmarks/|studies\.discrepancy\.confusion")


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    """sphinx -W -n: a broken cross-reference, a missing page or a docstring Sphinx cannot read fails."""
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-n", "--keep-going", "-q", "-b", "html",
                        "-D", "plot_gallery=0", str(DOCS), str(tmp_path / "html")],
                       capture_output=True, text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stderr[-4000:]
    assert (tmp_path / "html" / "index.html").exists()
    api = (tmp_path / "html" / "api" / "lumped.html").read_text()
    assert "simulate" in api and "check_valve_kind" in api
    # the export tables: whole first sentences, roles rendered (no raw :func: markup)
    for page in (tmp_path / "html" / "api").glob("*.html"):
        text = page.read_text()
        assert not re.search(r":(func|class|meth|mod|attr|obj|data):", text), page.name
    assert "after a number of revolutions, or at the cyclic steady state." in api   # StopRule's whole first sentence


def test_the_export_tables_show_first_sentences():
    """docs/conf.py's summary: the first sentence whole (joined across lines, not cut at an abbreviation or a
    literal), cross-references shown as the names they link to."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("docs_conf", DOCS / "conf.py")
    conf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conf)          # (writes the generated pages of docs/api/, as a build does)
    summary = conf.summary
    from lumped import StopRule, reed_properties, with_values

    for obj in (StopRule, with_values, reed_properties):
        text = summary(obj.__doc__)
        assert text.endswith("."), (obj, text)
        assert text.split()[-1].rstrip(".") in " ".join(obj.__doc__.split()), (obj, text)
        assert ":func:" not in text and ":class:" not in text
    assert summary(":func:`~lumped.simulate` runs it (eq. 3.21, i.e. one mode). Then more.") == \
        "``simulate()`` runs it (eq. 3.21, i.e. one mode)."
    assert summary(":class:`the pump <lumped.PumpModel>` in ``a.b``. Next.") == "the pump in ``a.b``."


def test_user_documents_speak_of_no_history():
    found = []
    for path in USER_DOCUMENTS:
        for i, line in enumerate(path.read_text().splitlines(), 1):
            if HISTORY.search(line):
                found.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()[:100]}")
    assert not found, "history in a user document (it goes to CHANGELOG.md):\n" + "\n".join(found)


def test_the_readme_is_a_five_minute_read():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 150, f"README.md has {len(lines)} lines"


def _blocks(page: Path) -> list[tuple[str, str]]:
    """(kind, text) of a page's runnable blocks in order: ("cmd", a command line) or ("python", code)."""
    out = []
    for lang, body in re.findall(r"```(\w*)\n(.*?)```", page.read_text(), re.S):
        if lang == "python":
            out.append(("python", body))
        elif lang in ("", "bash", "sh", "console"):
            for line in body.splitlines():
                line = re.sub(r"\s+#.*$", "", line).strip()
                if line.startswith(("valvelab ", "python -m studies", "python benchmarks/", "python docs/")):
                    out.append(("cmd", line))
    return out


# docs/discrepancy.md has a runner of its own (tests/test_docs_discrepancy.py: its lines marked slow in comments)
GUIDE = [p for p in sorted(DOCS.glob("*.md")) if _blocks(p) and p.name != "discrepancy.md"]


def _run_page(page: Path, tmp_path: Path, slow: bool) -> None:
    (tmp_path / "docs").symlink_to(DOCS)
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}", "MPLBACKEND": "Agg",
           "PYTHONPATH": str(ROOT)}
    for kind, text in _blocks(page):
        if kind == "cmd":
            if bool(SLOW.search(text)) != slow:
                continue
            line = text.replace("python benchmarks/", f"python {ROOT}/benchmarks/")
            r = subprocess.run(["bash", "-c", line], cwd=tmp_path, capture_output=True, text=True, env=env,
                               timeout=3000)
            assert r.returncode == 0, f"{page.name}: {text!r} exited {r.returncode}:\n{r.stderr[-2000:]}"
        elif not slow:
            r = subprocess.run([sys.executable, "-c", text], cwd=tmp_path, capture_output=True, text=True,
                               env=env, timeout=1200)
            assert r.returncode == 0, f"{page.name}: a Python block failed:\n{text}\n{r.stderr[-2000:]}"


@pytest.mark.parametrize("page", GUIDE, ids=lambda p: p.stem)
def test_the_guide_pages_quick_blocks_run(page, tmp_path):
    _run_page(page, tmp_path, slow=False)


@pytest.mark.slow
@pytest.mark.parametrize("page", GUIDE, ids=lambda p: p.stem)
def test_the_guide_pages_slow_blocks_run(page, tmp_path):
    _run_page(page, tmp_path, slow=True)
