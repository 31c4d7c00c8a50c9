"""`exhibit inspect SCENE`: build a scene's mesh and report on each part — size, topology and
how closely the vertices satisfy the surface's equations."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING, cast

import numpy as np

from exhibit import scenes
from exhibit.geometry.lemma2_marks import lemma2_exclusion
from exhibit.scenes.base import add_scene_arguments, build_from_arguments
from exhibit.surfaces import analyse
from exhibit.surfaces.mesh import Surface
from exhibit.surfaces.metrics import boundary_box_distance, distance_to_mesh, surface_sag

if TYPE_CHECKING:
    from exhibit.scenes.implicit_scene import ImplicitPart

HELP = "build a scene and check its mesh: components, Euler characteristic, edges, residuals"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scene_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print JSON")


def part_report(surface: Surface) -> dict:
    topology = analyse(surface.triangles, len(surface.positions))
    info = surface.info
    return {
        "name": surface.name,
        "kind": info.get("kind", "surface"),
        "vertices": len(surface.positions),
        "triangles": len(surface.triangles),
        "components": topology.components,
        "euler_characteristic": topology.euler_characteristic,
        "boundary_edges": topology.boundary_edges,
        "nonmanifold_edges": topology.nonmanifold_edges,
        "max_residual": info.get("max_residual"),
        "singular_points": info.get("singular_points", 0),
        "seconds": round(float(info.get("seconds", 0.0)), 4),
        **exactness(surface),
        "lemma2_exclusion": lemma2_exclusion(surface.positions, surface.normals, surface.triangles),
    }


def exactness(surface: Surface) -> dict:
    """For implicit parts: how far the boundary is from the box's faces (0: the surface is cut
    exactly at the box, or closed), how far the traced singular set is from the mesh, and how far
    the vertices and the triangles between them are from the true surface (None where the part
    has no exact f1 = f2 = 0 at hand)."""
    box = surface.info.get("box")
    if box is None:
        return {
            "boundary_box_distance": None,
            "singular_gap": None,
            "max_vertex_distance": None,
            "max_sag": None,
        }
    report: dict[str, float | None] = {
        "boundary_box_distance": boundary_box_distance(surface.positions, surface.triangles, *box)
    }
    result = getattr(surface.exact, "result", None)
    singular = None if result is None else result.singular_positions
    if singular is None:
        report["singular_gap"] = None
    elif len(singular) == 0:
        report["singular_gap"] = 0.0
    else:
        report["singular_gap"] = float(
            distance_to_mesh(singular, surface.positions, surface.triangles).max()
        )
    if result is None:
        report.update(max_vertex_distance=None, max_sag=None)
    else:
        # An exact surface with a result is an implicit part (scenes.implicit_scene).
        exact = cast("ImplicitPart", surface.exact)
        report.update(
            surface_sag(
                (exact.f1, exact.f2),
                surface.positions,
                surface.triangles,
                float(surface.info["cell_size"]),
                singular,
            )
        )
    diagonal = float(np.linalg.norm(np.subtract(box[1], box[0])))
    report["box_diagonal"] = diagonal
    return report


def run(args: argparse.Namespace) -> int:
    scene = scenes.get(args.scene)
    mesh = build_from_arguments(scene, args)
    parts = [part_report(surface) for surface in mesh.surfaces]
    if args.json:
        print(json.dumps({"scene": scene.name, "parts": parts}, indent=2, ensure_ascii=False))
        return 0
    print(f"{scene.title} ({scene.name})")
    for p in parts:
        residual = "-" if p["max_residual"] is None else f"{p['max_residual']:.1e}"
        print(
            f"  {p['name']}: {p['kind']}, {p['vertices']} vertices, {p['triangles']} triangles, "
            f"{p['components']} component(s), χ = {p['euler_characteristic']}, "
            f"{p['boundary_edges']} boundary / {p['nonmanifold_edges']} non-manifold edges, "
            f"max residual {residual}, {p['singular_points']} singular points, "
            f"{p['seconds']:.2f} s"
        )
        if p["boundary_box_distance"] is not None:
            gap = "-" if p["singular_gap"] is None else f"{p['singular_gap']:.2g}"
            print(
                f"    boundary off the box by {p['boundary_box_distance']:.1e}, singular set "
                f"off the mesh by {gap} (box diagonal {p['box_diagonal']:.3g})"
            )
        if p["max_sag"] is not None:
            print(
                f"    vertices off the surface by at most {p['max_vertex_distance']:.1e}, "
                f"triangles (edge midpoints, centroids) by at most {p['max_sag']:.2g}"
            )
        lemma2 = p["lemma2_exclusion"]
        if lemma2["always_from"] > 0:
            print(
                f"    Lemma 2 discs: none within {lemma2['never_within']:.3g} of a singular "
                f"vertex ({lemma2['reach_edges']:g} median edges of {lemma2['median_edge']:.3g}),"
                f" every point from {lemma2['always_from']:.3g} (+ the longest edge there,"
                f" {lemma2['longest_edge_within']:.3g})"
            )
    for curve in mesh.curves:
        closed = " (closed)" if curve.closed else ""
        print(f"  {curve.name}: curve, {len(curve.points)} points{closed}")
    for marker in mesh.markers:
        print(
            f"  {marker.name}: {', '.join(f'{v:.6g}' for v in marker.position)}"
            f"{' — ' + marker.label if marker.label else ''}"
        )
    return 0
