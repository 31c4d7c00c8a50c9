"""The implicit polygonizer on surfaces with known answers: the collision cases of section 4.3
(components and topology as the paper describes them), Hopf tori, and the quality bounds."""

import math

import numpy as np
import pytest

from exhibit.geometry.hopf import hopf_map
from exhibit.surfaces import analyse
from exhibit.surfaces.expressions import compile_field
from exhibit.surfaces.implicit import polygonize

XYZT = ("x", "y", "z", "t")


def collision(rc, rs, vc, vs, n=24, seed=1):
    p = dict(rc=rc, rs=rs, vc=vc, vs=vs)
    f = compile_field("(y - vc*t)^2 + z^2 - rc^2", XYZT, p)
    g = compile_field("x^2 + y^2 + (z + vs*t)^2 - rs^2", XYZT, p)
    T = 1.05 * (rc + rs) / math.hypot(vc, vs)
    lo = [-1.05 * rs, -1.05 * rs, -1.05 * rc, -T]
    return polygonize("collision", f, g, lo, [-v for v in lo], n, seed=seed), f, g


@pytest.mark.parametrize(
    "params, components, euler",
    [
        ((1.0, 0.7, 0.2, 1.0), 2, 4),  # Figure 16: two separate components, each a sphere
        ((1.0, 1.2, 0.0, 1.0), 1, 0),  # Figure 17: connected, with a hole (a torus)
    ],
)
def test_collision_topology_matches_the_paper(params, components, euler):
    result, f, g = collision(*params)
    report = analyse(result.surface.triangles)
    assert report.components == components
    assert report.euler_characteristic == euler
    assert report.boundary_edges == 0 and report.nonmanifold_edges == 0
    assert result.stats.max_residual <= 1e-9
    v = result.surface.positions
    assert np.max(np.abs(f.value(v))) <= 1e-9 and np.max(np.abs(g.value(v))) <= 1e-9


def test_normals_are_the_gradients():
    result, f, g = collision(1.0, 1.2, 0.0, 1.0, n=12)
    s = result.surface
    for grad in (f.gradient(s.positions), g.gradient(s.positions)):
        # each gradient lies in the span of the stored orthonormal normal pair
        inside = np.einsum("vai,vi->va", s.normals, grad)
        residual = grad - np.einsum("va,vai->vi", inside, s.normals)
        assert np.max(np.linalg.norm(residual, axis=1) / np.linalg.norm(grad, axis=1)) < 1e-9


def test_hopf_torus_comes_out_closed_on_its_latitude():
    a = 0.3
    f1 = compile_field(f"x^2 + z^2 - {(1 + a) / 2}", ("x", "y", "z", "w"))
    f2 = compile_field(f"y^2 + w^2 - {(1 - a) / 2}", ("x", "y", "z", "w"))
    result = polygonize("torus", f1, f2, [-1.0] * 4, [1.0] * 4, 20, seed=3)
    report = analyse(result.surface.triangles)
    assert (report.components, report.euler_characteristic, report.boundary_edges) == (1, 0, 0)
    np.testing.assert_allclose(hopf_map(result.surface.positions)[:, 2], a, atol=1e-9)


def test_cost_follows_the_surface_not_the_grid():
    """Doubling n should multiply the surviving cells by about 4 (n²), not 16 (n⁴)."""
    small = collision(1.0, 1.2, 0.0, 1.0, n=16)[0].stats.cells
    large = collision(1.0, 1.2, 0.0, 1.0, n=32)[0].stats.cells
    assert 3.0 < large / small < 5.0


def test_no_vertex_lost_or_duplicated_at_cell_borders():
    """Each cell holds at most one vertex and every quad uses four distinct cells' vertices."""
    result, _, _ = collision(1.0, 0.7, 0.2, 1.0, n=16)
    s = result.surface
    assert len(np.unique(s.triangles)) == len(s.positions)  # no orphan vertex
    assert np.all(s.triangles[:, 0] != s.triangles[:, 1])
    rounded = np.round(s.positions, 12)
    assert len(np.unique(rounded, axis=0)) == len(s.positions)  # no duplicate vertex


def test_random_shift_changes_the_mesh_not_the_topology():
    a = analyse(collision(1.0, 1.2, 0.0, 1.0, n=16, seed=1)[0].surface.triangles)
    b = analyse(collision(1.0, 1.2, 0.0, 1.0, n=16, seed=2)[0].surface.triangles)
    assert (a.components, a.euler_characteristic) == (b.components, b.euler_characteristic)


def test_singular_circle_of_the_cusp_pipe_is_found():
    """Section 4.2: on the pipe of y² = x³ the points with u = v = 0 are singular (∇f = 0); they
    form the circle of radius r around the cusp (the dashed circle of Figure 4)."""
    xyuv = ("x", "y", "u", "v")
    g = compile_field("(x - u)^2 + (y - v)^2 - 1", xyuv)
    f = compile_field("v^2 - u^3", xyuv)
    result = polygonize("cusp", g, f, [-2.2, -2.2, -1.2, -1.3], [3.2, 2.2, 1.5, 1.3], 24, seed=2)
    points = result.singular_positions
    assert result.stats.singular_points == len(points) > 20
    np.testing.assert_allclose(points[:, 2:], 0.0, atol=1e-5)
    np.testing.assert_allclose(np.hypot(points[:, 0], points[:, 1]), 1.0, atol=1e-5)
    angles = np.arctan2(points[:, 1], points[:, 0])
    assert np.ptp(angles) > 5.0  # spread around the whole circle
    assert result.stats.max_residual <= 1e-9


def test_empty_and_bad_boxes():
    f1 = compile_field("x^2 + y^2 + z^2 + w^2 + 1", ("x", "y", "z", "w"))
    f2 = compile_field("w", ("x", "y", "z", "w"))
    result = polygonize("none", f1, f2, [-1] * 4, [1] * 4, 8)
    assert len(result.surface.triangles) == 0 and result.stats.cells == 0
    with pytest.raises(ValueError, match="increasing"):
        polygonize("bad", f1, f2, [1] * 4, [-1] * 4, 8)


@pytest.mark.parametrize(
    "f1_text, f2_text, level",
    [
        ("sign(x)*x + abs(y) + abs(z) + abs(w) - 1", "min(w, 1) - 0.2", "abs(x) + abs(y) + abs(z)"),
        ("max(abs(x), abs(y), abs(z), abs(w)) - 0.7", "w - 0.3", "max(abs(x), abs(y), abs(z))"),
    ],
)
def test_surfaces_with_kinks_are_closed_and_on_their_equations(f1_text, f2_text, level):
    """An octahedron and a cube (f1 = f2 = 0 in the slice w = const): abs, sign, min and max in
    the pruning bounds, the Newton projection and the singular-point search."""
    xyzw = ("x", "y", "z", "w")
    f1, f2 = compile_field(f1_text, xyzw), compile_field(f2_text, xyzw)
    result = polygonize("kinks", f1, f2, [-1.0] * 4, [1.0] * 4, 16, seed=4)
    report = analyse(result.surface.triangles)
    assert (report.components, report.euler_characteristic, report.boundary_edges) == (1, 2, 0)
    v = result.surface.positions
    assert np.max(np.abs(f1.value(v))) <= 1e-9 and np.max(np.abs(f2.value(v))) <= 1e-9
    assert np.all(np.isfinite(result.surface.normals)) and np.all(np.isfinite(v))
    assert result.stats.cells < 16**4 / 4  # the bounds of abs, max... pruned most of the grid
    np.testing.assert_allclose(
        compile_field(level, xyzw).value(v), 0.8 if "sign" in f1_text else 0.7, atol=1e-9
    )


def test_singular_circle_is_found_through_abs():
    """The cusp pipe of v² = |u|³ (the cusp y² = x³ mirrored): the singular circle is the same,
    found by Gauss-Newton on second derivatives of abs."""
    xyuv = ("x", "y", "u", "v")
    g = compile_field("(x - u)^2 + (y - v)^2 - 1", xyuv)
    f = compile_field("v^2 - abs(u)^3", xyuv)
    result = polygonize("cusp", g, f, [-2.2, -2.2, -1.2, -1.3], [2.2, 2.2, 1.2, 1.3], 20, seed=2)
    points = result.singular_positions
    assert len(points) > 10
    np.testing.assert_allclose(points[:, 2:], 0.0, atol=1e-5)
    np.testing.assert_allclose(np.hypot(points[:, 0], points[:, 1]), 1.0, atol=1e-5)
