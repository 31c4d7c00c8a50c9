"""Formulas that are undefined or infinite on part of their box: the build masks those values,
so no NaN or inf reaches a Surface or a Curve (and numpy's warnings, errors under pytest here,
are not raised either)."""

import math

import numpy as np
import pytest

from exhibit.scenes.implicit_scene import fixed_silhouette, mesh_implicit
from exhibit.surfaces import analyse
from exhibit.surfaces.expressions import compile_field
from exhibit.surfaces.implicit import polygonize
from exhibit.surfaces.exact_silhouette import RefineStats
from exhibit.surfaces.mesh import Material
from exhibit.surfaces.parametric import Interval, tessellate

XYZW = ("x", "y", "z", "w")
SPHERE = "x^2 + y^2 + z^2 + w^2 - 1"


def assert_finite(surface):
    assert np.all(np.isfinite(surface.positions)) and np.all(np.isfinite(surface.normals))
    assert len(surface.triangles) and surface.triangles.max() < len(surface.positions)


@pytest.mark.parametrize(
    "f1_text, f2_text, domain",
    [
        ("sqrt(x) - y", SPHERE, lambda p: p[:, 0] >= 0),  # NaN for x < 0
        (
            "log(max(x, 0)^2) + y^2 + z^2 + w^2 - 1",
            "w - 0.1*x",  # -inf for x <= 0
            lambda p: p[:, 0] > 0,
        ),
        ("x^2 + y^2 + z^2 + sqrt(w) - 1", "x - y", lambda p: p[:, 3] >= 0),
    ],
)
def test_implicit_surfaces_drop_what_is_off_the_domain(f1_text, f2_text, domain):
    f1, f2 = compile_field(f1_text, XYZW), compile_field(f2_text, XYZW)
    result = polygonize("partly undefined", f1, f2, [-1.2] * 4, [1.2] * 4, 12, seed=5)
    surface = result.surface
    assert_finite(surface)
    assert np.all(domain(surface.positions))
    v = surface.positions[~surface.singular]
    assert np.max(np.abs(f1.value(v))) <= 1e-9 and np.max(np.abs(f2.value(v))) <= 1e-9
    assert math.isfinite(result.stats.max_residual)
    assert analyse(surface.triangles).nonmanifold_edges == 0


def test_implicit_surface_undefined_everywhere_is_empty():
    f1, f2 = compile_field("log(-1 - x^2) + y", XYZW), compile_field(SPHERE, XYZW)
    surface = polygonize("nowhere", f1, f2, [-1.2] * 4, [1.2] * 4, 8).surface
    assert len(surface.positions) == 0 and len(surface.triangles) == 0


def test_gradients_that_are_not_finite_make_singular_vertices_and_finite_silhouettes():
    """sqrt(max(x, 0)) is finite for x < 0 but its gradient is not (0 · ∞): those vertices stay,
    with zero normals flagged singular, and the silhouette traced through them has no NaN.
    Here s = -0.1/√x never vanishes where it is defined: the sign changes the mesh shows are
    all at non-finite gradients, so every traced point is dropped, none kept unrefined."""
    part = mesh_implicit(
        "half",
        "sqrt(max(x, 0)) + y^2 + z^2 + w^2 - 1",
        "w - 0.2*y",
        XYZW,
        {},
        [-1.2] * 4,
        [1.2] * 4,
        10,
        Material(),
    )
    surface = part.surface
    assert np.all(np.isfinite(surface.positions)) and np.all(np.isfinite(surface.normals))
    assert np.any(surface.singular)
    stats = RefineStats()
    curves = fixed_silhouette(part, (0, 1), "silhouette", Material(), stats)
    assert all(np.all(np.isfinite(c.points)) for c in curves)
    assert stats.dropped + stats.excluded > 0 and stats.refined == 0 and curves == []


def _fields(*texts):
    fields = [compile_field(t, ("s", "t")) for t in texts]

    def point(s, t):
        return np.stack([f.value(np.stack([s, t], -1)) for f in fields], -1)

    def tangents(s, t):
        gradients = [f.gradient(np.stack([s, t], -1)) for f in fields]
        return (
            np.stack([g[..., 0] for g in gradients], -1),
            np.stack([g[..., 1] for g in gradients], -1),
        )

    return point, tangents


@pytest.mark.parametrize("adaptive", [False, True])
@pytest.mark.parametrize("analytic", [False, True])
def test_parametric_patches_drop_samples_where_the_point_is_not_finite(adaptive, analytic):
    point, tangents = _fields("s", "t", "sqrt(s)", "log(t^2)")  # NaN for s < 0, -inf at t = 0
    surface = tessellate(
        "partly undefined",
        point,
        Interval(-1.0, 1.0),
        Interval(-1.0, 1.0),
        (9, 11),
        tangents if analytic else None,
        adaptive=adaptive,
    )
    assert_finite(surface)
    s, t = surface.positions[:, 0], surface.positions[:, 1]
    assert np.all(s >= 0) and np.all(t != 0)
    np.testing.assert_allclose(surface.positions[:, 2], np.sqrt(s))
    assert len(surface.positions) < 9 * 11


def test_parametric_patch_undefined_everywhere_is_empty():
    point, tangents = _fields("s", "t", "log(-1 - s^2)", "t")
    surface = tessellate("nowhere", point, Interval(0.0, 1.0), Interval(0.0, 1.0), (5, 5), tangents)
    assert len(surface.positions) == 0 and len(surface.triangles) == 0


def test_overflowing_values_and_tangents_are_masked():
    point, tangents = _fields("s", "t", "exp(exp(exp(3*s)))", "exp(720*t)")
    surface = tessellate("huge", point, Interval(-1.0, 1.0), Interval(-1.0, 1.0), (8, 8), tangents)
    assert_finite(surface)
