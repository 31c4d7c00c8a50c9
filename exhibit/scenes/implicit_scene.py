"""Shared building blocks for scenes made of implicit surfaces f1 = f2 = 0."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from exhibit.geometry.silhouette import silhouette_function
from exhibit.surfaces.curves import zero_set_curves
from exhibit.surfaces.expressions import ScalarField, compile_field
from exhibit.surfaces.implicit import ImplicitResult, polygonize, project_onto
from exhibit.surfaces.mesh import Curve, Material, Surface


@dataclass
class ImplicitPart:
    """One implicit surface of a scene and what polygonizing it found."""

    result: ImplicitResult
    f1: ScalarField
    f2: ScalarField

    @property
    def surface(self) -> Surface:
        return self.result.surface


def seed_for(name: str) -> int:
    """A fixed per-surface seed for the grid shift, so a scene always meshes the same way."""
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:4], "little")


def mesh_implicit(name: str, f1_text: str, f2_text: str, axes, params: dict, lo, hi,
                  resolution: int, material: Material, progress=None) -> ImplicitPart:
    f1 = compile_field(f1_text, axes, params)
    f2 = compile_field(f2_text, axes, params)
    result = polygonize(name, f1, f2, lo, hi, resolution, material, seed=seed_for(name),
                        progress=progress)
    return ImplicitPart(result, f1, f2)


def fixed_silhouette(part: ImplicitPart, along: tuple[int, int], name: str,
                     material: Material) -> list[Curve]:
    """Silhouette curves for the orthographic projection along two coordinate axes (Lemma 3(c)).

    Traced as the zero set of s = (n1·e_a)(n2·e_b) - (n1·e_b)(n2·e_a), n1 = ∇f1, n2 = ∇f2, on the
    mesh, then each point is Newton-projected onto the exact curve f1 = f2 = s = 0 (s built
    symbolically), so the curve is as accurate as the surface's vertices, not the triangles.
    Vertices where a gradient is not finite count as silhouette points; no point is NaN."""
    surface = part.surface
    if len(surface.triangles) == 0:
        return []
    e = np.eye(4)
    p = surface.positions
    with np.errstate(all="ignore"):
        values = silhouette_function(part.f1.gradient(p), part.f2.gradient(p), e[along[0]],
                                     e[along[1]])
    values = np.where(np.isfinite(values), values, 0.0)  # on the silhouette, as singular points
    curves = zero_set_curves(surface, values, name, material)
    g1, g2 = part.f1.gradient_expressions, part.f2.gradient_expressions
    a, b = along
    s = ScalarField(g1[a] * g2[b] - g1[b] * g2[a], part.f1.symbols)
    edge = float(np.max(np.ptp(p, axis=0))) / max(part.result.stats.resolution, 1)
    for curve in curves:
        points, _, _ = project_onto((part.f1, part.f2, s), curve.points, 2.0 * edge)
        curve.points = points[np.all(np.isfinite(points), axis=1)]
    return [curve for curve in curves if len(curve.points) >= 2]
