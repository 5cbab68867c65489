"""The ``valvelab`` command line (CONTRACT.md).

Each subcommand lives in its own module. Adding a command is adding a module to this
package (``studies/cli/``) that defines:

``HELP`` : str
    One line for ``valvelab --help``.
``configure(p)``
    Adds the command's arguments to ``p``, its :class:`argparse.ArgumentParser`; every
    numeric flag declared with its unit and range (:mod:`studies.cli.flags`).
``run(args) -> dict``
    Runs the command on the parsed :class:`argparse.Namespace`; returns the result, the JSON
    object ``--json`` prints (CONTRACT.md names its keys and units).
``render(r) -> str`` (optional)
    The result as readable text (default: the JSON, indented).

Conventions shared by every command:
- ``--json`` prints exactly one JSON object on stdout; progress and logs go to stderr;
- a user mistake (:class:`geometry.errors.InputError`, bad flags) exits 2 with one
  line on stderr naming the field or file; never a traceback, never a NaN in output;
- anything else that goes wrong (a result breaking its own invariants, a bug) exits 1
  with one line and, for a bug, where to report it;
- a command that simulates puts ``warnings`` (``[{"code", "message"}]``, lumped.validity) in its JSON and
  writes each on stderr as one line.
"""

from __future__ import annotations

import argparse
import ast
import errno
import importlib
import importlib.util
import json
import os
import pkgutil
import re
import sys

from geometry.errors import InputError

#: modules of this package that are not commands
HELPERS = frozenset({"flags"})
#: the order commands are listed in ``valvelab --help`` (others follow alphabetically)
ORDER = ("validate", "pump", "model", "reed", "modes", "check", "gci", "seat", "table", "lts", "sweep",
         "sweep-plot", "sensitivity", "optimize", "synth", "discrepancy")


def _discover() -> dict[str, str]:
    """{command name: module name}: every module of this package is a command (``sweep_plot`` ->
    ``sweep-plot``), found without importing it (each import costs scipy/matplotlib/skfem time)."""
    found = {m.name.replace("_", "-"): f"{__name__}.{m.name}" for m in pkgutil.iter_modules(__path__)
             if m.name not in HELPERS and not m.name.startswith("_")}
    first = [n for n in ORDER if n in found]
    return {n: found[n] for n in first + sorted(set(found) - set(first))}


#: subcommand -> module implementing it (a new module in studies/cli/ is a new command)
COMMANDS: dict[str, str] = _discover()


#: a negative number as users type it, exponent form and -inf/-nan included (argparse's own pattern knows only
#: plain decimals, so ``--mesh-size -1e-4`` would be taken for a flag and refused as "expected one argument"); so
#: is a comma-separated list that starts with one (``gci ... --cells -18000,-8000,-4500`` reaches its range check)
_NUMBER = r"(?:(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|inf|infinity|nan)"
NEGATIVE_NUMBER = re.compile(rf"^-{_NUMBER}(?:\s*,\s*[-+]?{_NUMBER})*$", re.IGNORECASE)


class _Parser(argparse.ArgumentParser):
    """argparse with the contract's one-line error and exit status 2; negative numbers in any form are values."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str):  # noqa: D102
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def _finite(obj, path="result"):
    """Raise if a NaN or infinity would reach the output (never a silent NaN)."""
    if isinstance(obj, float) and obj != obj or obj in (float("inf"), float("-inf")):
        raise ValueError(f"{path} is not finite ({obj})")
    if isinstance(obj, dict):
        for k, v in obj.items():
            _finite(v, f"{path}.{k}")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            _finite(v, f"{path}[{i}]")


#: operating-system errors that say the disk refused a write (exit 1 with one line, not an internal error)
DISK_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EIO, errno.EFBIG})

#: where users report a failure that is not their mistake
REPORT_URL = "https://github.com/valvelab/valvelab/issues"


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _internal_error(command: str, exc: BaseException) -> int:
    """Exit status 1 and one line for a failure that is not a user mistake (VALVELAB_DEBUG=1: traceback)."""
    if os.environ.get("VALVELAB_DEBUG"):
        import traceback

        traceback.print_exception(exc)
    model_failure = getattr(exc, "model_failure", False) or "is not finite" in str(exc)
    what = "the model failed" if model_failure else "internal error"
    hint = "" if model_failure else f" (please report it with the command line at {REPORT_URL}; " \
                                    "VALVELAB_DEBUG=1 shows the traceback)"
    sys.stderr.write(f"valvelab {command}: {what}: {type(exc).__name__}: {_one_line(exc)}{hint}\n")
    return 1


def help_line(modname: str) -> str:
    """A command module's ``HELP``, read from its source without importing it.

    ``valvelab --help`` lists every command: importing each module would import scipy, numba,
    matplotlib, dask and scikit-fem (seconds); its ``HELP`` literal is all the list needs.

    Parameters
    ----------
    modname : str
        The command's module (``studies.cli.pump``).

    Returns
    -------
    str
        The line (the imported module's ``HELP`` where the source does not give it as a literal).
    """
    spec = importlib.util.find_spec(modname)
    try:
        tree = ast.parse(open(spec.origin, encoding="utf-8").read())
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "HELP" for t in node.targets):
                return ast.literal_eval(node.value)
    except (OSError, ValueError, SyntaxError, TypeError):
        pass
    return importlib.import_module(modname).HELP


def build_parser(selected: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser.

    Parameters
    ----------
    selected : str, optional
        The command asked for: only its module is imported (none for ``valvelab --help``, which
        lists the commands from their ``HELP`` lines, :func:`help_line`).

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = _Parser(prog="valvelab", description="Hydraulic disc, reed and ball check valve models.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, modname in COMMANDS.items():
        if selected is None:
            # argparse formats a command's help with %, not its description
            sub.add_parser(name, help=help_line(modname).replace("%", "%%"))
            continue
        if name != selected:
            sub.add_parser(name)  # known name, configured only when chosen
            continue
        mod = importlib.import_module(modname)
        p = sub.add_parser(name, help=mod.HELP.replace("%", "%%"), description=mod.HELP)
        p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
        mod.configure(p)
        p.set_defaults(_module=mod)
    return parser


def _fluid_forms() -> None:
    """Offer the disc's predicted fluid parameters (``fluid = "predicted"``) to the model loader without
    importing the fluid references until a model asks (the installed entry point does the same)."""
    from lumped.valves import fluid_forms

    def disc(valve, oil):
        from fea.fluid.compact import predicted_values

        return predicted_values(valve, oil)

    fluid_forms.FORMS.setdefault("disc", disc)


def main(argv: list[str] | None = None) -> int:
    """Run ``valvelab`` with a command line.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status: 0, 2 for a bad input (:class:`~geometry.errors.InputError`, one line on
        stderr), 1 for a failed model or an internal error (one line), 130 when interrupted.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    # importing every command module (scipy, matplotlib, skfem...) costs seconds per call
    selected = next((a for a in argv if not a.startswith("-")), None)
    try:
        parser = build_parser(selected if selected in COMMANDS else None)
    except Exception as exc:  # noqa: BLE001 - a broken installation, said in one line
        return _internal_error(selected or "", exc)
    args = parser.parse_args(argv)
    mod = args._module
    try:
        _fluid_forms()
        result = mod.run(args)
        _finite(result)
    except InputError as exc:
        sys.stderr.write(f"valvelab {args.command}: error: {_one_line(str(exc))}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("valvelab: interrupted\n")
        return 130
    except OSError as exc:
        if exc.errno not in DISK_ERRORS:
            return _internal_error(args.command, exc)
        # the machine's, not the user's mistake nor ours: a full or read-only disk, a quota, a failing device
        where = f" {exc.filename}" if exc.filename else ""
        sys.stderr.write(f"valvelab {args.command}: could not write{where}: {os.strerror(exc.errno)} "
                         f"({errno.errorcode.get(exc.errno, exc.errno)}); free space or choose another path\n")
        return 1
    except Exception as exc:  # noqa: BLE001 - the boundary: anything else is our failure, said in one line
        return _internal_error(args.command, exc)
    # a result outside its model's validity envelope (lumped.validity): one line each, on stderr
    for w in (result.get("warnings") or ()) if isinstance(result, dict) else ():
        sys.stderr.write(f"valvelab {args.command}: warning: {w['code']}: {_one_line(w['message'])}\n")
    if args.json:
        sys.stdout.write(json.dumps(result, allow_nan=False) + "\n")
    else:
        render = getattr(mod, "render", None)
        sys.stdout.write((render(result) if render else json.dumps(result, indent=2)) + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
