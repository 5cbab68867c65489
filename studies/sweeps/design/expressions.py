"""The ``[derived]`` keys of a design spec: arithmetic on the variables' names, checked before it is evaluated.

A derived key is a string such as ``"step_length / valves.geometry.length"``: numbers, names
(dotted key paths too), ``+ - * / **``, unary minus and the functions min, max, sqrt, exp,
log, abs. :func:`expression_names` checks the text (Python's own parser, ``ast``; nothing
else is allowed, so nothing is executed) and lists the names it reads;
:func:`evaluate_expression` computes it for one design.
"""

from __future__ import annotations

import ast
import math

from geometry.errors import InputError

_FUNCS = {"min": min, "max": max, "sqrt": math.sqrt, "exp": math.exp, "log": math.log, "abs": abs}
# floats only, math.pow for powers: every operation is one floating-point operation, so an expression's work is
# bounded by its length ("9 ** 9 ** 9 ** 9" in integers would compute a number of 10^8 digits; in floats it
# overflows at once), and a negative base to a fractional power is a ValueError, not a complex number
_BINOPS = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.Div: lambda a, b: a / b, ast.Pow: math.pow}
#: the longest expression accepted [characters] (Python's parser recurses on nesting)
MAX_LENGTH = 2000
#: how many arguments each function takes (min, max: at least two)
_ARITY = {"min": (2, None), "max": (2, None), "sqrt": (1, 1), "exp": (1, 1), "log": (1, 1), "abs": (1, 1)}


def _dotted(node) -> str | None:
    """The dotted name of a Name or Attribute node (``valves.geometry.length``), or None."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return ".".join(reversed(parts))
    return None


def expression_names(text: str, where: str) -> list[str]:
    """Check an arithmetic expression and list the names it reads.

    Parameters
    ----------
    text : str
        The expression.
    where : str
        Its field name (``derived."valves.geometry.step_fraction"``).

    Returns
    -------
    list of str
        The names, in order of appearance.

    Raises
    ------
    InputError
        For anything but numbers, names, ``+ - * / **``, unary signs and calls of min, max,
        sqrt, exp, log, abs.

    Examples
    --------
    >>> expression_names("step_length / valves.geometry.length", "derived.x")
    ['step_length', 'valves.geometry.length']
    """
    names: list[str] = []
    try:
        _visit(_parse(text, where), where, names)
    except RecursionError:
        raise InputError(where, "nested too deeply to be an arithmetic expression") from None
    return names


def _parse(text: str, where: str) -> ast.Expression:
    """The expression's syntax tree, or InputError naming ``where``."""
    if not isinstance(text, str):
        raise InputError(where, f"expected an arithmetic expression as a string, got {text!r}")
    if len(text) > MAX_LENGTH:
        raise InputError(where, f"an expression of {len(text)} characters; at most {MAX_LENGTH}")
    try:
        return ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise InputError(where, f"not an arithmetic expression ({exc.msg})") from None
    except (RecursionError, MemoryError):
        raise InputError(where, "nested too deeply to be an arithmetic expression") from None


def _visit(n, where: str, names: list[str]) -> None:
    """Append the names node ``n`` reads to ``names``; InputError for an element outside the grammar."""
    if isinstance(n, ast.Expression):
        return _visit(n.body, where, names)
    if isinstance(n, ast.Constant) and isinstance(n.value, (int, float)) and not isinstance(n.value, bool):
        return None
    if isinstance(n, (ast.Name, ast.Attribute)):
        d = _dotted(n)
        if d is None:
            raise InputError(where, "only names and numbers may be combined")
        names.append(d)
        return None
    if isinstance(n, ast.BinOp) and type(n.op) in _BINOPS:
        _visit(n.left, where, names)
        return _visit(n.right, where, names)
    if isinstance(n, ast.UnaryOp) and isinstance(n.op, (ast.USub, ast.UAdd)):
        return _visit(n.operand, where, names)
    if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in _FUNCS and not n.keywords:
        lo, hi = _ARITY[n.func.id]
        if len(n.args) < lo or (hi is not None and len(n.args) > hi) or \
                any(isinstance(a, ast.Starred) for a in n.args):
            raise InputError(where, f"{n.func.id}() takes {lo if hi == lo else f'{lo} or more'} argument"
                                    f"{'s' if lo > 1 else ''}")
        for a in n.args:
            _visit(a, where, names)
        return None
    raise InputError(where, f"unsupported element {type(n).__name__}: use numbers, variable names, "
                            "+ - * / **, min, max, sqrt, exp, log, abs")


def evaluate_expression(text: str, values: dict) -> float:
    """The value of an expression checked by :func:`expression_names`.

    Parameters
    ----------
    text : str
        The expression.
    values : dict of str to float
        The value of every name it reads.

    Returns
    -------
    float
        Finite; OverflowError, ValueError or ZeroDivisionError otherwise (a power too large, the root or log of
        a negative number, a division by zero).

    Examples
    --------
    >>> evaluate_expression("step_length / valves.geometry.length",
    ...                     {"step_length": 5e-3, "valves.geometry.length": 20e-3})
    0.25
    """
    tree = ast.parse(text, mode="eval")

    def ev(n):
        if isinstance(n, ast.Expression):
            return ev(n.body)
        if isinstance(n, ast.Constant):
            return float(n.value)
        if isinstance(n, (ast.Name, ast.Attribute)):
            return values[_dotted(n)]
        if isinstance(n, ast.BinOp):
            return _BINOPS[type(n.op)](ev(n.left), ev(n.right))
        if isinstance(n, ast.UnaryOp):
            v = ev(n.operand)
            return -v if isinstance(n.op, ast.USub) else v
        return _FUNCS[n.func.id](*[ev(a) for a in n.args])

    out = float(ev(tree))
    if not math.isfinite(out):
        raise OverflowError(f"the value is {out}")
    return out
