"""`exhibit collide`: do a moving cylinder and sphere collide, and where do they first touch?
The paper's section 4.3 as a tool: the collision 2-surface in XYZT and its lowest point in t."""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from exhibit.errors import ExhibitError
from exhibit.scenes import collision
from exhibit.scenes.base import parse_resolution
from exhibit.scenes.implicit_scene import ImplicitPart
from exhibit import progress
from exhibit.surfaces.topology import connected_components, edge_counts

HELP = "first contact of a moving cylinder and sphere (paper, section 4.3)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    for name, help_text in (
        ("rc", "cylinder radius"),
        ("rs", "sphere radius"),
        ("vc", "cylinder speed along +y"),
        ("vs", "sphere speed along -z"),
    ):
        parser.add_argument(f"--{name}", required=True, metavar="R", help=help_text)
    parser.add_argument("--resolution", metavar="N", help="mesh resolution (default: 48)")
    parser.add_argument("--json", action="store_true", help="print JSON")


def components_through_singular_points(part: ImplicitPart, cell: float) -> int:
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


def first_contact(part: ImplicitPart, unit: dict) -> np.ndarray:
    """(x, y, z, t) of first contact in scale-free units (t = -1): the mesh's lowest point
    refined by Newton on condition C where it agrees with the closed form, else the closed form
    (moving bodies with a speed always touch: the centres meet the axis at t = 0)."""
    closed = collision.initial_colliding_point_closed_form(unit)
    exact = np.array([closed["x"], closed["y"], closed["z"], closed["t"]])
    refined = collision.colliding_point(part)
    if refined is not None and np.max(np.abs(refined - exact)) < 1e-6:
        return np.asarray(refined, dtype=float)
    return exact


def run(args: argparse.Namespace) -> int:
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
    # Scale-free: lengths in units of rc + rs, time in units of (rc + rs)/√(vc² + vs²), so the
    # mesh and Newton see first contact at t = -1 whatever the radii and speeds (rc = 1e-6
    # with rs = 1e6 no longer falls between the cells); scaled back at the end.
    length, speed = params["rc"] + params["rs"], math.hypot(params["vc"], params["vs"])
    unit = {
        "rc": params["rc"] / length,
        "rs": params["rs"] / length,
        "vc": params["vc"] / speed,
        "vs": params["vs"] / speed,
    }
    with progress.on_terminal():
        part = collision.build_part(unit, resolution)
    lo, hi = collision.box(unit)
    cell = max(high - low for low, high in zip(lo, hi)) / resolution
    point = first_contact(part, unit)
    scale = np.array([length, length, length, length / speed])
    point = point * scale
    components = components_through_singular_points(part, cell)
    contact = {
        "t": float(point[3]),
        "x": float(point[0]),
        "y": float(point[1]),
        "z": float(point[2]),
    }
    result = {
        "colliding_point": contact,
        # None: the surface is too thin for a mesh at this resolution (a tiny radius)
        "components": components or None,
    }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        p = contact
        pieces = (
            f"the collision surface has {components} component(s)"
            if components
            else "the collision surface is too thin to mesh at this resolution"
        )
        print(
            f"First contact at t = {p['t']:.6g}, at (x, y, z) = "
            f"({p['x']:.6g}, {p['y']:.6g}, {p['z']:.6g}); {pieces}."
        )
    return 0
