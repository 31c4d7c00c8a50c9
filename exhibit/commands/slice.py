"""`exhibit slice SCENE --axis A --at C`: the curves where a scene's surfaces cross the
hyperplane A = C — for the collision along t, the 3D world at the moment C (where the pipe and
the ball meet then). Every point is refined onto the exact surface and the hyperplane
(exhibit/surfaces/slice.py); points that do not converge are dropped and counted."""

from __future__ import annotations

import argparse
import json

from exhibit import scenes
from exhibit.commands._arg_types import number
from exhibit.errors import ExhibitError
from exhibit.scenes.base import add_scene_arguments, build_from_arguments
from exhibit.surfaces.exact_silhouette import RefineStats
from exhibit.surfaces.slice import slice_curves

HELP = "the curves where a scene's surfaces cross a hyperplane (e.g. the collision at time t)"
#: The largest |C| accepted (scenes live within a few units of the origin).
MAX_AT = 1e6


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scene_arguments(parser)
    parser.add_argument(
        "--axis",
        required=True,
        metavar="AXIS",
        help="one of the scene's axis names, e.g. t for the collision",
    )
    parser.add_argument(
        "--at",
        required=True,
        type=number(-MAX_AT, MAX_AT),
        metavar="C",
        help="where the hyperplane AXIS = C lies",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def parse_axis(name: str, axes: tuple[str, ...]) -> int:
    name = name.strip()
    if name not in axes:
        raise ExhibitError(
            f"--axis: {name!r} is not an axis of this scene (axes: {', '.join(axes)})"
        )
    return axes.index(name)


def run(args: argparse.Namespace) -> int:
    scene = scenes.get(args.scene)
    axis = parse_axis(args.axis, tuple(scene.axes))
    mesh = build_from_arguments(scene, args)
    stats = RefineStats()
    curves = []
    for surface in mesh.surfaces:
        curves += [
            curve.polyline().tolist()
            for curve in slice_curves(surface, axis, float(args.at), stats)
        ]
    if args.json:
        print(
            json.dumps(
                {
                    "axis": scene.axes[axis],
                    "at": float(args.at),
                    "axes": list(scene.axes),
                    "curves": curves,
                    "refined": int(stats.refined),
                    "dropped": int(stats.dropped),
                    "max_residual": stats.max_residual,
                }
            )
        )
        return 0
    print(f"{len(curves)} curve(s) of {scene.name} at {scene.axes[axis]} = {args.at:g}:")
    for i, curve in enumerate(curves, 1):
        print(f"  curve {i}: {len(curve)} points")
    print(
        f"  {stats.refined} points refined to residual {stats.max_residual:.1e}, "
        f"{stats.dropped} dropped (no convergence)"
    )
    return 0
