"""The ``valvelab`` command line (CONTRACT.md).

Each subcommand lives in its own module that defines ``HELP``, ``configure(parser)``
and ``run(args) -> dict`` (the JSON payload) and optionally ``render(result) -> str``
(the readable text). Adding a command is one line in :data:`COMMANDS`.

Conventions shared by every command:
- ``--json`` prints exactly one JSON object on stdout; progress and logs go to stderr;
- a user mistake (:class:`geometry.errors.InputError`, bad flags) exits 2 with one
  line on stderr naming the field or file; never a traceback, never a NaN in output.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys

from geometry.errors import InputError

#: subcommand -> module implementing it
COMMANDS: dict[str, str] = {
    "reed": "studies.cmd_reed",
    "table": "studies.cmd_table",
    "lts": "studies.cmd_lts",
    "pump": "studies.cmd_pump",
    "model": "studies.cmd_model",
    "validate": "studies.cmd_validate",
    "check": "studies.cmd_check",
    "seat": "studies.cmd_seat",
    "modes": "studies.cmd_modes",
    "sweep": "studies.cmd_sweep",
    "sweep-plot": "studies.cmd_sweep_plot",
    "synth": "studies.cmd_synth",
    "discrepancy": "studies.cmd_discrepancy",
    "sensitivity": "studies.cmd_sensitivity",
    "optimize": "studies.cmd_optimize",
}


class _Parser(argparse.ArgumentParser):
    """argparse with the contract's one-line error and exit status 2."""

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


def build_parser(selected: str | None = None) -> argparse.ArgumentParser:
    """The parser; only the ``selected`` command's module is imported (all of them for --help)."""
    parser = _Parser(prog="valvelab", description="Hydraulic disc and reed check valve models.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, modname in COMMANDS.items():
        if selected is not None and name != selected:
            sub.add_parser(name)  # known name, configured only when chosen
            continue
        mod = importlib.import_module(modname)
        text = mod.HELP.replace("%", "%%")  # argparse formats help strings with %
        p = sub.add_parser(name, help=text, description=text)
        p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
        mod.configure(p)
        p.set_defaults(_module=mod)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # importing every command module (scipy, matplotlib, skfem...) costs seconds per call
    selected = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(selected if selected in COMMANDS else None)
    args = parser.parse_args(argv)
    mod = args._module
    try:
        result = mod.run(args)
        _finite(result)
    except InputError as exc:
        sys.stderr.write(f"valvelab {args.command}: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("valvelab: interrupted\n")
        return 130
    except ValueError as exc:
        # a non-finite result is a model failure, reported without a traceback
        if "is not finite" in str(exc):
            sys.stderr.write(f"valvelab {args.command}: error: {exc}\n")
            return 1
        raise
    if args.json:
        sys.stdout.write(json.dumps(result, allow_nan=False) + "\n")
    else:
        render = getattr(mod, "render", None)
        sys.stdout.write((render(result) if render else json.dumps(result, indent=2)) + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
