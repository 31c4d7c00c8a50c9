"""The curators' formula language: f1, f2 in TOML scene files, parsed safely into sympy.

The parser accepts only arithmetic: numbers, the four coordinates, the scene's parameters,
+ - * / ^ (** works too), and a short list of functions. Nothing is ever passed to eval: the text
goes through Python's ast parser and each node is translated by hand into a sympy expression, or
rejected with its column.

A formula that is accepted must not fail later, when a scene is built in front of visitors, so
everything that can go wrong in its text is refused up front with an ExpressionError (never
another exception): sizes that blow up recursion or floating point (length, nesting depth,
literals, constants, exponents and the degree they multiply up to), exact infinities and complex
values. One walk over the allowed nodes serves both the cheap check (no sympy, at start-up) and
the translation, each with its own algebra; what a formula does on a box, and the numpy
functions built from it, are :mod:`exhibit.surfaces.expressions`.

Why one module of this size: the checker and the translator walk the same set of allowed nodes
with the same limits; apart, each would repeat it."""

from __future__ import annotations

import ast
import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING
from collections.abc import Mapping, Sequence

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


class ExpressionError(ValueError):
    """A formula that cannot be accepted; the message names the column and the reason."""


class _Refused(Exception):
    """Raised by an algebra inside the walk; the walk turns it into an ExpressionError naming
    the column of the node that produced it."""


@contextlib.contextmanager
def refusing(action: str) -> Iterator[None]:
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


def check_structure(
    text: str, variables: Sequence[str], parameters: Mapping[str, float] | None = None
) -> None:
    """ExpressionError unless ``text`` is a formula in the language, within every limit; no
    sympy (cheap at start-up)."""
    with refusing("checked"):
        _walk(text, variables, parameters, _CheckAlgebra())


def parse_expression(
    text: str, variables: Sequence[str], parameters: Mapping[str, float] | None = None
) -> sympy.Expr:
    """Translate ``text`` into a sympy expression in ``variables`` with parameters substituted.

    The cheap check runs first, so sympy never sees a formula that could exhaust it."""
    with refusing("parsed"):
        _walk(text, variables, parameters, _CheckAlgebra())
        algebra = _SympyAlgebra(variables)
        expression = _walk(text, variables, parameters, algebra)
        if not isinstance(expression, algebra.sympy.Expr):
            raise ExpressionError("the formula is not a number-valued expression")
        return expression
