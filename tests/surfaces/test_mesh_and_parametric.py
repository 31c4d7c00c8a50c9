"""Mesh4D, topology checks and the parametric tessellator."""

import math

import numpy as np
import pytest

from exhibit.geometry.hopf import hopf_map, hopf_torus, hopf_torus_tangents
from exhibit.surfaces import Curve, Interval, Marker, Material, Mesh4D, analyse, tessellate
from exhibit.surfaces.parametric import grid_triangles

FULL = Interval(0.0, 2 * math.pi, periodic=True)


def torus(latitude=0.3, resolution=(24, 32), adaptive=False):
    return tessellate(
        "torus",
        lambda a, b: hopf_torus(latitude, a, b),
        FULL,
        FULL,
        resolution,
        tangents=lambda a, b: hopf_torus_tangents(latitude, a, b),
        adaptive=adaptive,
    )


def test_hopf_torus_vertices_lie_on_their_equations_and_latitude():
    z = 0.3
    s = torus(z)
    x, y, zz, w = s.positions.T
    np.testing.assert_allclose(x * x + zz * zz, (1 + z) / 2, atol=1e-12)
    np.testing.assert_allclose(y * y + w * w, (1 - z) / 2, atol=1e-12)
    np.testing.assert_allclose(hopf_map(s.positions)[:, 2], z, atol=1e-12)


@pytest.mark.parametrize("adaptive", [False, True])
def test_periodic_torus_is_closed_and_manifold(adaptive):
    report = analyse(torus(adaptive=adaptive).triangles)
    assert report.boundary_edges == 0 and report.nonmanifold_edges == 0
    assert report.euler_characteristic == 0 and report.components == 1


def test_open_patch_is_a_disc():
    s = tessellate(
        "patch",
        lambda u, v: np.stack([u, v, u * u - v * v, 2 * u * v], -1),
        Interval(-1, 1),
        Interval(-1, 1),
        (9, 13),
    )
    report = analyse(s.triangles)
    assert report.euler_characteristic == 1
    assert report.boundary_edges == 2 * (8 + 12)


def test_normals_are_orthonormal_and_orthogonal_to_the_tangents():
    s = torus()
    alpha, beta = np.meshgrid(FULL.uniform(24), FULL.uniform(32), indexing="ij")
    t1, t2 = (t.reshape(-1, 4) for t in hopf_torus_tangents(0.3, alpha, beta))
    n = s.normals
    np.testing.assert_allclose(
        np.einsum("vai,vbi->vab", n, n), np.broadcast_to(np.eye(2), (len(n), 2, 2)), atol=1e-12
    )
    np.testing.assert_allclose(np.einsum("vai,vi->va", n, t1), 0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("vai,vi->va", n, t2), 0, atol=1e-12)


def test_adaptive_sampling_puts_rows_where_the_surface_bends():
    """A surface flat for s < 0 and bending fast for s > 0 gets most rows on the bent side."""

    def bend(s, t):
        k = np.where(s > 0, 6.0, 0.0)
        return np.stack([s, t, np.where(s > 0, np.sin(k * s) / 6, 0), 0 * s], -1)

    surface = tessellate("bend", bend, Interval(-1, 1), Interval(0, 1), (21, 3))
    s_values = surface.positions.reshape(21, 3, 4)[:, 0, 0]
    assert np.sum(s_values > 0) > 1.5 * np.sum(s_values < 0)
    assert np.all(np.diff(s_values) > 0)


def test_grid_wraps_without_duplicate_vertices():
    tris = grid_triangles(4, 5, True, False)
    assert tris.max() == 4 * 5 - 1
    assert analyse(tris).boundary_edges == 2 * 4


def test_topology_counts_components_and_nonmanifold_edges():
    two = np.array([[0, 1, 2], [3, 4, 5]])
    assert analyse(two).components == 2
    fan = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]])
    assert analyse(fan).nonmanifold_edges == 1


def test_mesh_round_trip_and_bad_archive():
    mesh = Mesh4D(
        [torus()],
        [Curve("c", np.eye(4), Material(style="wire"), closed=True)],
        [Marker("m", [1, 2, 3, 4], label="here")],
    )
    back = Mesh4D.from_bytes(mesh.to_bytes())
    np.testing.assert_array_equal(back.surfaces[0].positions, mesh.surfaces[0].positions)
    np.testing.assert_array_equal(back.surfaces[0].triangles, mesh.surfaces[0].triangles)
    assert back.curves[0].closed and back.curves[0].material.style == "wire"
    assert back.markers[0].label == "here"
    with pytest.raises(ValueError, match="not a mesh archive"):
        Mesh4D.from_bytes(b"garbage")


def test_curve_segments_and_tangents():
    c = Curve("square", [[0, 0, 0, 0], [1, 0, 0, 0], [1, 1, 0, 0], [0, 1, 0, 0]], closed=True)
    assert c.segments().shape == (4, 2, 4)
    np.testing.assert_allclose(np.linalg.norm(c.tangents, axis=1), 1.0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"color": (2, 0, 0)}, "colour"),
        ({"style": "dotted"}, "style"),
        ({"line_width": 0}, "width"),
    ],
)
def test_material_validation(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Material(**kwargs)
