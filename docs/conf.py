"""Sphinx configuration of valvelab's documentation site.

Build (from the repository root; the gallery's examples run, their figures are kept):

    pip install -e ".[docs]" && python -m sphinx -W -n -b html docs docs/_build/html

Stack: Sphinx with MyST (the pages are Markdown), numpydoc (the API reference from the
docstrings), sphinx-gallery (docs/examples/ as a gallery) and the PyData theme. The API
pages are generated from each package's ``__all__`` (what it exports), so a new public
function appears without editing this site. No intersphinx: the build reaches no network;
references to other libraries' types are not cross-linked (``nitpick_ignore_regex``), every
reference to valvelab's own objects must resolve (``-n``).
"""

from __future__ import annotations

import importlib
import os
import importlib.metadata
import pkgutil
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")

project = "valvelab"
author = "the valvelab developers"
copyright = "2026, the valvelab developers"
release = importlib.metadata.version("valvelab")

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "examples/*.toml", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.json"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
suppress_warnings = ["myst.header"]

# ----------------------------------------------------------------- API reference from the docstrings
autodoc_typehints = "none"                  # numpydoc's Parameters section says the types
autodoc_default_options = {"no-value": True}   # a registry's repr is no documentation
autodoc_preserve_defaults = True            # a default argument as written (LIBRARY), not its repr
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()

#: the packages whose exports make the API reference, with one line on what each is for
API_PACKAGES = {
    "geometry": "One parametric description per part: reeds, the disc valve, seat and stop, ports.",
    "lumped": "The lumped (ODE) models: valve kinds, oil, the pump, effects, simulate.",
    "fea": "Finite-element references (scikit-fem): beam, plate and solid reeds, seat and stop.",
    "instruments": "The laser triangulation sensor of the thesis rig.",
    "studies.validation": "The validation chain and its uncertainty (ASME V&V 20).",
    "studies.discrepancy": "Measured data, synthetic data and the discrepancy workflow.",
    "studies.sweeps": "Parameter sweeps on dask.",
    "studies.tables": "The thesis's tables, regenerated.",
    "studies": "Output folders and the figures the commands draw.",
}


def _canonical(obj, fallback: str) -> str:
    """Where an exported object is defined (module.qualname): its one description in the reference."""
    mod, qual = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    if isinstance(mod, str) and isinstance(qual, str) and "<" not in qual:
        return f"{mod}.{qual}"
    return fallback


def _modules(package: str) -> list[str]:
    """The package's modules, subpackages' included (the command-line modules are CONTRACT.md's)."""
    pkg = importlib.import_module(package)
    names = [package] if package.count(".") else []       # a subpackage's own __init__ defines things too
    for info in pkgutil.walk_packages(pkg.__path__, prefix=f"{package}."):
        if ".cli" in info.name or info.name.split(".")[-1].startswith("_"):
            continue
        if any(info.name == other or info.name.startswith(f"{other}.") for other in API_PACKAGES
               if other != package and other.startswith(f"{package}.")):
            continue
        names.append(info.name)
    return sorted(names)


def _write(path: Path, lines: list[str]) -> None:
    text = "\n".join(lines) + "\n"
    if not path.exists() or path.read_text() != text:      # unchanged pages keep Sphinx's cache
        path.write_text(text)


#: exported name (geometry.Reed) -> where it is defined and described (geometry.reed.Reed)
ALIASES: dict[str, str] = {}


def _write_api_pages() -> None:
    """docs/api/: per package, a list of what it exports (``__all__``) linked to where each is defined, then
    one page per module with its docstring and every member it defines (the one description of each)."""
    out = DOCS / "api"
    (out / "modules").mkdir(parents=True, exist_ok=True)
    index = ["API reference", "=============", "",
             "Generated from the numpydoc docstrings: per package what it exports (its ``__all__``), then",
             "each of its modules with its docstring and the functions and classes it defines.", "",
             ".. toctree::", "   :maxdepth: 1", ""]
    for name, what in API_PACKAGES.items():
        mod = importlib.import_module(name)
        lines = [f"``{name}``", "=" * (len(name) + 4), "", what, ""]
        rows = []
        for n in sorted(getattr(mod, "__all__", [])):
            obj = getattr(mod, n)
            target = _canonical(obj, "")
            if callable(obj) and target.startswith(("geometry.", "lumped.", "fea.", "instruments.", "studies.")):
                ALIASES[f"{name}.{n}"] = target
                role = "class" if isinstance(obj, type) else "func"
                rows.append(f"* :py:{role}:`{n} <{target}>`: {_escape(summary(obj.__doc__))}")
            else:                        # a registry or a constant: no page of its own
                rows.append(f"* ``{n}``: {type(obj).__name__}" + (f" of {len(obj)} entries" if hasattr(obj, "__len__")
                                                                  else ""))
        if rows:
            lines += ["Exports", "-------", ""] + rows + [""]
        modules = _modules(name)
        lines += ["Modules", "-------", "", ".. toctree::", "   :maxdepth: 1", ""] + [f"   modules/{m}" for m in modules]
        for m in modules:
            # a package's page documents what it defines, not what it re-exports from its modules
            _write(out / "modules" / f"{m}.rst", [f"``{m}``", "=" * (len(m) + 4), "", f".. automodule:: {m}",
                                                  "   :members:", "   :ignore-module-all:", ""])
        _write(out / f"{name}.rst", lines)
        index.append(f"   {name}")
    _write(out / "index.rst", index)
    # pages of modules that no longer exist (moved or removed) would be orphans: -W fails on them
    current = {f"{m}.rst" for name in API_PACKAGES for m in _modules(name)}
    for page in (out / "modules").glob("*.rst"):
        if page.name not in current:
            page.unlink()


#: words ending in a full stop that end no sentence (eq. 3.21, e.g., Knutson et al.)
ABBREVIATIONS = ("e.g.", "i.e.", "eq.", "eqs.", "Eq.", "Eqs.", "etc.", "vs.", "al.", "cf.", "Fig.", "Ref.", "No.")
#: a reStructuredText role: :func:`~lumped.simulate`, :class:`text <target>`, :math:`x`
ROLE = re.compile(r":(?:py:)?(\w+):`([^`]+)`")


def _role_text(m: re.Match) -> str:
    """A role as the text it renders: a cross-reference as its shown name in code style, math as math."""
    role, body = m.group(1), m.group(2)
    if role == "math":
        return m.group(0)
    titled = re.fullmatch(r"(.+?)\s*<[^>]+>", body)
    if titled:
        return titled.group(1)
    target = body.lstrip("!")
    if target.startswith("~"):
        target = target[1:].split(".")[-1]
    return f"``{target}{'()' if role in ('func', 'meth') else ''}``"


def summary(doc: str | None) -> str:
    """The first sentence of a docstring, its roles rendered, for the export tables.

    The first paragraph is joined across its lines and cut after its first full stop that ends a
    sentence (not inside a literal, not after an abbreviation such as ``eq.``); a cross-reference
    role shows the name it links to (``:func:`~lumped.simulate``` as ``simulate()``), math stays math.

    Parameters
    ----------
    doc : str or None

    Returns
    -------
    str

    >>> summary("Run at least ``revolutions``; continue until the\\n    steady state (eq. 3.2). More text.")
    'Run at least ``revolutions``; continue until the steady state (eq. 3.2).'
    >>> summary(":func:`parse_port` then :func:`~geometry.reed_port.check_port`.")
    '``parse_port()`` then ``check_port()``.'
    """
    lines = []
    for line in (doc or "").strip().splitlines():
        if not line.strip():
            break
        lines.append(line.strip())
    text = ROLE.sub(_role_text, " ".join(lines))
    depth = 0                                   # inside ``literals`` no sentence ends
    for i, ch in enumerate(text):
        if text.startswith("``", i):
            depth ^= 1
        if ch in ".!?" and not depth and (i + 1 == len(text) or text[i + 1] == " "):
            word = text[:i + 1].rsplit(" ", 1)[-1].lstrip("(")
            if word not in ABBREVIATIONS:
                return text[:i + 1]
    return text


def _escape(text: str) -> str:
    """A summary inside a reStructuredText list: bars and stars are text, not markup."""
    return text.replace("|", "\\|").replace("*", "\\*")


def _resolve_alias(app, env, node, contnode):
    """A reference to an exported name (``geometry.Reed``, ``lumped.simulate``) resolves to its description."""
    target = node.get("reftarget", "")
    head = next((a for a in ALIASES if target == a or target.startswith(f"{a}.")), None)   # geometry.Reed.pieces too
    if node.get("refdomain") != "py" or head is None:
        return None
    new = ALIASES[head] + target[len(head):]
    return env.get_domain("py").resolve_xref(env, node["refdoc"], app.builder, node["reftype"], new, node, contnode)


def _escape_bars(app, what, name, obj, options, lines) -> None:
    """|x| in a docstring is an absolute value, not a reStructuredText substitution: escape the bars (a line
    that starts and ends with one is a table row and keeps them)."""
    for i, line in enumerate(lines):
        text = line.strip()
        if "|" in text and not (text.startswith("|") and text.endswith("|")):
            lines[i] = line.replace("|", "\\|")


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars, priority=900)   # after numpydoc's rewrite
    app.connect("missing-reference", _resolve_alias)


_write_api_pages()          # here, not in a hook: Sphinx lists the source files before any hook runs


# ----------------------------------------------------------------- cross-references
nitpicky = True
#: types of Python and of other libraries (no intersphinx: the build is offline); valvelab's own must resolve
nitpick_ignore_regex = [
    ("py:class", r"(int|float|str|bool|bytes|dict|list|tuple|set|object|callable|None|type|Path|"
                 r"optional|iterable|sequence|mapping|array_like|array-like|ndarray|function|default.*)"),
    ("py:class", r"(numpy|np|scipy|pandas|pd|matplotlib|dask|distributed|skfem|meshio|pyarrow|pymoo|SALib|"
                 r"pathlib|collections|typing|dataclasses|os|io|argparse)\..*"),
    ("py:obj", r"(numpy|np|scipy|pandas|pd|matplotlib|dask|skfem|typing)\..*"),
]

# ----------------------------------------------------------------- the gallery
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/ex\d\d_",        # every example runs (and its figures are kept)
    "ignore_pattern": r"__init__\.py",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "within_subsection_order": "FileNameSortKey",
    "reset_modules": ("matplotlib",),
    "abort_on_example_error": True,
}

# ----------------------------------------------------------------- HTML
html_theme = "pydata_sphinx_theme"
html_title = "valvelab"
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2,
                      "secondary_sidebar_items": ["page-toc"]}
html_static_path = []
html_last_updated_fmt = None
