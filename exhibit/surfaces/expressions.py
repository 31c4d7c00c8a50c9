"""Scalar functions of R^4 given as formulas: parsed safely, differentiated symbolically (sympy),
evaluated vectorised (numpy) and bounded on boxes (interval arithmetic) for the polygonizer.

Curators write f1, f2 in TOML scene files, so the parser accepts only arithmetic: numbers, the
four coordinates, the scene's parameters, + - * / ^ (** works too), and a short list
of functions. Nothing is ever passed to eval: the text goes through Python's ast parser and each
node is translated by hand into a sympy expression, or rejected with its column.

A formula that is accepted must not fail later, when a scene is built in front of visitors, so
everything that can go wrong is refused up front with an ExpressionError (never another
exception): sizes that blow up recursion or floating point (length, nesting depth, literals,
constants, exponents and the degree they multiply up to), exact infinities and complex values,
and, given the box it is drawn in, formulas that are undefined on most of it. What a sample
cannot rule out (sqrt(x) on a box reaching x < 0) the build masks: no NaN reaches a mesh.

Why one module of this size: the parser, checker, evaluator and differentiator of the curators'
formula language walk the same set of allowed nodes; apart, each would repeat it."""

from __future__ import annotations

import ast
import contextlib
import functools
import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

import numpy as np

if TYPE_CHECKING:  # sympy is imported where it is used: it costs half a second
    import sympy

FUNCTION_NAMES = (
    "sin",
    "cos",
    "tan",
    "exp",
    "log",
    "sqrt",
    "abs",
    "sign",
    "sinh",
    "cosh",
    "tanh",
    "atan",
    "min",
    "max",
)
#: Functions of two or more arguments; the others take exactly one.
VARIADIC = ("min", "max")
CONSTANT_NAMES = ("pi", "e")
MAX_LENGTH = 2000
#: Nesting of functions, powers, signs and brackets, a run of + - (or * /) counting once, as
#: sympy flattens it. Deeper formulas overflow the recursion of sympy's printer and lambdify.
MAX_DEPTH = 32
#: The largest exponent written in a formula, and the degree exponents may multiply up to in
#: nested powers and products (((x^64)^64)^64 has degree 262144); a function call counts as 1.
MAX_EXPONENT = 64
MAX_DEGREE = 256
#: Literals and parameter values, and constant parts of a formula once folded.
MAX_NUMBER = 1e12
MAX_CONSTANT = 1e100
#: check_expression(..., box=...) evaluates the formula at the box's corners, its centre and this
#: many seeded random points, and refuses it when the value or the gradient is not a finite real
#: number at more than MAX_UNDEFINED of them (undefined on almost all of the box is a mistake;
#: on a part of it, e.g. sqrt(x) on x in [-1, 1], the build drops those vertices).
SAMPLES = 256
MAX_UNDEFINED = 0.9


class ExpressionError(ValueError):
    """A formula that cannot be accepted; the message names the column and the reason."""


class _Refused(Exception):
    """Raised by an algebra inside the walk; the walk turns it into an ExpressionError naming
    the column of the node that produced it."""


@contextlib.contextmanager
def _refusing(action: str):
    """Whatever sympy or numpy raise on a formula reaches the caller as an ExpressionError."""
    try:
        yield
    except ExpressionError:
        raise
    except Exception as exc:  # noqa: BLE001 - the public boundary: one exception type out
        raise ExpressionError(
            f"the formula could not be {action}: {type(exc).__name__}: {exc}"[:300]
        ) from exc


# ---------------------------------------------------------------------------- parsing


@dataclass(frozen=True, slots=True)
class _Checked:
    """A formula part while only checking it (no sympy): its value when it is a known constant,
    and its degree, so exponent towers are caught however they are written."""

    value: float | None
    degree: float


_MATH = {
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "exp": math.exp,
    "log": math.log,
    "sqrt": math.sqrt,
    "abs": abs,
    "sign": lambda v: math.copysign(v != 0, v),
    "sinh": math.sinh,
    "cosh": math.cosh,
    "tanh": math.tanh,
    "atan": math.atan,
    "min": min,
    "max": max,
}


class _CheckAlgebra:
    """Folds constants in floating point (refusing division by zero, complex and oversized
    values) and tracks degrees; cheap enough for checking scene files at start-up."""

    def number(self, value):
        return _Checked(float(value), 0.0)

    def symbol(self, name):
        return _Checked(None, 1.0)

    def constant(self, name):
        return _Checked({"pi": math.pi, "e": math.e}[name], 0.0)

    def numeric(self, part) -> float | None:
        return part.value

    def _result(self, compute, parts, degree, partial=False):
        """compute() of the parts' values when all are known; with ``partial`` (sums and
        products) the known ones are folded and checked even if others are not (10^60*x*10^60
        is refused: sympy would print 10^120 as an integer numpy cannot take)."""
        if degree > MAX_DEGREE:
            raise _Refused(
                f"degree {degree:g} is above {MAX_DEGREE} (exponents multiply when "
                "powers are nested)"
            )
        known = [p for p in parts if p.value is not None]
        if len(known) < len(parts):
            if partial and len(known) > 1:
                self._result(compute, known, 0.0)
            return _Checked(None, degree)
        try:
            value = compute(*(p.value for p in parts))
        except ZeroDivisionError:
            raise _Refused("division by zero") from None
        except OverflowError:
            raise _Refused(f"a constant is larger than {MAX_CONSTANT:g}") from None
        except ValueError:
            raise _Refused("undefined for this argument") from None
        if isinstance(value, complex):
            raise _Refused("a constant is not a real number")
        if not math.isfinite(value) or abs(value) > MAX_CONSTANT:
            raise _Refused(f"a constant is larger than {MAX_CONSTANT:g}")
        return _Checked(float(value), degree)

    def add(self, terms):
        return self._result(lambda *v: math.fsum(v), terms, max(t.degree for t in terms), True)

    def mul(self, factors):
        return self._result(lambda *v: math.prod(v), factors, sum(f.degree for f in factors), True)

    def negate(self, part):
        return _Checked(None if part.value is None else -part.value, part.degree)

    def reciprocal(self, part):
        return self._result(lambda v: 1.0 / v, [part], part.degree)

    def power(self, base, exponent):
        if exponent.value is None:
            degree = max(base.degree, 1.0)
        else:
            degree = base.degree * abs(exponent.value)
        return self._result(lambda b, x: b**x, [base, exponent], degree)

    def function(self, name, args):
        degree = {
            "abs": args[0].degree,
            "sqrt": args[0].degree / 2,
            "min": max(a.degree for a in args),
            "max": max(a.degree for a in args),
        }.get(name, 1.0 if any(a.value is None for a in args) else 0.0)
        return self._result(_MATH[name], args, degree)


class _SympyAlgebra:
    """Builds the sympy expression (imported only here: it costs half a second at start-up),
    refusing parts that sympy evaluates exactly to an infinity or a complex number."""

    def __init__(self, variables):
        import sympy

        self.sympy = sympy
        self.symbols = {name: sympy.Symbol(name, real=True) for name in variables}
        self.functions = {
            "sin": sympy.sin,
            "cos": sympy.cos,
            "tan": sympy.tan,
            "exp": sympy.exp,
            "log": sympy.log,
            "sqrt": sympy.sqrt,
            "abs": sympy.Abs,
            "sign": sympy.sign,
            "sinh": sympy.sinh,
            "cosh": sympy.cosh,
            "tanh": sympy.tanh,
            "atan": sympy.atan,
            "min": sympy.Min,
            "max": sympy.Max,
        }
        self.constants = {"pi": sympy.pi, "e": sympy.E}

    def number(self, value: float):
        if float(value).is_integer() and abs(value) <= 10**6:
            return self.sympy.Integer(int(value))
        return self.sympy.Float(value)

    def symbol(self, name):
        return self.symbols[name]

    def constant(self, name):
        return self.constants[name]

    def numeric(self, value) -> float | None:
        if not value.is_number:
            return None
        try:
            return float(value)
        except TypeError:  # a complex constant
            return None

    def _real(self, result):
        s = self.sympy.S
        if result.has(s.ComplexInfinity, s.Infinity, s.NegativeInfinity, s.NaN):
            raise _Refused("the value is infinite or undefined (e.g. tan(pi/2), log(0))")
        if result.has(s.ImaginaryUnit) or (result.is_number and result.is_extended_real is False):
            raise _Refused("the value is not a real number (e.g. sqrt(-1))")
        return result

    def add(self, terms):
        return self.sympy.Add(*terms)

    def mul(self, factors):
        return self._real(self.sympy.Mul(*factors))

    def negate(self, part):
        return -part

    def reciprocal(self, part):
        return self._real(1 / part)

    def power(self, base, exponent):
        return self._real(base**exponent)

    def function(self, name, args):
        return self._real(self.functions[name](*args))


_KIND = {ast.Add: "sum", ast.Sub: "sum", ast.Mult: "product", ast.Div: "product"}


def _kind(node) -> str | None:
    return _KIND.get(type(node.op)) if isinstance(node, ast.BinOp) else None


def _operands(node: ast.BinOp) -> list[tuple[ast.expr, bool]]:
    """The terms of a run of + and - (or the factors of * and /), each with whether it is
    subtracted (divided by); without recursion, so a sum of a thousand terms is fine."""
    kind = _kind(node)
    out: list[tuple[ast.expr, bool]] = []
    stack: list[tuple[ast.expr, bool]] = [(node, False)]
    while stack:
        part, inverted = stack.pop()
        if _kind(part) == kind and isinstance(part, ast.BinOp):
            stack.append((part.right, inverted ^ isinstance(part.op, (ast.Sub, ast.Div))))
            stack.append((part.left, inverted))
        else:
            out.append((part, inverted))
    return out


def _too_deep(tree: ast.Expression) -> ast.AST | None:
    """The first node nested deeper than MAX_DEPTH, found without recursion (the text may be a
    thousand unary minus signs)."""
    stack: list[tuple[ast.expr, int, str | None]] = [(tree.body, 0, None)]
    while stack:
        node, depth, parent_kind = stack.pop()
        kind = _kind(node)
        if kind is None or kind != parent_kind:
            depth += 1
        if depth > MAX_DEPTH:
            return node
        stack.extend(
            (child, depth, kind)
            for child in ast.iter_child_nodes(node)
            if isinstance(child, ast.expr)
        )
    return None


def _walk(text: str, variables: Sequence[str], parameters: Mapping[str, float] | None, algebra):
    parameters = dict(parameters or {})
    if not isinstance(text, str):
        raise ExpressionError(f"the formula must be text, not {type(text).__name__}")
    source = text.strip()
    if not source:
        raise ExpressionError("the formula is empty")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"the formula is longer than {MAX_LENGTH} characters")
    # '^' means power, as curators write it; as text '**' it also gets the power's precedence.
    # Columns are reported in the curator's text, so each '^' counts once.
    lead = len(text) - len(text.lstrip())
    columns = [lead + i + 1 for i, ch in enumerate(source) for _ in range(2 if ch == "^" else 1)]

    def column(offset: int) -> int:
        return columns[max(0, min(offset, len(columns) - 1))]

    try:
        tree = ast.parse(source.replace("^", "**"), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(
            f"syntax error at column {column((exc.offset or 1) - 1)}: {exc.msg}"
        ) from None
    except (RecursionError, MemoryError):
        raise ExpressionError("the formula is nested too deeply to read") from None
    except ValueError as exc:  # e.g. a NUL character
        raise ExpressionError(f"the formula cannot be read: {exc}") from None
    clash = set(variables) & (set(parameters) | set(FUNCTION_NAMES) | set(CONSTANT_NAMES))
    if clash:
        raise ExpressionError(f"names used twice: {', '.join(sorted(clash))}")

    def fail(node, reason):
        raise ExpressionError(f"column {column(getattr(node, 'col_offset', 0))}: {reason}")

    deep = _too_deep(tree)
    if deep is not None:
        fail(
            deep,
            f"nested more than {MAX_DEPTH} levels deep (functions, powers, signs and "
            "brackets inside each other)",
        )

    def snippet(node) -> str:
        """The node's text as the curator wrote it, shortened."""
        part = text[column(node.col_offset) - 1 : column(node.end_col_offset - 1)]
        return part if len(part) <= 40 else part[:37] + "..."

    def apply(node, operation, *args):
        try:
            return operation(*args)
        except _Refused as exc:
            fail(node, f"{snippet(node)}: {exc}")

    def number(value, node, what="number"):
        if isinstance(value, float) and not math.isfinite(value) or abs(value) > MAX_NUMBER:
            shown = f"{value:.6g}" if isinstance(value, float) else f"{value!r:.40}"
            fail(node, f"{what} {shown} is out of range (at most {MAX_NUMBER:g})")
        return algebra.number(value)

    def visit(node):
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                fail(node, f"{node.value!r:.40} is not a number")
            return number(node.value, node)
        if isinstance(node, ast.Name):
            if node.id in variables:
                return algebra.symbol(node.id)
            if node.id in parameters:
                return number(float(parameters[node.id]), node, f"parameter {node.id} =")
            if node.id in CONSTANT_NAMES:
                return algebra.constant(node.id)
            known = ", ".join(list(variables) + sorted(parameters) + list(CONSTANT_NAMES))
            fail(node, f"unknown name {node.id!r} (known: {known})")
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = visit(node.operand)
            return algebra.negate(operand) if isinstance(node.op, ast.USub) else operand
        if _kind(node) == "sum":
            terms = [
                algebra.negate(visit(part)) if minus else visit(part)
                for part, minus in _operands(node)
            ]
            return apply(node, algebra.add, terms)
        if _kind(node) == "product":
            factors = []
            for part, divided in _operands(node):
                factor = visit(part)
                if divided:
                    if algebra.numeric(factor) == 0:
                        fail(part, f"division by zero ({snippet(part)} is 0)")
                    factor = apply(part, algebra.reciprocal, factor)
                factors.append(factor)
            return apply(node, algebra.mul, factors)
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            base, exponent = visit(node.left), visit(node.right)
            value = algebra.numeric(exponent)
            if value is not None and abs(value) > MAX_EXPONENT:
                fail(node, f"exponent {value:g} is larger than {MAX_EXPONENT}")
            return apply(node, algebra.power, base, exponent)
        if isinstance(node, ast.BinOp):
            fail(node, f"operator {type(node.op).__name__} is not allowed (use + - * / ^ or **)")
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTION_NAMES:
                name = getattr(node.func, "id", "this")
                fail(
                    node, f"function {name!r} is not allowed (allowed: {', '.join(FUNCTION_NAMES)})"
                )
            name = node.func.id  # type: ignore[attr-defined]  # fail() raised otherwise
            if name in VARIADIC:
                if node.keywords or len(node.args) < 2:
                    fail(node, f"{name} takes two or more arguments")
            elif node.keywords or len(node.args) != 1:
                fail(node, f"{name} takes exactly one argument")
            return apply(node, algebra.function, name, [visit(a) for a in node.args])
        fail(node, f"{type(node).__name__} is not allowed in a formula")

    return visit(tree.body)


def check_expression(
    text: str,
    variables: Sequence[str],
    parameters: Mapping[str, float] | None = None,
    box: Sequence[tuple[float, float]] | None = None,
) -> None:
    """Raise ExpressionError (and nothing else) if ``text`` is not a formula the exhibit can draw.

    Without ``box`` the check is structural and needs no sympy (cheap at start-up): syntax,
    names, sizes, nesting depth, exponents and degree, and constant parts folded in floating
    point. With ``box``, one (low, high) per variable, the formula is also compiled exactly as a
    build compiles it (so x/sin(pi) or tan(pi/2) are refused as sympy sees them) and its value
    and gradient are evaluated on a fixed sample of the box (its corners, its centre and SAMPLES
    seeded random points): more than MAX_UNDEFINED of them non-finite or complex is refused.
    """
    with _refusing("checked"):
        _walk(text, variables, parameters, _CheckAlgebra())
        if box is not None:
            _check_sample(compile_field(text, variables, parameters), variables, box)


def _sample(box, variables) -> np.ndarray:
    try:
        box = np.asarray(box, dtype=float)
    except (TypeError, ValueError):
        box = np.zeros(0)
    if (
        box.shape != (len(variables), 2)
        or not np.all(np.isfinite(box))
        or np.any(box[:, 1] <= box[:, 0])
    ):
        raise ExpressionError(
            f"the box must be {len(variables)} finite (low, high) pairs with low < high"
        )
    lo, hi = box.T
    corners = np.array(list(itertools.product((0.0, 1.0), repeat=len(lo))))
    inside = np.random.default_rng(0).random((SAMPLES, len(lo)))
    return lo + np.vstack([corners, np.full(len(lo), 0.5), inside]) * (hi - lo)


def _check_sample(field: ScalarField, variables, box) -> None:
    points = _sample(box, variables)
    value, gradient = field.value(points), field.gradient(points)
    bad = ~(np.isfinite(value) & np.all(np.isfinite(gradient), axis=-1))
    if bad.mean() > MAX_UNDEFINED:
        first = int(np.argmax(bad))
        what = "value" if not np.isfinite(value[first]) else "gradient"
        where = ", ".join(f"{n} = {v:.3g}" for n, v in zip(variables, points[first]))
        raise ExpressionError(
            f"not a finite real number on {bad.mean():.0%} of the box "
            f"(e.g. its {what} at {where}); at most {MAX_UNDEFINED:.0%} of "
            "it may be undefined"
        )


def parse_expression(
    text: str, variables: Sequence[str], parameters: Mapping[str, float] | None = None
) -> "sympy.Expr":
    """Translate ``text`` into a sympy expression in ``variables`` with parameters substituted.

    The cheap check runs first, so sympy never sees a formula that could exhaust it."""
    with _refusing("parsed"):
        _walk(text, variables, parameters, _CheckAlgebra())
        algebra = _SympyAlgebra(variables)
        expression = _walk(text, variables, parameters, algebra)
        if not isinstance(expression, algebra.sympy.Expr):
            raise ExpressionError("the formula is not a number-valued expression")
        return expression


# ---------------------------------------------------------------------------- non-smooth functions


@functools.cache
def _kinks():
    """sympy functions standing in for abs, sign and max while differentiating.

    sympy differentiates Abs(u) for a u it cannot prove real (log(x), x^y) into re/im terms and
    unevaluated Derivatives that lambdify cannot print, and sign into DiracDelta; rewriting to
    Piecewise grows exponentially with nesting. These have the derivative almost everywhere
    instead, finite at the kinks too, which is what Newton and Gauss-Newton need: sign(u) u' for
    |u|, 0 for sign(u), and for max the derivative of its (first) largest argument, picked, not
    multiplied by an indicator, so an infinite derivative of an argument that is not the
    largest (log|y| at y = 0 in max(log(abs(y)), z)) does not make a NaN. min is -max(-a, ...).
    """
    import sympy

    class KinkSign(sympy.Function):
        nargs = 1

        def fdiff(self, argindex=1):
            return sympy.S.Zero

    class KinkAbs(sympy.Function):
        nargs = 1

        def fdiff(self, argindex=1):
            return KinkSign(self.args[0])

    class KinkPick(sympy.Function):
        """KinkPick(a1, ..., an, d1, ..., dn): d_i for the first largest a_i."""

        @classmethod
        def eval(cls, *args):
            picks = args[len(args) // 2 :]
            if all(d == picks[0] for d in picks):
                return picks[0]
            return None

        def _eval_derivative(self, s):
            n = len(self.args) // 2
            return KinkPick(*self.args[:n], *[d.diff(s) for d in self.args[n:]])

    class KinkMax(sympy.Function):
        def _eval_derivative(self, s):
            return KinkPick(*self.args, *[a.diff(s) for a in self.args])

    def pick(*args):
        arrays = np.broadcast_arrays(*args)
        n = len(arrays) // 2
        first = np.argmax(np.stack(arrays[:n]), axis=0)
        return np.take_along_axis(np.stack(arrays[n:]), first[None], axis=0)[0]

    numpy = {
        "KinkSign": np.sign,
        "KinkAbs": np.abs,
        "KinkPick": pick,
        "KinkMax": lambda *a: functools.reduce(np.maximum, a),
    }
    return KinkSign, KinkAbs, KinkMax, KinkPick, numpy


def differentiable(expression: sympy.Expr) -> sympy.Expr:
    """The same function with abs, sign, min and max replaced by their _kinks() stand-ins."""
    import sympy

    sign, absolute, maximum, _, _ = _kinks()
    return (
        expression.replace(sympy.Abs, absolute)
        .replace(sympy.sign, sign)
        .replace(sympy.Max, maximum)
        .replace(sympy.Min, lambda *args: -maximum(*[-a for a in args]))
    )


def lambdify(symbols, expression) -> Callable:
    """sympy.lambdify to numpy, knowing the _kinks() stand-ins; a Float runs as the same double
    as float() gives (interval bounds rely on it), and an integer too large for a double as
    inf, which the callers mask."""
    import sympy

    # sympy keeps exact integers (10^12 to the 64th); numpy cannot take those beyond a float.
    # Floats are printed with 15 digits, which is not the double they stand for: 30 digits is.
    exact = {n: sympy.Float(n, 30) for n in expression.atoms(sympy.Float)}
    exact.update(
        {
            n: sympy.Float(n)
            for n in expression.atoms(sympy.Rational)
            if max(abs(n.p), n.q) > 2**1000
        }
    )
    return sympy.lambdify(symbols, expression.xreplace(exact), modules=[_kinks()[-1], "numpy"])


def evaluate(function: Callable, points: np.ndarray) -> np.ndarray:
    """A lambdified function at points (..., n) as real floats of shape (...): complex values
    become NaN and overflow inf, silently (the callers mask them); a failure is an
    ExpressionError."""
    points = np.asarray(points, dtype=float)
    return evaluate_axes(function, tuple(np.moveaxis(points, -1, 0)))


def evaluate_axes(function: Callable, axes: Sequence[np.ndarray]) -> np.ndarray:
    """As evaluate, with the points given as one array per coordinate (all of one shape).
    Contiguous per-axis arrays make numpy's loops about 1.7x faster than the strided columns
    of an (..., n) array (the polygonizer's grid corners, docs/PERFORMANCE.md)."""
    with np.errstate(all="ignore"), _refusing("evaluated"):
        out = np.asarray(function(*axes))
        if np.iscomplexobj(out):
            out = np.where(out.imag == 0, out.real, np.nan)
        return np.broadcast_to(out.astype(float), np.shape(axes[0])).copy()


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
    if n % 2:  # odd: monotone
        return _outward(lo**n, hi**n)
    # even: |x|^n over the interval; the nearest |x| to zero is max(0, lo, -hi) and the farthest
    # max(-lo, hi) (fewer passes over the arrays than testing whether the interval holds 0)
    nearest = np.maximum(np.maximum(lo, -hi), 0.0)
    return _outward(nearest**n, np.maximum(-lo, hi) ** n)


def _reciprocal(a):
    lo, hi = a
    spans_zero = (lo <= 0) & (hi >= 0)
    rlo, rhi = 1.0 / hi, 1.0 / lo
    return (np.where(spans_zero, -np.inf, rlo), np.where(spans_zero, np.inf, rhi))


def _monotone(function, a, domain_lo=-np.inf):
    lo = np.maximum(a[0], domain_lo)
    hi = np.maximum(a[1], domain_lo)
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


def interval_bounds(
    expression: sympy.Expr, variables: Sequence[sympy.Symbol], lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Enclosure of expression over boxes [lo, hi] (shape (N, 4)): the natural interval extension.

    Every finite value the expression takes in a box lies within the returned bounds (never a
    box with a zero pruned); the bounds may be loose, and infinite where nothing better is known.
    """
    import sympy

    sign, absolute, maximum, pick, _ = _kinks()
    index = {symbol: i for i, symbol in enumerate(variables)}
    count = lo.shape[0]
    # Contiguous per-variable columns (numpy's loops run ~1.7x faster than on strided columns);
    # constants stay scalars (broadcast) instead of arrays of `count` equal values.
    lo_columns, hi_columns = np.ascontiguousarray(lo.T), np.ascontiguousarray(hi.T)
    unbounded = (np.float64(-np.inf), np.float64(np.inf))
    cache: dict = {}

    def visit(e):
        if e in cache:
            return cache[e]
        if e in index:
            result = (lo_columns[index[e]], hi_columns[index[e]])
        elif e.is_Number or e.is_NumberSymbol:  # constant parts are bounded operation by
            value = np.float64(float(e))  # operation, as numpy rounds them
            result = _outward(value, value)
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
            if exponent.is_Number and float(exponent).is_integer():  # 3 or 3.0
                result = _integer_power(visit(base), int(exponent))
            elif exponent == sympy.Rational(1, 2):
                result = _monotone(np.sqrt, visit(base), 0.0)
            elif exponent.is_Number:
                p = float(exponent)
                b = visit(base)
                result = (
                    _monotone(lambda x: x**p, b, 0.0)
                    if p > 0
                    else _reciprocal(_monotone(lambda x: x ** (-p), b, 0.0))
                )
            else:  # |x**y| = exp(y log|x|), in intervals (in sympy it folds back to x**y);
                b = visit(base)  # numpy gives x < 0 a value (of either sign) at whole y
                log_size = _monotone(np.log, _abs(b), 0.0)
                size = _monotone(np.exp, _mul(visit(exponent), log_size))
                result = (np.where(b[0] < 0, -size[1], size[0]), size[1])
        elif isinstance(e, sympy.sin):
            result = _sin(visit(e.args[0]))
        elif isinstance(e, sympy.cos):
            inner = visit(e.args[0])
            result = _sin((inner[0] + np.pi / 2, inner[1] + np.pi / 2))
        elif isinstance(e, sympy.exp):
            result = _monotone(np.exp, visit(e.args[0]))
        elif isinstance(e, sympy.log):
            result = _monotone(np.log, visit(e.args[0]), 0.0)
        elif isinstance(e, (sympy.Abs, absolute)):
            result = _abs(visit(e.args[0]))
        elif isinstance(e, (sympy.sign, sign)):  # monotone, and exact: no widening
            inner = visit(e.args[0])
            result = (np.sign(inner[0]), np.sign(inner[1]))
        elif isinstance(e, (sympy.Max, sympy.Min, maximum)):  # monotone in every argument
            extreme = np.minimum if isinstance(e, sympy.Min) else np.maximum
            parts = [visit(arg) for arg in e.args]
            result = (
                functools.reduce(extreme, [p[0] for p in parts]),
                functools.reduce(extreme, [p[1] for p in parts]),
            )
        elif isinstance(e, pick):  # one of its second half of arguments
            parts = [visit(arg) for arg in e.args[len(e.args) // 2 :]]
            result = (
                functools.reduce(np.minimum, [p[0] for p in parts]),
                functools.reduce(np.maximum, [p[1] for p in parts]),
            )
        elif isinstance(e, (sympy.sinh, sympy.tanh, sympy.atan)):
            function = {sympy.sinh: np.sinh, sympy.tanh: np.tanh, sympy.atan: np.arctan}[e.func]
            result = _monotone(function, visit(e.args[0]))
        elif isinstance(e, sympy.cosh):
            result = _monotone(np.cosh, _abs(visit(e.args[0])))
        else:  # tan and anything exotic: no useful bound, never prune on it
            result = unbounded
        cache[e] = result
        return result

    with np.errstate(all="ignore"):  # overflow to inf is a valid (loose) bound
        low, high = visit(expression)
    low = np.broadcast_to(np.nan_to_num(low, nan=-np.inf), (count,)).copy()
    high = np.broadcast_to(np.nan_to_num(high, nan=np.inf), (count,)).copy()
    return low, high


# ---------------------------------------------------------------------------- compiled functions


@dataclass
class ScalarField:
    """f: R^4 -> R with its gradient, vectorised, and box bounds for pruning.

    ``differentiable`` is the expression with abs, sign, min and max in their differentiable
    stand-ins (see _kinks); gradients and everything built from them use it."""

    expression: sympy.Expr
    symbols: tuple[sympy.Symbol, ...]

    def __post_init__(self) -> None:
        import sympy

        self.differentiable = differentiable(self.expression)
        self.gradient_expressions = [sympy.diff(self.differentiable, s) for s in self.symbols]
        self._value = lambdify(self.symbols, self.differentiable)
        self._gradient = [lambdify(self.symbols, g) for g in self.gradient_expressions]

    def value(self, points: np.ndarray) -> np.ndarray:
        """Values at points (..., n); NaN or inf where the formula is undefined or overflows."""
        return evaluate(self._value, points)

    def value_on_axes(self, axes: Sequence[np.ndarray]) -> np.ndarray:
        """Values at points given as one array per coordinate (see evaluate_axes)."""
        return evaluate_axes(self._value, axes)

    def gradient(self, points: np.ndarray) -> np.ndarray:
        axes = tuple(np.ascontiguousarray(np.moveaxis(np.asarray(points, dtype=float), -1, 0)))
        return np.stack([evaluate_axes(g, axes) for g in self._gradient], axis=-1)

    def bounds(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return interval_bounds(self.expression, self.symbols, lo, hi)


def compile_field(
    text_or_expression, variables: Sequence[str], parameters: Mapping[str, float] | None = None
) -> ScalarField:
    """A ScalarField from a formula string (parsed safely) or a sympy expression; any failure is
    an ExpressionError (parameter values that differ from the checked ones can still divide by
    zero, e.g. x/(a - 1) at a = 1)."""
    with _refusing("compiled"):
        import sympy

        if isinstance(text_or_expression, str):
            expression = parse_expression(text_or_expression, variables, parameters)
        else:
            expression = sympy.sympify(text_or_expression).subs(
                {sympy.Symbol(k, real=True): v for k, v in (parameters or {}).items()}
            )
        symbols = tuple(sympy.Symbol(name, real=True) for name in variables)
        return ScalarField(expression, symbols)
