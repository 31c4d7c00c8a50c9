"""Shared building blocks for scenes made of implicit surfaces f1 = f2 = 0."""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from exhibit.geometry.silhouette import silhouette_function
from exhibit.surfaces.crossings import find_crossings, join_at_crossings
from exhibit.surfaces.curves import zero_set_curves
from exhibit.surfaces.double_zeros import touching_silhouette
from exhibit.surfaces.exact_silhouette import RefineStats, SilhouetteSystem
from exhibit.surfaces.expressions import ScalarField, compile_field
from exhibit.surfaces.implicit import ImplicitResult, polygonize
from exhibit.surfaces.mesh import Curve, Material, Surface
from exhibit.surfaces.silhouette_curves import refine_curves


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


def mesh_implicit(
    name: str,
    f1_text: str,
    f2_text: str,
    axes: Sequence[str],
    params: dict,
    lo: ArrayLike,
    hi: ArrayLike,
    resolution: int,
    material: Material,
    progress: Callable[[str], None] | None = None,
) -> ImplicitPart:
    f1 = compile_field(f1_text, axes, params)
    f2 = compile_field(f2_text, axes, params)
    result = polygonize(
        name, f1, f2, lo, hi, resolution, material, seed=seed_for(name), progress=progress
    )
    part = ImplicitPart(result, f1, f2)
    result.surface.exact = part
    return part


def fixed_silhouette(
    part: ImplicitPart,
    along: tuple[int, int],
    name: str,
    material: Material,
    stats: RefineStats | None = None,
) -> list[Curve]:
    """Silhouette curves for the orthographic projection along two coordinate axes (Lemma 3(c)).

    Traced as the zero set of s = (n1·e_a)(n2·e_b) - (n1·e_b)(n2·e_a), n1 = ∇f1, n2 = ∇f2, on the
    mesh; then every point is Newton-refined onto the exact curve f1 = f2 = s = 0 (s built
    symbolically from the scene's own f1, f2) to a scale-free residual of 1e-9. Points that do not
    converge are dropped, points near a singular point or curve are excluded (singular points are
    never silhouettes), and curves are split there (`surfaces/exact_silhouette.py`). Where two
    branches cross, the crossing is solved for and every piece ends there
    (`surfaces/crossings.py`). Branches where s touches zero without changing sign, which sign
    changes cannot see, are found where |s| dips along the surface and refined the same way
    (`surfaces/double_zeros.py`), named "NAME (touching)". ``stats``, when given, accumulates
    the counts."""
    surface = part.surface
    if len(surface.triangles) == 0:
        return []
    e = np.eye(4)
    p = surface.positions
    with np.errstate(all="ignore"):
        values = silhouette_function(
            part.f1.gradient(p), part.f2.gradient(p), e[along[0]], e[along[1]]
        )
    # A vertex where a gradient is not finite gets a sign change around it; refinement decides.
    values = np.where(np.isfinite(values), values, 0.0)
    curves = zero_set_curves(surface, values, name, material)
    system = SilhouetteSystem(part.f1, part.f2, along)
    edge = cell_size(part)
    refined, counts = refine_curves(
        system, curves, 2.0 * edge, part.result.singular_positions, exclusion_radius(part)
    )
    # Where two branches cross, every piece ends at the crossing itself (an X, not "><").
    crossings = find_crossings(system, refined, edge)
    if len(crossings):
        refined = join_at_crossings(system, refined, crossings, edge)
        counts.refined = sum(len(c.points) + c.closed for c in refined)  # the points exported
        counts.max_residual = max(
            (float(system.residual(c.points).max()) for c in refined), default=0.0
        )
    if stats is not None:
        stats.add(counts)
    for i, curve in enumerate(refined):
        curve.name = name if i == 0 else f"{name} {i + 1}"
    touching = touching_silhouette(
        part.f1,
        part.f2,
        surface,
        along,
        edge,
        part.result.singular_positions,
        exclusion_radius(part),
        f"{name} (touching)",
        material,
        stats,
        [c.points for c in refined],
    )
    for i, curve in enumerate(touching[1:], 2):
        curve.name = f"{curve.name} {i}"
    return refined + touching


def cell_size(part: ImplicitPart) -> float:
    """The polygonizer's largest cell edge for this part."""
    info = part.surface.info
    if "cell_size" in info:
        return float(info["cell_size"])
    p = part.surface.positions
    return float(np.max(np.ptp(p, axis=0))) / max(part.result.stats.resolution, 1)


def exclusion_radius(part: ImplicitPart) -> float:
    """Silhouette points closer than this to a singular point the polygonizer found are excluded:
    half a cell, the distance below which the mesh cannot tell a singular point's sheets apart."""
    return 0.5 * cell_size(part)
