"""The live slice's rule for tangency (geometry/touching.py, mirrored by the geometry shader):
where h touches zero without changing sign, segments along the touching curve; where it only
comes near zero, or changes sign, none."""

import numpy as np
import pytest

from exhibit.geometry.silhouette import zero_set_segments
from exhibit.geometry.touching import (
    TOUCH_TOLERANCE,
    critical_values,
    hermite_dip,
    near_critical,
    tangential_gradient,
    touching_segments,
)


def parabolic_sheet(n: int = 24, kappa: float = 2.0):
    """p(u, v) = (u, v, 0, κu²/2) over [-1, 1]² (κ the curvature of t across u = 0), triangulated
    with the grid shifted off u = 0, with its orthonormal normals."""
    s = np.linspace(-1, 1, n + 1) + 0.37 / n
    U, V = (a.ravel() for a in np.meshgrid(s, s, indexing="ij"))
    positions = np.stack([U, V, 0 * U, 0.5 * kappa * U**2], 1)
    n1 = np.stack([0 * U, 0 * U, 1 + 0 * U, 0 * U], 1)
    n2 = np.stack([-kappa * U, 0 * U, 0 * U, 1 + 0 * U], 1)
    n2 /= np.linalg.norm(n2, axis=1, keepdims=True)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    tris = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    return positions, np.stack([n1, n2], 1), tris


def _segments(at: float, singular=None):
    positions, normals, tris = parabolic_sheet()
    axis = np.eye(4)[3]
    values = positions @ axis - at
    return touching_segments(
        positions, tris, values, tangential_gradient(axis, normals), singular
    ), positions


def test_the_hermite_minimum_of_a_parabola_is_exact():
    # h(λ) = (λ - 0.3)², h' = 2(λ - 0.3): a quadratic is its own cubic Hermite interpolant
    dip, lam, value = hermite_dip(0.09, 0.49, -0.6, 1.4)
    assert dip and abs(lam - 0.3) < 1e-4 and abs(value) < 1e-8
    # the same shifted up by m: |H(λ*)| / (d1 - d0) = m / 2
    dip, lam, value = hermite_dip(0.09 + 0.01, 0.49 + 0.01, -0.6, 1.4)
    assert dip and abs(value - 0.01) < 1e-8
    # no dip where |h| only rises or only falls, or where the ends differ in sign
    assert not hermite_dip(0.1, 0.5, 0.2, 0.6)[0]
    assert not hermite_dip(-0.1, 0.2, 0.1, 0.4)[0]
    assert hermite_dip(-0.09, -0.49, 0.6, -1.4)[0]  # and a negative h's |h| dips too


def test_a_touching_line_is_found_along_its_length():
    segments, _ = _segments(0.0)
    assert len(segments) > 20
    points = segments.reshape(-1, 4)
    u, v, z, t = points.T
    # on u = 0; t is the chord's height over the sheet there, at most κ(ℓ/2)²/2 = 1.7e-3
    assert np.abs(u).max() < 1e-3 and np.abs(t).max() < 2e-3
    covered = np.histogram(v, bins=20, range=(-0.95, 0.95))[0]
    assert covered.min() > 0


@pytest.mark.parametrize("at", [1e-3, -0.05, 0.05])
def test_near_tangency_it_draws_what_sign_changes_draw(at):
    """Off tangency by m, an edge passes only while m ≤ TOUCH_TOLERANCE κℓ² (here 2e-4)."""
    positions, _, tris = parabolic_sheet()
    assert TOUCH_TOLERANCE * 2.0 * (2 / 24) ** 2 < 1e-3
    segments, _ = _segments(at)
    assert len(segments) == 0
    crossings = zero_set_segments(positions, tris, positions[:, 3] - at)
    assert (len(crossings) > 0) == (at > 0)


def test_just_off_tangency_it_draws_only_where_the_slice_is():
    """t ≥ 0 on the sheet: at c = 1e-4 the slice is two lines 0.02 apart, inside one cell, drawn
    as one touching line; at c = −1e-4 there is no slice and nothing is drawn (before issue 32
    both were, the dip being within TOUCH_TOLERANCE·κℓ² of zero either way)."""
    assert len(_segments(1e-4)[0]) > 20
    assert len(_segments(-1e-4)[0]) == 0


def test_after_figure_15s_tangency_the_upper_half_goes_dark():
    """rc = rs = 1, vc = 0, vs = 1 at t = 3e-5: the ball touches the pipe only below its axis
    (z = −(x² + c²)/2c); before issue 32 the live slice also lit the upper half circle."""
    from exhibit.scenes.collision import build_part

    surface = build_part({"rc": 1.0, "rs": 1.0, "vc": 0.0, "vs": 1.0}, 48).surface
    p, n = surface.positions, surface.normals
    singular = np.einsum("vi,vi->v", n[:, 0], n[:, 0]) < 0.25
    e = np.eye(4)[3]
    h = p[:, 3] - 3e-5
    tris = surface.triangles
    segments = [
        np.asarray(s).reshape(-1, 2, 4)
        for s in (
            zero_set_segments(p, tris, h),
            touching_segments(p, tris, h, tangential_gradient(e, n), singular),
        )
    ]
    drawn = np.concatenate(segments)
    length = np.linalg.norm(drawn[:, 1] - drawn[:, 0], axis=1)
    z = drawn[:, :, 2].mean(axis=1)
    # before: 3.0; now two stubs of 0.002 next to the singular points, where the mesh is torn
    assert length[z > 0.02].sum() < 0.01
    assert length[z < -0.02].sum() > 2 * np.pi - 0.5  # both sides of the thin loop


def test_singular_vertices_are_skipped():
    positions, _, _ = parabolic_sheet()
    singular = np.abs(positions[:, 1]) < 0.5
    segments, _ = _segments(0.0, singular)
    assert len(segments) > 5
    assert np.abs(segments[..., 1]).min() > 0.4


def test_the_gate_lets_every_touching_slice_through():
    """The renderer runs the tangency test only where the slice is within an edge of a critical
    value (critical_values, near_critical): on Figure 15's surface every slice t = c that
    touching_segments would light is gated on, and most of the sweep is not."""
    from exhibit import scenes

    scene, preset = scenes.figure(15)
    surface = scene.build(preset.params, resolution=32).surfaces[0]
    p, tris = surface.positions, surface.triangles
    longest = max(
        np.linalg.norm(p[tris[:, k]] - p[tris[:, (k + 1) % 3]], axis=1).max() for k in range(3)
    )
    critical = critical_values(p, surface.normals)[3]
    gradient = tangential_gradient(np.eye(4)[3], surface.normals)
    gated = []
    for c in np.concatenate([np.linspace(-2.5, 2.5, 51), [-2.0, 0.0, 2.0]]):
        on = near_critical(critical, c, longest)
        lit = len(touching_segments(p, tris, p[:, 3] - c, gradient, surface.singular)) > 0
        assert on or not lit, c
        gated.append(on)
    assert near_critical(critical, 0.0, longest) and not near_critical(critical, -1.0, longest)
    assert np.mean(gated) < 0.5
