"""`exhibit sweep`: the sensor approaching the hypersphere (the paper's Figures 6-8), in numbers.

For each Hopf torus of Figures 6-8 it prints the size of its 3D image as the sensor moves in from
infinity: the paper's observation that "the circumference of the green 2-surface enlarges
significantly while the red one enlarges only moderately", measured by the geometry core.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

import numpy as np

from exhibit.commands import _arg_types as _args
from exhibit.geometry import ViewState, project_to_3d
from exhibit.geometry.hopf import hopf_torus

HELP = "the sensor approaching the hypersphere (Figures 6-8): sizes of the Hopf tori's images"

#: The tori of Figures 6-8: name (the paper's colour) and latitude Z on S^2.
TORI = (("green", -math.sqrt(2) / 2), ("gray", 0.0), ("red", math.sqrt(2) / 2))
#: The hypersphere is translated by 1 along +w, so the sensor at distance 2 touches it.
HYPERSPHERE_OFFSET = (0.0, 0.0, 0.0, 1.0)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--distances",
        type=_args.distances,
        default="inf,6,4,3,2.5,2.2,2",
        help="comma-separated sensor distances (inf = orthographic); default: %(default)s",
    )
    parser.add_argument(
        "--samples",
        type=_args.integer(8, 2048),
        default=181,
        help="samples per circle of each torus (default: %(default)s)",
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")


def torus_image_area(latitude: float, view: ViewState, samples: int) -> tuple[float, float]:
    """Area and largest radius of the torus's image in R^3, from a samples x samples grid."""
    angles = np.linspace(0.0, 2 * math.pi, samples)
    alpha, beta = np.meshgrid(angles, angles, indexing="ij")
    points = view.to_view(hopf_torus(latitude, alpha, beta))
    image, in_front = project_to_3d(points, view.sensor_r)
    if not in_front.all():
        return math.inf, math.inf
    # Two triangles per grid cell; the area is the sum of their areas.
    a, b = image[:-1, :-1], image[1:, :-1]
    c, d = image[1:, 1:], image[:-1, 1:]
    area = (
        0.5
        * (
            np.linalg.norm(np.cross(b - a, c - a), axis=-1)
            + np.linalg.norm(np.cross(c - a, d - a), axis=-1)
        ).sum()
    )
    return float(area), float(np.linalg.norm(image, axis=-1).max())


def run(args: argparse.Namespace) -> int:
    distances = args.distances
    base = ViewState(offset=HYPERSPHERE_OFFSET)
    rows = []
    for distance in distances:
        view = base.with_sensor_distance(distance)
        row: dict[str, Any] = {"sensor_distance": None if math.isinf(distance) else distance}
        for name, latitude in TORI:
            area, radius = torus_image_area(latitude, view, args.samples)
            row[name] = {"area": area, "max_radius": radius}
        rows.append(row)
    if args.json:
        print(json.dumps({"tori": dict(TORI), "rows": rows}, indent=2))
        return 0
    print("Hopf tori on the hypersphere (moved +1 along w) seen by a sensor moving in along w.")
    print("Area of each torus's 3D image, and its growth since the first distance:")
    print(f"{'sensor distance':>16} " + " ".join(f"{name:>20}" for name, _ in TORI))
    first = rows[0]
    for row in rows:
        label = "inf" if row["sensor_distance"] is None else f"{row['sensor_distance']:g}"
        cells = []
        for name, _ in TORI:
            area = row[name]["area"]
            growth = area / first[name]["area"]
            cells.append(f"{area:10.3f} (x{growth:6.2f})")
        print(f"{label:>16} " + " ".join(f"{cell:>20}" for cell in cells))
    print("As in Figures 6-8: the green torus grows far more than the red one.")
    return 0
