"""Math-only expressions in config files (support values, tractions).

An expression is a string such as `"-0.01 * x"` or `"P * sqrt(1 - (x / a)**2)"`. It may
use numbers, `+ - * / **`, unary minus and plus, parentheses, the coordinates `x` and `y`
(arrays over the nodes or integration points), the `[parameters]` by name, the constants
`pi` and `e`, and the elementwise functions in FUNCTIONS. Nothing else is accepted: no
attribute access, subscripts, other calls, strings, lists, comparisons or keywords.

Expressions are parsed with `ast` and checked against that whitelist when the config is
loaded (`parse_expression`); their constant parts are evaluated then, so an overflow such
as `9**9**9` is reported before any meshing. `Expression.evaluate` computes them vectorised
over points, in float64 only (so no integer power can take unbounded time), and requires
every intermediate and final value to be finite. Every failure is an InputError naming
the config key and the expression.
"""

from __future__ import annotations

import ast
import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.errors import InputError

FUNCTIONS: dict[str, tuple[Callable[..., np.ndarray], int]] = {
    # name: (numpy ufunc, number of arguments)
    "sin": (np.sin, 1),
    "cos": (np.cos, 1),
    "tan": (np.tan, 1),
    "arcsin": (np.arcsin, 1),
    "arccos": (np.arccos, 1),
    "arctan": (np.arctan, 1),
    "arctan2": (np.arctan2, 2),
    "sinh": (np.sinh, 1),
    "cosh": (np.cosh, 1),
    "tanh": (np.tanh, 1),
    "exp": (np.exp, 1),
    "log": (np.log, 1),
    "log10": (np.log10, 1),
    "sqrt": (np.sqrt, 1),
    "abs": (np.abs, 1),
    "sign": (np.sign, 1),
    "floor": (np.floor, 1),
    "ceil": (np.ceil, 1),
    "hypot": (np.hypot, 2),
    "minimum": (np.minimum, 2),
    "maximum": (np.maximum, 2),
}
CONSTANTS: dict[str, float] = {"pi": math.pi, "e": math.e}
COORDINATES = ("x", "y")
RESERVED = frozenset(COORDINATES) | frozenset(FUNCTIONS) | frozenset(CONSTANTS)
"""Names a [parameters] entry may not take."""

MAX_LENGTH = 1000  # characters in one expression
MAX_DEPTH = 60  # nesting depth of the syntax tree
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

_BINARY = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply,
           ast.Div: np.divide, ast.Pow: np.power}
_UNARY = {ast.USub: np.negative, ast.UAdd: np.positive}
_SYMBOL = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**",
           ast.FloorDiv: "//", ast.Mod: "%", ast.MatMult: "@", ast.BitAnd: "&",
           ast.BitOr: "|", ast.BitXor: "^", ast.LShift: "<<", ast.RShift: ">>",
           ast.Not: "not", ast.Invert: "~"}


def _show(text: str, limit: int = 60) -> str:
    """The expression quoted on one line, shortened if long."""
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


def check_parameter_name(name: str, where: str = "parameters") -> None:
    """A [parameters] key must be an identifier that is not x, y, a function or a constant."""
    if not isinstance(name, str) or not _NAME.match(name) or name in (
            "True", "False", "None") or _is_keyword(name):
        raise InputError(f"{where}.{name}: a parameter name must be a plain identifier "
                         "(letters, digits, _; not starting with a digit)")
    if name in RESERVED:
        what = ("a coordinate" if name in COORDINATES else
                "a function" if name in FUNCTIONS else "a constant")
        raise InputError(f"{where}.{name}: the name is reserved ({what} in expressions); "
                         "rename the parameter")


def _is_keyword(name: str) -> bool:
    import keyword

    return keyword.iskeyword(name)


@dataclass(frozen=True)
class Expression:
    """A checked expression; `evaluate(x, y)` gives its values at points."""

    text: str
    tree: ast.Expression
    parameters: dict[str, float]
    where: str

    def fail(self, why: str) -> InputError:
        """The InputError naming the expression's config entry and text, with `why`."""
        return InputError(f"{self.where}: expression {_show(self.text)} {why}")

    def evaluate(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Values (same shape as x) at the points (x, y); finite, float64."""
        x = np.asarray(x, dtype=float)
        y = np.broadcast_to(np.asarray(y, dtype=float), x.shape)
        with np.errstate(all="ignore"):
            out = _evaluate(self, self.tree.body, {"x": x, "y": y})
        return np.broadcast_to(np.asarray(out, dtype=float), x.shape).copy()


def parse_expression(text: str, where: str, parameters: dict[str, float]) -> Expression:
    """Parse and check an expression (whitelist, names, argument counts, constant parts).

    where: the config key, for messages (e.g. "support #1 (base): ux").
    parameters: name -> value of the config's [parameters].
    Raises InputError naming `where` and the expression on anything not allowed.
    """
    if not isinstance(text, str):
        raise InputError(f"{where}: an expression must be a string (got {text!r})")
    if len(text) > MAX_LENGTH:
        raise InputError(f"{where}: expression {_show(text)} is longer than {MAX_LENGTH} "
                         "characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise InputError(f"{where}: expression {_show(text)} is not valid: "
                         f"{exc.msg}") from None
    except (RecursionError, MemoryError):
        raise InputError(f"{where}: expression {_show(text)} is nested too deeply") from None
    except ValueError as exc:  # a NUL character (it was reported as "nested too deeply")
        raise InputError(f"{where}: expression {_show(text)} is not valid: {exc}") from None
    expr = Expression(text.strip(), tree, dict(parameters), where)
    _check_tree(expr)
    with np.errstate(all="ignore"):
        _evaluate(expr, tree.body, {"x": None, "y": None})  # the constant parts, now
    return expr


def _check_tree(expr: Expression) -> None:
    """Every node on the whitelist; depth bounded (iterative, so no recursion limit)."""
    stack: list[tuple[ast.AST, int]] = [(expr.tree.body, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise expr.fail(f"is nested more than {MAX_DEPTH} levels deep")
        seg = ast.get_source_segment(expr.text, node) or ast.unparse(node)
        check = _NODE_CHECKS.get(type(node))
        if check is None:
            raise expr.fail(f"contains {_describe(node)} ({_show(seg, 30)}): only numbers, "
                            "+ - * / **, parentheses, x, y, parameters, pi, e and the "
                            "functions " + ", ".join(sorted(FUNCTIONS)) + " are allowed")
        stack += [(child, depth + 1) for child in check(expr, node, seg)]


def _check_constant(expr: Expression, node: ast.Constant, seg: str) -> list[ast.AST]:
    """A real, finite number (no bool, string, bytes, complex or None)."""
    v = node.value
    if isinstance(v, bool) or not isinstance(v, int | float):
        kind = "a string" if isinstance(v, str | bytes) else repr(v)
        raise expr.fail(f"contains {kind}: only real numbers are allowed")
    try:
        if not math.isfinite(float(v)):
            raise OverflowError
    except OverflowError:
        raise expr.fail(f"contains the number {_show(seg, 20)}, too large for a "
                        "float") from None
    return []


def _check_name(expr: Expression, node: ast.Name, seg: str) -> list[ast.AST]:
    """A coordinate, constant or parameter; a function name only when called."""
    if node.id in FUNCTIONS:
        raise expr.fail(f"uses the function {node.id} without calling it")
    if node.id not in COORDINATES and node.id not in CONSTANTS \
            and node.id not in expr.parameters:
        names = sorted(set(COORDINATES) | set(CONSTANTS) | set(expr.parameters))
        raise expr.fail(f"uses the unknown name '{node.id}' (names: {', '.join(names)}; "
                        f"functions: {', '.join(sorted(FUNCTIONS))})")
    return []


def _check_operator(expr: Expression, node: ast.BinOp | ast.UnaryOp,
                    seg: str) -> list[ast.AST]:
    """+ - * / ** (binary) or + - (unary); returns the operands."""
    allowed = _BINARY if isinstance(node, ast.BinOp) else _UNARY
    if type(node.op) not in allowed:
        raise expr.fail(f"uses the operator {_SYMBOL.get(type(node.op), '?')}: "
                        "only + - * / ** are allowed")
    return [node.left, node.right] if isinstance(node, ast.BinOp) else [node.operand]


def _check_call(expr: Expression, node: ast.Call, seg: str) -> list[ast.AST]:
    """A whitelisted function by name with its number of positional arguments."""
    f = node.func.id if isinstance(node.func, ast.Name) else None
    if f not in FUNCTIONS:
        raise expr.fail(f"calls {_show(seg, 30)}: only the functions "
                        f"{', '.join(sorted(FUNCTIONS))} may be called")
    n = FUNCTIONS[f][1]
    if node.keywords or len(node.args) != n or any(
            isinstance(a, ast.Starred) for a in node.args):
        raise expr.fail(f"calls {f} with {len(node.args)} argument(s) "
                        f"{'and keywords ' if node.keywords else ''}(it takes {n})")
    return list(node.args)


_NODE_CHECKS = {ast.Constant: _check_constant, ast.Name: _check_name,
                ast.BinOp: _check_operator, ast.UnaryOp: _check_operator,
                ast.Call: _check_call}
"""The allowed node types and their checks (each returns the children to visit)."""


def _describe(node: ast.AST) -> str:
    return {ast.Attribute: "an attribute access", ast.Subscript: "a subscript",
            ast.Lambda: "a lambda", ast.List: "a list", ast.Tuple: "a tuple",
            ast.Set: "a set", ast.Dict: "a dict", ast.Compare: "a comparison",
            ast.BoolOp: "a boolean operator", ast.IfExp: "an if-expression",
            ast.ListComp: "a comprehension", ast.SetComp: "a comprehension",
            ast.DictComp: "a comprehension", ast.GeneratorExp: "a generator",
            ast.NamedExpr: "an assignment", ast.JoinedStr: "a string",
            ast.Starred: "a starred expression", ast.Await: "await",
            ast.Yield: "yield", ast.YieldFrom: "yield", ast.Slice: "a slice",
            }.get(type(node), f"a {type(node).__name__} element")


def _evaluate(expr: Expression, node: ast.AST, env: dict) -> np.ndarray | float | None:
    """Value of a checked node; None when it depends on x or y and env has them as None.

    Every computed value must be finite; otherwise InputError naming the sub-expression.
    """
    if isinstance(node, ast.Constant):
        return np.float64(node.value)
    if isinstance(node, ast.Name):
        if node.id in env:
            return env[node.id]
        return np.float64(expr.parameters[node.id] if node.id in expr.parameters
                          else CONSTANTS[node.id])
    if isinstance(node, ast.BinOp):
        args = [_evaluate(expr, node.left, env), _evaluate(expr, node.right, env)]
        fn = _BINARY[type(node.op)]
    elif isinstance(node, ast.UnaryOp):
        args = [_evaluate(expr, node.operand, env)]
        fn = _UNARY[type(node.op)]
    else:  # a whitelisted call (checked by _check_tree)
        args = [_evaluate(expr, a, env) for a in node.args]
        fn = FUNCTIONS[node.func.id][0]
    if any(a is None for a in args):
        return None
    out = fn(*args)
    if not np.all(np.isfinite(out)):
        seg = ast.get_source_segment(expr.text, node) or ast.unparse(node)
        what = "is undefined (nan)" if np.any(np.isnan(out)) else "is infinite (overflow)"
        at = "" if np.ndim(out) == 0 else " at some points"
        part = "" if node is expr.tree.body else f": {_show(seg, 40)}"
        raise expr.fail(f"{what}{at}{part}")
    return out
