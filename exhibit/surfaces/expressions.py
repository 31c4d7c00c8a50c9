"""Scalar functions of R^4 given as formulas: parsed safely, differentiated symbolically (sympy),
evaluated vectorised (numpy) and bounded on boxes (interval arithmetic) for the polygonizer.

Curators write f1, f2 in TOML scene files, so the parser accepts only arithmetic: numbers, the
four coordinates, the scene's parameters, + - * / ^ (** works too), and a short list
of functions. Nothing is ever passed to eval: the text goes through Python's ast parser and each
node is translated by hand into a sympy expression, or rejected with its column.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np

if TYPE_CHECKING:  # sympy is imported where it is used: it costs half a second
    import sympy

FUNCTION_NAMES = ("sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sinh", "cosh", "tanh",
                  "atan")
CONSTANT_NAMES = ("pi", "e")
MAX_LENGTH = 2000
MAX_EXPONENT = 64


class ExpressionError(ValueError):
    """A formula that cannot be accepted; the message names the column and the reason."""


class _SympyAlgebra:
    """Builds the sympy expression (imported only here: it costs half a second at start-up)."""

    def __init__(self, variables):
        import sympy
        self.sympy = sympy
        self.symbols = {name: sympy.Symbol(name, real=True) for name in variables}
        self.functions = {"sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan,
                          "exp": sympy.exp, "log": sympy.log, "sqrt": sympy.sqrt,
                          "abs": sympy.Abs, "sinh": sympy.sinh, "cosh": sympy.cosh,
                          "tanh": sympy.tanh, "atan": sympy.atan}
        self.constants = {"pi": sympy.pi, "e": sympy.E}

    def number(self, value: float):
        if float(value).is_integer() and abs(value) <= 10**6:
            return self.sympy.Integer(int(value))
        return self.sympy.Float(value)

    def symbol(self, name):
        return self.symbols[name]

    def constant(self, name):
        return self.constants[name]

    def function(self, name, argument):
        return self.functions[name](argument)

    def numeric(self, value) -> float | None:
        if not value.is_number:
            return None
        try:
            return float(value)
        except TypeError:  # a complex constant
            return None


class _Checked:
    """A formula's value while only checking it: the number when it is a known constant, else
    None. Enough to catch division by zero and oversized exponents without sympy."""

    __slots__ = ("value",)

    def __init__(self, value):
        self.value = value

    def _apply(self, other, function):
        a, b = self.value, other.value
        if a is None or b is None:
            return _Checked(None)
        try:
            result = function(a, b)
        except (ArithmeticError, ValueError):
            return _Checked(None)
        return _Checked(result if isinstance(result, float) and math.isfinite(result) else None)

    def __add__(self, other):
        return self._apply(other, lambda a, b: a + b)

    def __sub__(self, other):
        return self._apply(other, lambda a, b: a - b)

    def __mul__(self, other):
        return self._apply(other, lambda a, b: a * b)

    def __truediv__(self, other):
        return self._apply(other, lambda a, b: a / b)

    def __pow__(self, other):
        return self._apply(other, lambda a, b: float(a**b))

    def __neg__(self):
        return _Checked(None if self.value is None else -self.value)


class _CheckAlgebra:
    def __init__(self, variables):
        self.symbols = set(variables)

    def number(self, value: float):
        return _Checked(float(value))

    def symbol(self, name):
        return _Checked(None)

    def constant(self, name):
        return _Checked({"pi": math.pi, "e": math.e}[name])

    def function(self, name, argument):
        return _Checked(None)

    def numeric(self, value) -> float | None:
        return value.value


def _walk(text: str, variables: Sequence[str], parameters: Mapping[str, float] | None,
          algebra):
    parameters = dict(parameters or {})
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError("the formula is empty")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"the formula is longer than {MAX_LENGTH} characters")
    try:
        # '^' means power, as curators write it; as text '**' it also gets the power's precedence.
        tree = ast.parse(text.strip().replace("^", "**"), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"syntax error at column {exc.offset}: {exc.msg}") from None
    clash = set(variables) & (set(parameters) | set(FUNCTION_NAMES) | set(CONSTANT_NAMES))
    if clash:
        raise ExpressionError(f"names used twice: {', '.join(sorted(clash))}")

    def fail(node, reason):
        raise ExpressionError(f"column {getattr(node, 'col_offset', 0) + 1}: {reason}")

    def number(value, node):
        if not math.isfinite(value) or abs(value) > 1e12:
            fail(node, f"number {value!r} is out of range")
        return algebra.number(value)

    def visit(node):
        if isinstance(node, ast.Expression):
            return visit(node.body)
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                fail(node, f"{node.value!r} is not a number")
            return number(node.value, node)
        if isinstance(node, ast.Name):
            if node.id in variables:
                return algebra.symbol(node.id)
            if node.id in parameters:
                return number(float(parameters[node.id]), node)
            if node.id in CONSTANT_NAMES:
                return algebra.constant(node.id)
            known = ", ".join(list(variables) + sorted(parameters) + list(CONSTANT_NAMES))
            fail(node, f"unknown name {node.id!r} (known: {known})")
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = visit(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            left, right = visit(node.left), visit(node.right)
            op = node.op
            if isinstance(op, ast.Add):
                return left + right
            if isinstance(op, ast.Sub):
                return left - right
            if isinstance(op, ast.Mult):
                return left * right
            if isinstance(op, ast.Div):
                if algebra.numeric(right) == 0:
                    fail(node, "division by zero")
                return left / right
            if isinstance(op, ast.Pow):
                exponent = algebra.numeric(right)
                if exponent is not None and abs(exponent) > MAX_EXPONENT:
                    fail(node, f"exponent {exponent:g} is larger than {MAX_EXPONENT}")
                return left**right
            fail(node, f"operator {type(op).__name__} is not allowed (use + - * / ^ or **)")
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTION_NAMES:
                name = getattr(node.func, "id", "this")
                fail(node, f"function {name!r} is not allowed "
                           f"(allowed: {', '.join(FUNCTION_NAMES)})")
            if node.keywords or len(node.args) != 1:
                fail(node, f"{node.func.id} takes exactly one argument")
            return algebra.function(node.func.id, visit(node.args[0]))
        fail(node, f"{type(node).__name__} is not allowed in a formula")

    return visit(tree)


def check_expression(text: str, variables: Sequence[str],
                     parameters: Mapping[str, float] | None = None) -> None:
    """Raise ExpressionError if ``text`` is not an acceptable formula; cheap (no sympy), so scene
    files can be checked when they load."""
    _walk(text, variables, parameters, _CheckAlgebra(variables))


def parse_expression(text: str, variables: Sequence[str],
                     parameters: Mapping[str, float] | None = None) -> "sympy.Expr":
    """Translate ``text`` into a sympy expression in ``variables`` with parameters substituted."""
    algebra = _SympyAlgebra(variables)
    expression = _walk(text, variables, parameters, algebra)
    if not isinstance(expression, algebra.sympy.Expr):
        raise ExpressionError("the formula is not a number-valued expression")
    return expression


# ---------------------------------------------------------------------------- interval arithmetic

#: Outward widening per operation: two ulps of the value (ulp(x) <= |x|·2^-52), plus a floor
#: for results near zero. Cheaper than np.nextafter by about 4x, and never narrower.
_ULPS = 2.0 * 2.0**-52
_FLOOR = 1e-300


def _outward(lo, hi):
    """Widen the bounds so floating-point rounding never shrinks an enclosure."""
    return lo - (np.abs(lo) * _ULPS + _FLOOR), hi + (np.abs(hi) * _ULPS + _FLOOR)


def _mul(a, b):
    products = np.stack([a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]])
    products = np.nan_to_num(products, nan=0.0)  # 0 * inf: the bound is 0 there
    return _outward(products.min(axis=0), products.max(axis=0))


def _integer_power(a, n: int):
    lo, hi = a
    if n == 0:
        return np.ones_like(lo), np.ones_like(hi)
    if n < 0:
        return _reciprocal(_integer_power(a, -n))
    plo, phi = lo**n, hi**n
    if n % 2:  # odd: monotone
        return _outward(plo, phi)
    contains_zero = (lo <= 0) & (hi >= 0)
    low = np.where(contains_zero, 0.0, np.minimum(plo, phi))
    return _outward(low, np.maximum(plo, phi))


def _reciprocal(a):
    lo, hi = a
    spans_zero = (lo <= 0) & (hi >= 0)
    with np.errstate(divide="ignore"):
        rlo, rhi = 1.0 / hi, 1.0 / lo
    return (np.where(spans_zero, -np.inf, rlo), np.where(spans_zero, np.inf, rhi))


def _monotone(function, a, domain_lo=-np.inf):
    lo = np.maximum(a[0], domain_lo)
    hi = np.maximum(a[1], domain_lo)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return _outward(function(lo), function(hi))


def _periodic_extremes(lo, hi, phase):
    """Whether lo..hi contains a point phase + 2πk (where sin or cos peaks)."""
    k = np.ceil((lo - phase) / (2 * np.pi))
    return phase + 2 * np.pi * k <= hi


def _sin(a):
    lo, hi = a
    wide = (hi - lo) >= 2 * np.pi
    slo, shi = np.sin(lo), np.sin(hi)
    low = np.where(_periodic_extremes(lo, hi, -np.pi / 2) | wide, -1.0, np.minimum(slo, shi))
    high = np.where(_periodic_extremes(lo, hi, np.pi / 2) | wide, 1.0, np.maximum(slo, shi))
    return _outward(low, high)


def _abs(a):
    lo, hi = a
    contains_zero = (lo <= 0) & (hi >= 0)
    low = np.where(contains_zero, 0.0, np.minimum(np.abs(lo), np.abs(hi)))
    return low, np.maximum(np.abs(lo), np.abs(hi))


def interval_bounds(expression: sympy.Expr, variables: Sequence[sympy.Symbol], lo: np.ndarray,
                    hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Enclosure of expression over boxes [lo, hi] (shape (N, 4)): the natural interval extension.

    Every value the expression takes in a box lies within the returned bounds (never a box with a
    zero pruned); the bounds may be loose.
    """
    import sympy

    index = {symbol: i for i, symbol in enumerate(variables)}
    count = lo.shape[0]
    cache: dict = {}

    def visit(e):
        if e in cache:
            return cache[e]
        if e in index:
            result = (lo[:, index[e]], hi[:, index[e]])
        elif e.is_number:
            value = float(e)
            result = _outward(np.full(count, value), np.full(count, value))
        elif isinstance(e, sympy.Add):
            parts = [visit(arg) for arg in e.args]
            result = _outward(sum(p[0] for p in parts), sum(p[1] for p in parts))
        elif isinstance(e, sympy.Mul):
            parts = [visit(arg) for arg in e.args]
            result = parts[0]
            for part in parts[1:]:
                result = _mul(result, part)
        elif isinstance(e, sympy.Pow):
            base, exponent = e.args
            if exponent.is_Integer:
                result = _integer_power(visit(base), int(exponent))
            elif exponent == sympy.Rational(1, 2):
                result = _monotone(np.sqrt, visit(base), 0.0)
            elif exponent.is_number:
                p = float(exponent)
                b = visit(base)
                result = _monotone(lambda x: x**p, b, 0.0) if p > 0 else \
                    _reciprocal(_monotone(lambda x: x ** (-p), b, 0.0))
            else:  # x**y = exp(y log x)
                result = visit(sympy.exp(exponent * sympy.log(base)))
        elif isinstance(e, sympy.sin):
            result = _sin(visit(e.args[0]))
        elif isinstance(e, sympy.cos):
            inner = visit(e.args[0])
            result = _sin((inner[0] + np.pi / 2, inner[1] + np.pi / 2))
        elif isinstance(e, sympy.exp):
            result = _monotone(np.exp, visit(e.args[0]))
        elif isinstance(e, sympy.log):
            result = _monotone(np.log, visit(e.args[0]), 0.0)
        elif isinstance(e, sympy.Abs):
            result = _abs(visit(e.args[0]))
        elif isinstance(e, (sympy.sinh, sympy.tanh, sympy.atan)):
            function = {sympy.sinh: np.sinh, sympy.tanh: np.tanh, sympy.atan: np.arctan}[e.func]
            result = _monotone(function, visit(e.args[0]))
        elif isinstance(e, sympy.cosh):
            result = _monotone(np.cosh, _abs(visit(e.args[0])))
        else:  # tan and anything exotic: no useful bound, never prune on it
            result = (np.full(count, -np.inf), np.full(count, np.inf))
        cache[e] = result
        return result

    low, high = visit(expression)
    return np.nan_to_num(low, nan=-np.inf), np.nan_to_num(high, nan=np.inf)


# ---------------------------------------------------------------------------- compiled functions

@dataclass
class ScalarField:
    """f: R^4 -> R with its gradient, vectorised, and box bounds for pruning."""

    expression: sympy.Expr
    symbols: tuple[sympy.Symbol, ...]

    def __post_init__(self) -> None:
        import sympy

        self.gradient_expressions = [sympy.diff(self.expression, s) for s in self.symbols]
        self._value = sympy.lambdify(self.symbols, self.expression, modules="numpy")
        self._gradient = [sympy.lambdify(self.symbols, g, modules="numpy")
                          for g in self.gradient_expressions]

    def value(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        out = self._value(*np.moveaxis(points, -1, 0))
        return np.broadcast_to(np.asarray(out, dtype=float), points.shape[:-1]).copy()

    def gradient(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        coords = np.moveaxis(points, -1, 0)
        parts = [np.broadcast_to(np.asarray(g(*coords), dtype=float), points.shape[:-1])
                 for g in self._gradient]
        return np.stack(parts, axis=-1)

    def bounds(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return interval_bounds(self.expression, self.symbols, lo, hi)


def compile_field(text_or_expression, variables: Sequence[str],
                  parameters: Mapping[str, float] | None = None) -> ScalarField:
    """A ScalarField from a formula string (parsed safely) or a sympy expression."""
    import sympy

    if isinstance(text_or_expression, str):
        expression = parse_expression(text_or_expression, variables, parameters)
    else:
        expression = sympy.sympify(text_or_expression).subs(
            {sympy.Symbol(k, real=True): v for k, v in (parameters or {}).items()})
    symbols = tuple(sympy.Symbol(name, real=True) for name in variables)
    return ScalarField(expression, symbols)
