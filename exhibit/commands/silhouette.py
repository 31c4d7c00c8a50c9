"""`exhibit silhouette SCENE --along A,B`: the silhouette curves of a scene's surfaces for the
orthographic projection along two of its axes (Lemma 3(c)) — e.g. the offset curve of a pipe
surface along u, v, or the collision curve along x, y."""

from __future__ import annotations

import json

import numpy as np

from exhibit import scenes
from exhibit.errors import ExhibitError
from exhibit.geometry.silhouette import silhouette_function, zero_set_segments
from exhibit.scenes.base import add_scene_arguments, parse_overrides, parse_resolution
from exhibit.surfaces import progress
from exhibit.surfaces.curves import chain_segments

HELP = "silhouette curves of a scene for the orthographic view along two axes"


def add_arguments(parser) -> None:
    add_scene_arguments(parser)
    parser.add_argument("--along", required=True, metavar="AXIS,AXIS",
                        help="two of the scene's axis names, e.g. u,v or x,y")
    parser.add_argument("--json", action="store_true", help="print JSON")


def parse_along(text: str, axes: tuple[str, ...]) -> tuple[int, int]:
    names = [a.strip() for a in text.split(",")]
    if len(names) != 2 or names[0] == names[1]:
        raise ExhibitError(f"--along needs two different axis names, got {text!r}")
    for name in names:
        if name not in axes:
            raise ExhibitError(f"--along: {name!r} is not an axis of this scene "
                               f"(axes: {', '.join(axes)})")
    return axes.index(names[0]), axes.index(names[1])


def run(args) -> int:
    scene = scenes.get(args.scene)
    along = parse_along(args.along, scene.axes)
    overrides = parse_overrides(args.param)
    resolution = parse_resolution(args.resolution)
    with progress.on_terminal():
        mesh = scene.build(overrides, resolution)
    e = np.eye(4)
    curves = []
    for surface in mesh.surfaces:
        # The stored normals span the same plane as the gradients, so s has the same zero set.
        n1, n2 = surface.normals[:, 0], surface.normals[:, 1]
        values = silhouette_function(n1, n2, e[along[0]], e[along[1]])
        segments = zero_set_segments(surface.positions, surface.triangles, values)
        for points, closed in chain_segments(segments):
            if closed:
                points = np.vstack([points, points[:1]])
            curves.append(np.round(points, 9).tolist())
    if args.json:
        print(json.dumps({"axes": list(scene.axes), "curves": curves}))
        return 0
    print(f"{len(curves)} silhouette curve(s) of {scene.name} along "
          f"{scene.axes[along[0]]}, {scene.axes[along[1]]}:")
    for i, curve in enumerate(curves, 1):
        print(f"  curve {i}: {len(curve)} points")
    return 0
