"""`exhibit collide`: do a moving cylinder and sphere collide, and where do they first touch?
The paper's section 4.3 as a tool: the collision 2-surface in XYZT and its lowest point in t."""

from __future__ import annotations

import json
import math

import numpy as np

from exhibit.errors import ExhibitError
from exhibit.scenes import collision
from exhibit.scenes.base import parse_resolution
from exhibit.surfaces import progress
from exhibit.surfaces.topology import connected_components, edge_counts

HELP = "first contact of a moving cylinder and sphere (paper, section 4.3)"


def add_arguments(parser) -> None:
    for name, help_text in (("rc", "cylinder radius"), ("rs", "sphere radius"),
                            ("vc", "cylinder speed along +y"), ("vs", "sphere speed along -z")):
        parser.add_argument(f"--{name}", required=True, metavar="R", help=help_text)
    parser.add_argument("--resolution", metavar="N", help="mesh resolution (default: 48)")
    parser.add_argument("--json", action="store_true", help="print JSON")


def components_through_singular_points(part, cell: float) -> int:
    """Mesh components, joined where they meet at a singular point (the surface is one set
    there even though no triangle crosses the pinch, as in Figure 15)."""
    surface = part.surface
    if len(surface.triangles) == 0:
        return 0
    edges, _ = edge_counts(surface.triangles)
    labels = connected_components(len(surface.positions), edges)
    pairs = []
    for point in part.result.singular_positions:
        near = np.nonzero(np.linalg.norm(surface.positions - point, axis=1) < 2.0 * cell)[0]
        pairs += [(near[0], other) for other in near[1:]]
    if pairs:
        link = np.stack([labels[np.array(pairs)[:, 0]], labels[np.array(pairs)[:, 1]]], 1)
        merged = connected_components(len(surface.positions), np.concatenate([edges, link]))
        labels = merged[labels]
    return len(np.unique(labels[np.unique(surface.triangles)]))


def run(args) -> int:
    params = {}
    for name in ("rc", "rs", "vc", "vs"):
        raw = getattr(args, name)
        try:
            params[name] = float(raw)
        except ValueError:
            raise ExhibitError(f"--{name} must be a number, got {raw!r}") from None
        if not (math.isfinite(params[name]) and abs(params[name]) <= 1e6):
            raise ExhibitError(f"--{name} must be a finite number within ±1e6, got {raw!r}")
    if not (params["rc"] >= 1e-6 and params["rs"] >= 1e-6):
        raise ExhibitError("--rc and --rs must be radii of at least 1e-6")
    if params["vc"] == 0 and params["vs"] == 0:
        raise ExhibitError("--vc and --vs are both 0: nothing moves, so there is no first contact")
    resolution = parse_resolution(args.resolution) or collision.SCENE.default_resolution
    with progress.on_terminal():
        part = collision.build_part(params, resolution)
    point = collision.colliding_point(part)
    lo, hi = collision.box(params)
    cell = max(h - l for l, h in zip(lo, hi)) / resolution
    result = {
        "colliding_point": None if point is None else
        {"t": float(point[3]), "x": float(point[0]), "y": float(point[1]), "z": float(point[2])},
        "components": components_through_singular_points(part, cell),
    }
    if args.json:
        print(json.dumps(result, indent=2))
    elif point is None:
        print("They never touch.")
    else:
        p = result["colliding_point"]
        print(f"First contact at t = {p['t']:.6f}, at (x, y, z) = "
              f"({p['x']:.6f}, {p['y']:.6f}, {p['z']:.6f}); the collision surface has "
              f"{result['components']} component(s).")
    return 0
