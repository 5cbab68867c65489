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
_BINOPS = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.Div: lambda a, b: a / b, ast.Pow: lambda a, b: a ** b}


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
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise InputError(where, f"not an arithmetic expression ({exc.msg})") from None
    names = []

    def visit(n):
        if isinstance(n, ast.Expression):
            return visit(n.body)
        if isinstance(n, ast.Constant) and isinstance(n.value, (int, float)) and not isinstance(n.value, bool):
            return
        if isinstance(n, (ast.Name, ast.Attribute)):
            d = _dotted(n)
            if d is None:
                raise InputError(where, "only names and numbers may be combined")
            names.append(d)
            return
        if isinstance(n, ast.BinOp) and type(n.op) in _BINOPS:
            visit(n.left), visit(n.right)
            return
        if isinstance(n, ast.UnaryOp) and isinstance(n.op, (ast.USub, ast.UAdd)):
            return visit(n.operand)
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in _FUNCS and not n.keywords:
            for a in n.args:
                visit(a)
            return
        raise InputError(where, f"unsupported element {type(n).__name__}: use numbers, variable names, "
                                "+ - * / **, min, max, sqrt, exp, log, abs")

    visit(tree)
    return names


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
            return n.value
        if isinstance(n, (ast.Name, ast.Attribute)):
            return values[_dotted(n)]
        if isinstance(n, ast.BinOp):
            return _BINOPS[type(n.op)](ev(n.left), ev(n.right))
        if isinstance(n, ast.UnaryOp):
            v = ev(n.operand)
            return -v if isinstance(n.op, ast.USub) else v
        return _FUNCS[n.func.id](*[ev(a) for a in n.args])

    return float(ev(tree))
