"""`exhibit silhouette SCENE --along A,B`: the silhouette curves of a scene's surfaces for the
orthographic projection along two of its axes (Lemma 3(c)) — e.g. the offset curve of a pipe
surface along u, v, or the collision curve along x, y."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from exhibit import scenes
from exhibit.errors import ExhibitError
from exhibit.geometry.silhouette import silhouette_function, zero_set_segments
from exhibit.scenes.base import add_scene_arguments, build_from_arguments
from exhibit.scenes.implicit_scene import (
    ImplicitPart,
    cell_size,
    exclusion_radius,
    fixed_silhouette,
)
from exhibit.surfaces.exact_silhouette import (
    EXCLUSION_RATIO,
    ParametricExact,
    RefineStats,
    SilhouetteSystem,
    parametric_silhouette,
)
from exhibit.surfaces.singular import jacobian_ratio
from exhibit.surfaces.mesh import Curve, Material, Surface
from exhibit.surfaces.whole_silhouette import whole_silhouette_components

HELP = "silhouette curves of a scene for the orthographic view along two axes"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scene_arguments(parser)
    parser.add_argument(
        "--along",
        required=True,
        metavar="AXIS,AXIS",
        help="two of the scene's axis names, e.g. u,v or x,y",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def parse_along(text: str, axes: tuple[str, ...]) -> tuple[int, int]:
    names = [a.strip() for a in text.split(",")]
    if len(names) != 2 or names[0] == names[1]:
        raise ExhibitError(f"--along needs two different axis names, got {text!r}")
    for name in names:
        if name not in axes:
            raise ExhibitError(
                f"--along: {name!r} is not an axis of this scene (axes: {', '.join(axes)})"
            )
    return axes.index(names[0]), axes.index(names[1])


def run(args: argparse.Namespace) -> int:
    scene = scenes.get(args.scene)
    along = parse_along(args.along, scene.axes)
    mesh = build_from_arguments(scene, args)
    stats = RefineStats()
    curves = []
    components = []
    for surface in mesh.surfaces:
        # A component on which s vanishes identically is silhouette as a whole: reported by
        # name, since sign changes find nothing there (surfaces/whole_silhouette.py).
        parts = whole_silhouette_components(surface, along)
        components += parts
        if parts and all(part["whole_component"] for part in parts):
            continue
        # Every exported point is refined onto the exact silhouette of the surface's own
        # equations (or parametrisation); points that do not converge are dropped, points near
        # singular points excluded (surfaces/exact_silhouette.py).
        curves += [
            curve.polyline().tolist() for curve in exact_silhouette_curves(surface, along, stats)
        ]
    names = f"{scene.axes[along[0]]}, {scene.axes[along[1]]}"
    smallest = smallest_ratio(mesh.surfaces, curves)
    if args.json:
        print(
            json.dumps(
                {
                    "axes": list(scene.axes),
                    "curves": curves,
                    "components": components,
                    "smallest_ratio": smallest,
                    **exclusion_report(mesh.surfaces, curves),
                    **stats.to_json(),
                }
            )
        )
        return 0
    for part in components:
        if part["whole_component"]:
            print(
                f"the whole of {part['name']} is silhouette along {names}: every tangent "
                "plane projects to a line (the silhouette function vanishes there)"
            )
    print(f"{len(curves)} silhouette curve(s) of {scene.name} along {names}:")
    for i, curve in enumerate(curves, 1):
        print(f"  curve {i}: {len(curve)} points")
    print(
        f"  {stats.refined} points refined to residual {stats.max_residual:.1e}, "
        f"{stats.dropped} dropped (no convergence), {stats.excluded} excluded (near singular "
        "points)"
    )
    if smallest is not None:
        print(
            f"  nearest to the singular set: σ_min/σ_max of the normals {smallest:.1e} "
            f"(points below {EXCLUSION_RATIO:.0e} are excluded)"
        )
    return 0


def smallest_ratio(surfaces: Sequence[Surface], curves: Sequence[ArrayLike]) -> float | None:
    """The smallest σ_min/σ_max of (∇f1, ∇f2) over the exported points (implicit surfaces):
    how close to the singular set the curves reach (the exclusion is EXCLUSION_RATIO)."""
    if not curves:
        return None
    points = np.concatenate([np.asarray(c, dtype=float) for c in curves])
    best = np.full(len(points), np.nan)
    for surface in surfaces:
        exact = surface.exact
        if isinstance(exact, ImplicitPart):
            system = SilhouetteSystem(exact.f1, exact.f2, (0, 1))
            on = system.f1_f2_residual(points) <= 1e-9
            best = np.where(on, jacobian_ratio(exact.f1, exact.f2, points), best)
    return float(np.nanmin(best)) if np.isfinite(best).any() else None


def exclusion_report(surfaces: Sequence[Surface], curves: Sequence[ArrayLike]) -> dict:
    """The exclusion used (implicit surfaces) and how close each open curve's ends got to the
    traced singular set: ``exclusion`` {"ratio": EXCLUSION_RATIO, "cell", "singular_radius"
    (half a cell, `implicit_scene.exclusion_radius`)} and ``ends`` [{"curve", "end" (0 first,
    1 last point), "to_singular_set", "ratio" (σ_min/σ_max of the normals there)}]."""
    parts = [s.exact for s in surfaces if isinstance(s.exact, ImplicitPart)]
    if not parts:
        return {"exclusion": None, "ends": []}
    part = parts[0]
    cell = cell_size(part)
    singular = np.concatenate([p.result.singular_positions.reshape(-1, 4) for p in parts])
    ends = []
    for index, curve in enumerate(curves):
        points = np.asarray(curve, dtype=float)
        if len(points) < 2 or np.array_equal(points[0], points[-1]):
            continue  # closed (the polyline repeats its first point)
        for which, point in ((0, points[0]), (1, points[-1])):
            gap = float(np.linalg.norm(singular - point, axis=1).min()) if len(singular) else None
            ratio = min(float(jacobian_ratio(p.f1, p.f2, point[None])[0]) for p in parts)
            ends.append({"curve": index, "end": which, "to_singular_set": gap, "ratio": ratio})
    return {
        "exclusion": {
            "ratio": EXCLUSION_RATIO,
            "cell": cell,
            "singular_radius": exclusion_radius(part),
        },
        "ends": ends,
    }


def exact_silhouette_curves(
    surface: Surface, along: tuple[int, int], stats: RefineStats
) -> list[Curve]:
    exact = surface.exact
    if isinstance(exact, ImplicitPart):
        # Sign changes of s, and the branches where s only touches zero (double zeros).
        return fixed_silhouette(exact, along, "silhouette", Material(), stats)
    if isinstance(exact, ParametricExact):
        return parametric_silhouette(surface, exact, along, "silhouette", Material(), stats)
    # Without the exact surface nothing can be refined: every traced point counts as dropped.
    e = np.eye(4)
    values = silhouette_function(
        surface.normals[:, 0], surface.normals[:, 1], e[along[0]], e[along[1]]
    )
    segments = zero_set_segments(surface.positions, surface.triangles, values)
    stats.dropped += 2 * len(segments)
    return []
