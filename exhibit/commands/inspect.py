"""`exhibit inspect SCENE`: build a scene's mesh and report on each part — size, topology and
how closely the vertices satisfy the surface's equations."""

from __future__ import annotations

import json

from exhibit import scenes
from exhibit.scenes.base import add_scene_arguments, parse_overrides, parse_resolution
from exhibit.surfaces import analyse, progress

HELP = "build a scene and check its mesh: components, Euler characteristic, edges, residuals"


def add_arguments(parser) -> None:
    add_scene_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print JSON")


def part_report(surface) -> dict:
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
    }


def run(args) -> int:
    scene = scenes.get(args.scene)
    overrides = parse_overrides(args.param)
    resolution = parse_resolution(args.resolution)
    with progress.on_terminal():
        mesh = scene.build(overrides, resolution)
    parts = [part_report(surface) for surface in mesh.surfaces]
    if args.json:
        print(json.dumps({"scene": scene.name, "parts": parts}, indent=2, ensure_ascii=False))
        return 0
    print(f"{scene.title} ({scene.name})")
    for p in parts:
        residual = "-" if p["max_residual"] is None else f"{p['max_residual']:.1e}"
        print(f"  {p['name']}: {p['kind']}, {p['vertices']} vertices, {p['triangles']} triangles, "
              f"{p['components']} component(s), χ = {p['euler_characteristic']}, "
              f"{p['boundary_edges']} boundary / {p['nonmanifold_edges']} non-manifold edges, "
              f"max residual {residual}, {p['singular_points']} singular points, "
              f"{p['seconds']:.2f} s")
    for curve in mesh.curves:
        print(f"  {curve.name}: curve, {len(curve.points)} points{' (closed)' if curve.closed else ''}")
    for marker in mesh.markers:
        print(f"  {marker.name}: {', '.join(f'{v:.6g}' for v in marker.position)}"
              f"{' — ' + marker.label if marker.label else ''}")
    return 0
