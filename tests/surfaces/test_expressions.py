"""Formulas from curators: safe parsing, symbolic gradients, and interval bounds that never
exclude a value the function takes."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit.surfaces.expressions import (
    ExpressionError,
    check_expression,
    compile_field,
    parse_expression,
)

V = ("x", "y", "z", "w")


def test_parse_and_gradient_match_finite_differences():
    f = compile_field("x^2 + sin(y*z) - exp(w)/(1 + x**2) + r*sqrt(1 + z^2)", V, {"r": 0.5})
    rng = np.random.default_rng(0)
    p = rng.uniform(-1, 1, (20, 4))
    x, y, z, w = p.T
    expected = x**2 + np.sin(y * z) - np.exp(w) / (1 + x**2) + 0.5 * np.sqrt(1 + z**2)
    np.testing.assert_allclose(f.value(p), expected, rtol=1e-12)
    h = 1e-6
    fd = np.stack([(f.value(p + h * e) - f.value(p - h * e)) / (2 * h) for e in np.eye(4)], -1)
    np.testing.assert_allclose(f.gradient(p), fd, rtol=1e-6, atol=1e-8)


def test_constant_gradients_broadcast():
    f = compile_field("3*x - w", V)
    np.testing.assert_array_equal(f.gradient(np.zeros((5, 4))), np.tile([3, 0, 0, -1], (5, 1)))


@pytest.mark.parametrize("text, message", [
    ("__import__('os').system('true')", "not allowed"),
    ("x.real", "Attribute is not allowed"),
    ("open('f')", "'open' is not allowed"),
    ("q + 1", "unknown name 'q'"),
    ("x +", "syntax error"),
    ("9**9**9", "exponent"),
    ("x / 0", "division by zero"),
    ("x if y else z", "IfExp is not allowed"),
    ("[x]", "List is not allowed"),
    ("'text'", "not a number"),
    ("sin(x, y)", "exactly one argument"),
    ("", "empty"),
    ("x" * 3000, "longer than"),
    ("x < y", "Compare is not allowed"),
    ("lambda: 1", "Lambda is not allowed"),
    ("1e400", "out of range"),
])
@pytest.mark.parametrize("parse", [parse_expression, check_expression])
def test_rejects_anything_but_arithmetic(text, message, parse):
    with pytest.raises(ExpressionError, match=message):
        parse(text, V, {"r": 1.0})


def test_checking_accepts_what_parsing_accepts():
    for text in ("x^2 + sin(y*z) - exp(w)/(1 + x**2) + r*sqrt(1 + z^2)", "2^3^2", "x / (r - 1.5)",
                 "-x^2 + pi * e"):
        check_expression(text, V, {"r": 1.0})
        parse_expression(text, V, {"r": 1.0})


def test_the_kiosk_starts_without_sympy():
    """sympy costs half a second of start-up; a kiosk with a warm mesh cache never needs it."""
    import subprocess
    import sys
    code = ("import sys, exhibit.kiosk.app, exhibit.commands.run, exhibit.scenes; "
            "print('sympy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


formulas = st.sampled_from([
    "x**2 + y**2 - 1", "(y - 0.2*w)**2 + z**2 - 1", "x*y - z*w + sin(x*w)", "cos(3*x) * exp(y) - z",
    "sqrt(x**2 + 1) - abs(y)", "x**3 - 2*x*y**2 + w**4", "1/(2 + x**2) - tanh(z)",
    "log(1 + y**2) * cosh(w) - atan(x)",
])


@settings(max_examples=150, deadline=None)
@given(formulas, st.lists(st.floats(-3, 3), min_size=4, max_size=4),
       st.lists(st.floats(0, 2), min_size=4, max_size=4))
def test_interval_bounds_enclose_sampled_values(text, corner, width):
    f = compile_field(text, V)
    lo = np.array([corner])
    hi = lo + np.array([width])
    low, high = f.bounds(lo, hi)
    samples = lo + np.random.default_rng(1).uniform(0, 1, (400, 4)) * (hi - lo)
    samples = np.vstack([samples, lo, hi])  # the corners too
    values = f.value(samples)
    assert np.all(values >= low[0]) and np.all(values <= high[0])


def test_bounds_of_periodic_functions_reach_their_peaks():
    f = compile_field("sin(x)", V)
    low, high = f.bounds(np.array([[0.0, 0, 0, 0]]), np.array([[math.pi, 0, 0, 0]]))
    assert high[0] >= 1.0 and low[0] <= 0.0 and low[0] > -1e-9


def test_caret_is_power_with_the_precedence_of_mathematics():
    f = compile_field("-x^2 + 1 + z^2", V)
    p = np.array([[3.0, 0, 2.0, 0]])
    assert f.value(p)[0] == -9 + 1 + 4
    assert float(parse_expression("2^3^2", V)) == 512
