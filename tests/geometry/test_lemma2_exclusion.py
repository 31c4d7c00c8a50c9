"""Lemma 2 discs stop where `lemma2_exclusion` (printed by `exhibit inspect`) says, next to the
singular points of Figure 15's collision ((0, ±1, 0, 0), where the sheets meet) and of the
cusp's pipe (its circle). Issue 32: "within about 5 edges of a singular point they are not
drawn at all", while the docs said 3 median edges; the rule is on the triangle's three vertices,
so a point is drawn from 3 edges plus the longest edge of the triangles there.

The exact Lemma 2 points are made here, not found by the code: on each surface's own
parametrisation a point P and a ray ρ in its tangent plane are chosen, and the view is the
rotation whose sensor axis is ρ (orthographic, as Figure 15's view), so P is a Lemma 2 point
of that view by construction (checked with numpy, to 1e-12)."""

import numpy as np
import pytest

from exhibit import scenes
from exhibit.geometry.lemma2_marks import eligible_triangles, lemma2_exclusion, lemma2_marks


def collision(a, b):
    """rc = rs = 1, vc = 0, vs = 1: y = cos a, z = sin a, x = sin a cos b, t = sin a (sin b - 1);
    the tangents X_a and X_b / sin a (smooth through the singular points a = 0, π)."""
    sa, ca, sb, cb = np.sin(a), np.cos(a), np.sin(b), np.cos(b)
    return (
        np.array([sa * cb, ca, sa, sa * (sb - 1)]),
        np.array([ca * cb, -sa, ca, ca * (sb - 1)]),
        np.array([-sb, 0.0, 0.0, cb]),
    )


def cusp(t, p):
    """r = 1: (t² + cos p, t³ + sin p, t², t³); the tangents X_t / t and X_p."""
    return (
        np.array([t * t + np.cos(p), t**3 + np.sin(p), t * t, t**3]),
        np.array([2.0, 3 * t, 2.0, 3 * t]),
        np.array([-np.sin(p), np.cos(p), 0.0, 0.0]),
    )


CASES = {
    "collision": (
        lambda: scenes.figure(15)[0].build(scenes.figure(15)[1].params),
        collision,
        np.linspace(0.01, 0.35, 18),
        lambda P: min(np.linalg.norm(P - [0, 1, 0, 0]), np.linalg.norm(P - [0, -1, 0, 0])),
    ),
    "cusp": (
        lambda: scenes.get("offset-cusp").build({"r": 1.0}),
        cusp,
        np.concatenate([np.linspace(0.05, 0.6, 12), -np.linspace(0.05, 0.6, 12)]),
        lambda P: np.sqrt((np.hypot(P[0], P[1]) - 1) ** 2 + P[2] ** 2 + P[3] ** 2),
    ),
}


def view_with_ray(rho):
    """A rotation R with R[3] = rho: in its view coordinates the orthographic sensor ray is e_w."""
    basis = np.linalg.qr(np.column_stack([rho, np.random.default_rng(0).normal(size=(4, 3))]))[0]
    basis[:, 0] *= np.sign(basis[:, 0] @ rho)
    return np.roll(basis, -1, axis=1).T


@pytest.mark.parametrize("case", ["collision", pytest.param("cusp", marks=pytest.mark.slow)])
def test_lemma2_discs_stop_where_the_exclusion_says(case):
    build, param, values, to_singular = CASES[case]
    surface = build().surfaces[0]
    exclusion = lemma2_exclusion(surface.positions, surface.normals, surface.triangles)
    edge = exclusion["median_edge"]
    tris = surface.triangles[
        eligible_triangles(surface.positions, surface.normals, surface.triangles)
    ]
    drawn, missed = [], []
    for s in values:
        for b in np.linspace(0, 2 * np.pi, 4, endpoint=False) + 0.3:
            for g in (0.2, 1.77):
                P, t1, t2 = param(s, b)
                e1 = t1 / np.linalg.norm(t1)
                e2 = t2 - (t2 @ e1) * e1
                rho = np.cos(g) * e1 + np.sin(g) * e2 / np.linalg.norm(e2)
                R = view_with_ray(rho)
                assert np.allclose(R @ R.T, np.eye(4)) and np.allclose(R.T @ [0, 0, 0, 1], rho)
                # P is a Lemma 2 point: ρ lies in the tangent plane
                plane = np.linalg.qr(np.column_stack([t1, t2]))[0]
                assert np.linalg.norm(rho - plane @ (plane.T @ rho)) < 1e-12
                m1, m2 = surface.normals[:, 0] @ R.T, surface.normals[:, 1] @ R.T
                rays = np.tile([0.0, 0.0, 0.0, 1.0], (len(m1), 1))
                index, bary = lemma2_marks(m1, m2, rays, tris)
                marks = np.einsum("kj,kjd->kd", bary, surface.positions[tris[index]])
                # no disc nearer a singular point than the exclusion says, in any view
                for mark in marks:
                    assert to_singular(mark) >= exclusion["never_within"] - 0.1 * edge
                hit = len(marks) and np.linalg.norm(marks - P, axis=1).min() < edge
                (drawn if hit else missed).append(to_singular(P))
    # every exact point beyond always_from is drawn; none nearer than never_within
    assert min(drawn) >= exclusion["never_within"] - 0.1 * edge
    assert max(missed) < exclusion["always_from"]
    # and the measured stop, in median edges, is what docs/SURFACES.md states: none below 3,
    # every one from 4.1 (the points between fall in triangles with a vertex within 3)
    assert min(drawn) / edge >= 2.9 and max(missed) / edge <= 4.1, (
        min(drawn) / edge,
        max(missed) / edge,
    )
