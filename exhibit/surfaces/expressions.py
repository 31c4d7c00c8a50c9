"""Scalar functions of R^4 given as formulas: parsed safely (:mod:`exhibit.surfaces.formula`),
differentiated symbolically (sympy), evaluated vectorised (numpy,
:mod:`exhibit.surfaces.evaluation`) and bounded on boxes (:mod:`exhibit.surfaces.intervals`) for
the polygonizer. This is where callers get them: :func:`compile_field` and :class:`ScalarField`,
and :func:`check_expression`, which, given the box a formula is drawn in, also refuses formulas
that are undefined on most of it. What a sample cannot rule out (sqrt(x) on a box reaching
x < 0) the build masks: no NaN reaches a mesh."""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from exhibit.surfaces.evaluation import differentiable, evaluate, evaluate_axes, lambdify
from exhibit.surfaces.formula import (
    FUNCTION_NAMES,
    MAX_LENGTH,
    ExpressionError,
    check_structure,
    parse_expression,
    refusing,
)
from exhibit.surfaces.intervals import interval_bounds

if TYPE_CHECKING:  # sympy is imported where it is used: it costs half a second
    import sympy

#: The formula language's names that callers check scene files against, here with the field.
__all__ = [
    "FUNCTION_NAMES",
    "MAX_LENGTH",
    "MAX_UNDEFINED",
    "SAMPLES",
    "ExpressionError",
    "ScalarField",
    "check_expression",
    "compile_field",
    "parse_expression",
]

#: check_expression(..., box=...) evaluates the formula at the box's corners, its centre and this
#: many seeded random points, and refuses it when the value or the gradient is not a finite real
#: number at more than MAX_UNDEFINED of them (undefined on almost all of the box is a mistake;
#: on a part of it, e.g. sqrt(x) on x in [-1, 1], the build drops those vertices).
SAMPLES = 256
MAX_UNDEFINED = 0.9


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
    check_structure(text, variables, parameters)
    with refusing("checked"):
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


@dataclass
class ScalarField:
    """f: R^4 -> R with its gradient, vectorised, and box bounds for pruning.

    ``differentiable`` is the expression with abs, sign, min and max in their differentiable
    stand-ins (see evaluation.kinks); gradients and everything built from them use it."""

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
    text_or_expression: str | sympy.Expr,
    variables: Sequence[str],
    parameters: Mapping[str, float] | None = None,
) -> ScalarField:
    """A ScalarField from a formula string (parsed safely) or a sympy expression; any failure is
    an ExpressionError (parameter values that differ from the checked ones can still divide by
    zero, e.g. x/(a - 1) at a = 1)."""
    with refusing("compiled"):
        import sympy

        if isinstance(text_or_expression, str):
            expression = parse_expression(text_or_expression, variables, parameters)
        else:
            expression = sympy.sympify(text_or_expression).subs(
                {sympy.Symbol(k, real=True): v for k, v in (parameters or {}).items()}
            )
        symbols = tuple(sympy.Symbol(name, real=True) for name in variables)
        return ScalarField(expression, symbols)
