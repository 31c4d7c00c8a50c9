"""More surfaces for visitors: the Clifford torus and the graph of w = z² in C² = R^4."""

from __future__ import annotations

import math

import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.scenes import palette
from exhibit.scenes.base import Parameter, Preset, Scene
from exhibit.surfaces.mesh import Curve, Material, Mesh4D
from exhibit.surfaces.parametric import Interval, tessellate

FULL = Interval(0.0, 2 * math.pi, periodic=True)
#: The Clifford torus's four circles b = 0, π/2, π and 3π/2: one object drawn in four pieces
#: ("NAME", "NAME 2", .. "NAME 4": exhibit.timelines.object_names), so that one label or claim
#: names all four, as a tag "lines drawn on it" means. They were four objects, "circle b = kπ/2"
#: for k = 0..3, which only the old start-of-name match could name together ("circle b"); a
#: name for each circle was never used on its own. "circle b", the name the shipped timeline
#: and the scene's label write, stays an alias of it.
CIRCLES = "circles b = kπ/2"
#: The graph of w = z² and the two lines on it.
SQUARE, REAL, IMAGINARY = "w = z²", "real numbers: w = x²", "imaginary numbers: w = -y²"


def _clifford(params: dict, resolution: int) -> Mesh4D:
    """(cos a, sin a, cos b, sin b)/√2 · radius: a torus with no bend at all, inside S^3."""
    r = params["radius"] / math.sqrt(2)

    def point(a, b):
        return r * np.stack([np.cos(a), np.sin(a), np.cos(b), np.sin(b)], -1)

    def tangents(a, b):
        zero = np.zeros_like(a)
        return (
            r * np.stack([-np.sin(a), np.cos(a), zero, zero], -1),
            r * np.stack([zero, zero, -np.sin(b), np.cos(b)], -1),
        )

    surface = tessellate(
        "Clifford torus",
        point,
        FULL,
        FULL,
        (resolution, resolution),
        tangents,
        Material(color=(0.9, 0.6, 0.2)),
        adaptive=False,
    )
    a = np.linspace(0, 2 * math.pi, 4 * resolution, endpoint=False)
    circles = [
        Curve(
            CIRCLES if k == 0 else f"{CIRCLES} {k + 1}",
            point(a, np.full_like(a, k * math.pi / 2)),
            Material(color=palette.BLUE, line_width=2.5),
            closed=True,
        )
        for k in range(4)
    ]
    return Mesh4D([surface], circles)


def _complex_square(params: dict, resolution: int) -> Mesh4D:
    """The graph {(z, z²)} over the square |Re z|, |Im z| <= R: a surface in C² = R^4
    (x, y, u, v) with u + iv = (x + iy)². The real numbers trace the parabola u = x² on it."""
    size = params["radius"]

    def point(x, y):
        return np.stack([x, y, x * x - y * y, 2 * x * y], -1)

    def tangents(x, y):
        one, zero = np.ones_like(x), np.zeros_like(x)
        return (np.stack([one, zero, 2 * x, 2 * y], -1), np.stack([zero, one, -2 * y, 2 * x], -1))

    side = Interval(-size, size)
    surface = tessellate(
        SQUARE,
        point,
        side,
        side,
        (resolution, resolution),
        tangents,
        Material(color=palette.TEAL),
    )
    x = np.linspace(-size, size, 4 * resolution)
    real = Curve(
        REAL,
        point(x, np.zeros_like(x)),
        Material(color=palette.RED, line_width=3.0),
    )
    imaginary = Curve(
        IMAGINARY,
        point(np.zeros_like(x), x),
        Material(color=palette.BLUE, line_width=3.0),
    )
    return Mesh4D([surface], [real, imaginary])


CLIFFORD = Scene(
    name="clifford-torus",
    title="The flat doughnut",
    caption=(
        "In 3D every doughnut is curved. In 4D there is one that is perfectly flat, like a "
        "sheet of paper rolled up twice, and it lies on a 4D ball. Turn the knobs: it never "
        "stretches, it only looks as if it does."
    ),
    labels=((CIRCLES, "lines drawn on it"),),
    objects=("Clifford torus", CIRCLES),
    aliases={"circle b": CIRCLES},
    parameters=(Parameter("radius", 1.0, 0.2, 3.0, "radius of the 3-sphere it lies on"),),
    build_mesh=_clifford,
    view=ViewState(
        angles=(0.4, -0.7, -0.9, 0, 0, 0),
        eye_azimuth=0.3,
        eye_incidence=-1.0,
        sensor_r=1 / 3,
        half_height=1.4,
    ),
    presets=(
        Preset(
            "perspective",
            ViewState(
                angles=(0.4, -0.7, -0.9, 0, 0, 0),
                eye_azimuth=0.3,
                eye_incidence=-1.0,
                sensor_r=1 / 3,
                half_height=1.4,
            ),
        ),
    ),
    default_resolution=64,
)

COMPLEX_SQUARE = Scene(
    name="complex-square",
    title="Squaring, as a shape",
    caption=(
        "Squaring a complex number turns a plane into a plane, wrapping it twice around. "
        "Both planes together need four dimensions; this surface is every number paired "
        "with its square. Its shadows cross themselves; the surface itself never does."
    ),
    parameters=(Parameter("radius", 1.2, 0.2, 3.0, "largest |Re z| and |Im z| shown"),),
    objects=(SQUARE, REAL, IMAGINARY),
    build_mesh=_complex_square,
    view=ViewState(
        angles=(0.3, -0.9, -0.6, 0, 0, 0), eye_azimuth=0.5, eye_incidence=-1.1, half_height=1.8
    ),
    axes=("x", "y", "u", "v"),
    default_resolution=64,
)
