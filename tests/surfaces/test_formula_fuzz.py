"""Fuzzing the formula pipeline: whatever a curator types, checking it raises nothing but an
ExpressionError, and a formula that passes the check compiles, is finite on the box where the
check says so, and meshes without NaN (implicitly and parametrically).

Strings come from a small grammar of the formula language (including operators, names and
numbers it refuses), from pathological shapes (deep nesting, towers, long sign chains, huge
literals) and from random junk spliced into them. Example counts are fixed (CHECK_EXAMPLES,
BUILD_EXAMPLES; the default run's scaled by tests/hypothesis_profiles.py outside CI) and generation
is derandomized, so a run is reproducible in cases and cost; the slow variants run many more.
`pytest --hypothesis-show-statistics` prints the counts, and how many formulas were accepted or
refused (events).
"""

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from exhibit.errors import ExhibitError
from exhibit.surfaces.expressions import (
    FUNCTION_NAMES,
    MAX_UNDEFINED,
    ExpressionError,
    _sample,
    check_expression,
    compile_field,
)
from exhibit.surfaces.implicit import polygonize
from exhibit.surfaces.parametric import Interval, tessellate
from tests.hypothesis_profiles import examples

V = ("x", "y", "z", "w")
PARAMS = {"a": 0.5, "b": -2.0}
BOX = [(-1.2, 1.2)] * 4
SPHERE = "x^2 + y^2 + z^2 + w^2 - 1"
#: Examples per test: (default run under CI=true, slow run).
CHECK_EXAMPLES = (1000, 10000)
BUILD_EXAMPLES = (100, 1200)

NUMBERS = st.sampled_from(
    [
        "0",
        "1",
        "2",
        "0.5",
        "3.25",
        "1e-3",
        "64",
        "65",
        "1e12",
        "1e13",
        "1e400",
        "1_0",
        ".5",
        "1e-400",
        "0.0",
        "2.5e6",
    ]
)
NAMES = st.sampled_from(["x", "y", "z", "w", "a", "b", "pi", "e", "q", "sin", "__import__"])
FUNCTIONS = st.sampled_from(FUNCTION_NAMES + ("foo", "eval", "x.real"))
UNARY = st.sampled_from(["-", "+", "--", "-" * 40, "~", "not "])
BINARY = st.sampled_from([" + ", " - ", "*", "/", "^", "**", " % ", "//", " < "])


def _extend(inner):
    return st.one_of(
        st.tuples(UNARY, inner).map("".join),
        st.tuples(inner, BINARY, inner).map("".join),
        inner.map(lambda t: f"({t})"),
        st.tuples(FUNCTIONS, st.lists(inner, min_size=1, max_size=3)).map(
            lambda t: f"{t[0]}({', '.join(t[1])})"
        ),
    )


#: Anything the parser may meet, mostly refused.
GRAMMAR = st.recursive(st.one_of(NUMBERS, NAMES), _extend, max_leaves=10)


def _extend_valid(inner):
    unary = [f for f in FUNCTION_NAMES if f not in ("min", "max")]
    return st.one_of(
        inner.map(lambda t: f"-({t})"),
        st.tuples(inner, st.sampled_from([" + ", " - ", "*", "/", "^"]), inner).map(
            lambda t: f"({t[0]}){t[1]}({t[2]})"
        ),
        st.tuples(st.sampled_from(unary), inner).map(lambda t: f"{t[0]}({t[1]})"),
        st.tuples(st.sampled_from(["min", "max"]), st.lists(inner, min_size=2, max_size=3)).map(
            lambda t: f"{t[0]}({', '.join(t[1])})"
        ),
    )


#: Formulas in the language, so many are accepted and go on to be compiled and meshed.
VALID = st.recursive(
    st.sampled_from(
        ["x", "y", "z", "w", "a", "b", "pi", "e", "0", "1", "2", "0.5", "3", "1e-3", "64"]
    ),
    _extend_valid,
    max_leaves=8,
)


@st.composite
def _pathological(draw):
    inner = draw(st.sampled_from(["x", "x + 1", "sin(y)", "2"]))
    n = draw(st.integers(0, 260))
    shape = draw(st.sampled_from(["nest", "tower", "signs", "sum", "literal", "product"]))
    if shape == "nest":
        name = draw(st.sampled_from(["sin", "sqrt", "abs", "exp", "log", ""]))
        return f"{name}(" * n + inner + ")" * n
    if shape == "tower":
        exponent = draw(st.sampled_from(["2", "8", "64", "0.5", "-64", "y"]))
        return "(" * n + inner + f")^{exponent}" * n
    if shape == "signs":
        return draw(st.sampled_from(["-", "+", "- "])) * (n * 7) + inner
    if shape == "sum":
        return " + ".join([inner] * (n + 1))
    if shape == "literal":
        return draw(st.sampled_from(["1", "9", "0"])) * (n + 1) + "*" + inner
    return "*".join([f"(10^{n % 64}*{inner})"] * (n % 30 + 1))


@st.composite
def _spliced(draw):
    text = draw(GRAMMAR)
    junk = draw(st.text(alphabet="xyzw+-*/^()., 0123456789abs[]'\"=<>!~&|@#:;\\\0é", max_size=4))
    at = draw(st.integers(0, len(text)))
    return text[:at] + junk + text[at:]


FORMULAS = st.one_of(
    VALID,
    GRAMMAR,
    _pathological(),
    _spliced(),
    st.text(alphabet="xyzwpie0123456789+-*/^() .,", max_size=40),
)
BUILDABLE = st.one_of(VALID, VALID, _pathological())


def _checked(text, variables=V, box=None) -> bool:
    """Whether the check accepts text; anything but an ExpressionError fails the test."""
    try:
        check_expression(text, variables, PARAMS, box)
    except ExpressionError as exc:
        assert str(exc)
        event(f"refused {'with' if box else 'without'} a box")
        return False
    event(f"accepted {'with' if box else 'without'} a box")
    return True


def _check_builds(text):
    """A formula accepted with its box compiles, is finite on at least 1 - MAX_UNDEFINED of the
    box's sample, and meshes (with a sphere) into finite arrays, or fails only as a user error."""
    if not _checked(text, V, BOX):
        return
    field = compile_field(text, V, PARAMS)
    points = _sample(BOX, V)
    value, gradient = field.value(points), field.gradient(points)
    good = np.isfinite(value) & np.isfinite(gradient).all(axis=1)
    assert good.mean() >= 1 - MAX_UNDEFINED
    lo, hi = field.bounds(np.array([[-1.2] * 4]), np.array([[1.2] * 4]))
    inside = value[np.isfinite(value)]
    assert np.all((lo[0] <= inside) & (inside <= hi[0]))
    try:
        surface = polygonize(
            "fuzz", field, compile_field(SPHERE, V), [-1.2] * 4, [1.2] * 4, 5, seed=0
        ).surface
    except (ExpressionError, ExhibitError):
        return
    assert np.isfinite(surface.positions).all() and np.isfinite(surface.normals).all()


def _check_parametric(text):
    """The same formula, in s and t, as one coordinate of a parametric patch."""
    text = re.sub(r"\bx\b", "s", re.sub(r"\by\b", "t", text))
    if not _checked(text, ("s", "t"), [(-1.0, 1.0), (-1.0, 1.0)]):
        return
    fields = [compile_field(t, ("s", "t"), PARAMS) for t in (text, "s", "t", "s*t")]

    def point(s, t):
        return np.stack([f.value(np.stack([s, t], -1)) for f in fields], -1)

    surface = tessellate("fuzz", point, Interval(-1.0, 1.0), Interval(-1.0, 1.0), (6, 6))
    assert np.isfinite(surface.positions).all() and np.isfinite(surface.normals).all()


_SETTINGS = dict(deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)


@settings(max_examples=examples(CHECK_EXAMPLES[0]), **_SETTINGS)
@given(FORMULAS)
def test_checking_raises_only_expression_errors(text):
    _checked(text)


@settings(max_examples=examples(BUILD_EXAMPLES[0]), **_SETTINGS)
@given(BUILDABLE)
def test_accepted_formulas_compile_and_mesh_without_nan(text):
    _check_builds(text)
    _check_parametric(text)


@pytest.mark.slow
@settings(max_examples=CHECK_EXAMPLES[1], **_SETTINGS)
@given(FORMULAS)
def test_checking_raises_only_expression_errors_long(text):
    _checked(text)


@pytest.mark.slow
@settings(max_examples=BUILD_EXAMPLES[1], **_SETTINGS)
@given(BUILDABLE)
def test_accepted_formulas_compile_and_mesh_without_nan_long(text):
    _check_builds(text)
    _check_parametric(text)
