"""sympy expressions run as numpy functions: the stand-ins for abs, sign, min and max that keep
derivatives finite at their kinks, sympy's lambdify knowing them, and evaluation that turns
complex values and overflow into NaN and inf for the callers to mask. Apart from the parser
because a ScalarField, the singular-point finder and the interval bounds all use it, on any
sympy expression, whether or not it came from a curator's text."""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from exhibit.surfaces.formula import refusing

if TYPE_CHECKING:  # sympy is imported where it is used: it costs half a second
    import sympy

#: A sympy function class standing in for a non-smooth one (see :func:`kinks`).
_Kink = type["sympy.Function"]


@functools.cache
def kinks() -> tuple[_Kink, _Kink, _Kink, _Kink, dict[str, Callable[..., np.ndarray]]]:
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

    numpy: dict[str, Callable[..., np.ndarray]] = {
        "KinkSign": np.sign,
        "KinkAbs": np.abs,
        "KinkPick": pick,
        "KinkMax": lambda *a: functools.reduce(np.maximum, a),
    }
    return KinkSign, KinkAbs, KinkMax, KinkPick, numpy


def differentiable(expression: sympy.Expr) -> sympy.Expr:
    """The same function with abs, sign, min and max replaced by their kinks() stand-ins."""
    import sympy

    sign, absolute, maximum, _, _ = kinks()
    return (
        expression.replace(sympy.Abs, absolute)
        .replace(sympy.sign, sign)
        .replace(sympy.Max, maximum)
        .replace(sympy.Min, lambda *args: -maximum(*[-a for a in args]))
    )


def lambdify(symbols: Sequence[sympy.Symbol], expression: sympy.Expr) -> Callable[..., np.ndarray]:
    """sympy.lambdify to numpy, knowing the kinks() stand-ins; a Float runs as the same double
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
    return sympy.lambdify(symbols, expression.xreplace(exact), modules=[kinks()[-1], "numpy"])


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
    with np.errstate(all="ignore"), refusing("evaluated"):
        out = np.asarray(function(*axes))
        if np.iscomplexobj(out):
            out = np.where(out.imag == 0, out.real, np.nan)
        return np.broadcast_to(out.astype(float), np.shape(axes[0])).copy()
