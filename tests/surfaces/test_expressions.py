"""Formulas from curators: safe parsing, symbolic gradients, and interval bounds that never
exclude a value the function takes."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit.surfaces import formula
from exhibit.surfaces.expressions import (
    ExpressionError,
    check_expression,
    compile_field,
    parse_expression,
)
from tests.hypothesis_profiles import examples

V = ("x", "y", "z", "w")
BOX = [(-1.0, 1.0)] * 4


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


@pytest.mark.parametrize(
    "text, message",
    [
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
        ("1" + "0" * 399, "out of range"),
        ("((x^64)^64)^64", "degree 4096 is above"),
        ("(x^16)^16 * y", "degree 257 is above"),
        ("sin(" * 200 + "x" + ")" * 200, "nested more than"),
        ("-" * 999 + "x", "nested more than"),
        ("x+sqrt(-1)", "sqrt\\(-1\\): undefined"),
        ("log(0) + x", "log\\(0\\): undefined"),
        ("(-8)^(1/3) + x", "not a real number"),
        ("exp(1000) * x", "larger than"),
        ("10^60 * x * 10^60", "larger than"),
        ("max(x)", "two or more"),
        ("sign(x, y)", "exactly one"),
        ("x / (r - 1)", "division by zero"),
    ],
)
@pytest.mark.parametrize("parse", [parse_expression, check_expression])
def test_rejects_anything_but_arithmetic(text, message, parse):
    with pytest.raises(ExpressionError, match=message):
        parse(text, V, {"r": 1.0})


@pytest.mark.parametrize(
    "text, message",
    [
        ("x/sin(pi)", "division by zero \\(sin\\(pi\\) is 0\\)"),
        ("1/(x-x)", "division by zero"),
        ("tan(pi/2)+x", "column 1: tan\\(pi/2\\): the value is infinite"),
        ("sqrt(-x^2 - 1)", "on 100% of the box"),
        ("log(-1-x^2)", "not a finite real number on 100% of the box"),
        ("sqrt(x) + sqrt(y) + sqrt(z) + sqrt(w)", "on 95% of the box"),
        ("(x*10^12)^64", "on 100% of the box"),
    ],
)
def test_the_box_check_refuses_what_fails_when_built(text, message):
    """Exact simplification and evaluation on the box catch what the cheap check cannot; each is
    also refused by compile_field or on evaluation, so accepting it would fail later."""
    check_expression(text, V, {"r": 1.0})  # structurally fine
    with pytest.raises(ExpressionError, match=message):
        check_expression(text, V, {"r": 1.0}, box=BOX)


def test_formulas_undefined_on_part_of_the_box_are_accepted():
    """The build drops vertices where the value is not finite; refusing is for most of the box."""
    for text in ("sqrt(x) - y", "log(x^2) + y", "sqrt(1 - x^2 - y^2) - z", "1/x + y"):
        check_expression(text, V, None, box=BOX)


def test_the_box_must_fit_the_variables():
    for box in ([(-1, 1)] * 3, [(1, -1)] * 4, [(0, float("inf"))] * 4, "box"):
        with pytest.raises(ExpressionError, match="box must be"):
            check_expression("x", V, None, box=box)


def test_columns_are_those_of_the_text_as_written():
    with pytest.raises(ExpressionError, match="column 10: unknown name 'q'"):
        check_expression(" x^2^2 + q", V)
    with pytest.raises(ExpressionError, match="column 5: \\(x\\^64\\)\\^8: degree"):
        check_expression("y + (x^64)^8", V)


def test_anything_sympy_raises_becomes_an_expression_error(monkeypatch):
    def broken(*args):
        raise RuntimeError("sympy broke")

    monkeypatch.setattr(formula._SympyAlgebra, "function", broken)
    for call in (
        lambda: check_expression("sin(x)", V, None, box=BOX),
        lambda: compile_field("sin(x)", V),
    ):
        with pytest.raises(ExpressionError, match="RuntimeError: sympy broke"):
            call()


def test_parameter_values_given_at_build_are_checked_as_well():
    check_expression("x / (a - 1)", V, {"a": 0.0}, box=BOX)
    with pytest.raises(ExpressionError, match="division by zero"):
        compile_field("x / (a - 1)", V, {"a": 1.0})
    with pytest.raises(ExpressionError, match="parameter a = 1e\\+13 is out of range"):
        compile_field("x * a", V, {"a": 1e13})


def _abs_sign(x, y, z, w):
    return np.abs(x - 1) + np.abs(y), [np.sign(x - 1), np.sign(y), 0 * z, 0 * w]


def _max_min(x, y, z, w):
    value = np.maximum(np.maximum(x, y), 2 * z) - np.minimum(w, 0.5)
    return value, [
        (x >= y) & (x >= 2 * z),
        (y > x) & (y >= 2 * z),
        2.0 * ((2 * z > x) & (2 * z > y)),
        -1.0 * (w < 0.5),
    ]


def _nested(x, y, z, w):
    value = np.abs(np.log(x * x)) + np.maximum(np.log(np.abs(y)), z)
    return value, [
        np.sign(np.log(x * x)) * 2 / x,
        (np.log(np.abs(y)) >= z) / y,
        1.0 * (z > np.log(np.abs(y))),
        0 * w,
    ]


@pytest.mark.parametrize(
    "text, expected",
    [
        ("abs(x - 1) + sign(y) * y", _abs_sign),
        ("max(x, y, 2*z) - min(w, 0.5)", _max_min),
        ("abs(log(x^2)) + max(log(abs(y)), z)", _nested),
    ],
)
def test_abs_sign_min_max_have_values_and_finite_gradients(text, expected):
    """Away from the kinks the gradient is the derivative; at them it is finite (one of the
    one-sided derivatives, or 0 for sign), so Newton never meets a NaN there."""
    f = compile_field(text, V)
    p = np.random.default_rng(2).uniform(-1, 1, (200, 4))
    value, gradient = expected(*p.T)
    np.testing.assert_allclose(f.value(p), value, rtol=1e-12)
    np.testing.assert_allclose(f.gradient(p), np.stack(gradient, -1), rtol=1e-12)
    kinks = np.array([[1.0, 0.0, 0.5, 0.5], [0.3, 0.3, 0.15, 0.5], [1.0, 1.0, 0.0, 0.0]])
    assert np.all(np.isfinite(f.gradient(kinks)))


def test_checking_accepts_what_parsing_accepts():
    for text in (
        "x^2 + sin(y*z) - exp(w)/(1 + x**2) + r*sqrt(1 + z^2)",
        "2^3^2",
        "x / (r - 1.5)",
        "-x^2 + pi * e",
    ):
        check_expression(text, V, {"r": 1.0})
        parse_expression(text, V, {"r": 1.0})


def test_the_kiosk_starts_without_sympy():
    """sympy costs half a second of start-up; a kiosk with a warm mesh cache never needs it."""
    import subprocess
    import sys

    code = (
        "import sys, exhibit.kiosk.app, exhibit.commands.run, exhibit.scenes; "
        "print('sympy' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


formulas = st.sampled_from(
    [
        "x**2 + y**2 - 1",
        "(y - 0.2*w)**2 + z**2 - 1",
        "x*y - z*w + sin(x*w)",
        "cos(3*x) * exp(y) - z",
        "sqrt(x**2 + 1) - abs(y)",
        "x**3 - 2*x*y**2 + w**4",
        "1/(2 + x**2) - tanh(z)",
        "log(1 + y**2) * cosh(w) - atan(x)",
        "sign(x - y) * z + abs(w - 0.5)",
        "max(x, y^2, -z) - min(w, sin(x), 0.25)",
        "abs(abs(x) - 1) * sign(y*z) + max(x, w)",
        "min(x*y, z) * sign(w) - (1 + x^2)^0.5",
        "2^(x + y) - max(abs(z), 1.5^w)",
    ]
)


@settings(max_examples=examples(150), deadline=None)
@given(
    formulas,
    st.lists(st.floats(-3, 3), min_size=4, max_size=4),
    st.lists(st.floats(0, 2), min_size=4, max_size=4),
)
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
