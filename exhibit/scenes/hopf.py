"""The Hopf tori on the hypersphere, with the sensor approaching (the paper's Figures 6-8)."""

from __future__ import annotations

import functools
import math

import numpy as np

from exhibit.geometry.hopf import hopf_torus, hopf_torus_tangents
from exhibit.geometry.view import ViewState
from exhibit.scenes.base import Parameter, Preset, Scene
from exhibit.scenes.palette import AMBER, BLUE, GREEN, GREY, LAVENDER, PURPLE, RED
from exhibit.surfaces.mesh import Curve, Material, Mesh4D
from exhibit.surfaces.parametric import Interval, tessellate

#: (name, latitude Z on S^2, colour) as in Figures 6-8.
TORI = (
    ("torus Z=-√2/2", -math.sqrt(0.5), GREEN),
    ("torus Z=0", 0.0, GREY),
    ("torus Z=√2/2", math.sqrt(0.5), RED),
)
FIBRES = (("fibre Z=-1", -1.0, PURPLE), ("fibre Z=1", 1.0, BLUE))
AXES = (("x axis", 0, RED), ("y axis", 1, AMBER), ("z axis", 2, LAVENDER), ("w axis", 3, BLUE))


def build(params: dict, resolution: int) -> Mesh4D:
    full = Interval(0.0, 2 * math.pi, periodic=True)
    mesh = Mesh4D()
    for name, latitude, color in TORI:
        mesh.surfaces.append(
            tessellate(
                name,
                functools.partial(hopf_torus, latitude),
                full,
                full,
                (resolution, resolution),
                tangents=functools.partial(hopf_torus_tangents, latitude),
                material=Material(color=color),
                adaptive=False,
            )
        )
    angles = np.linspace(0.0, 2 * math.pi, 4 * resolution, endpoint=False)
    for name, latitude, color in FIBRES:
        mesh.curves.append(
            Curve(
                name,
                hopf_torus(latitude, angles, angles),
                Material(color=color, line_width=3.0),
                closed=True,
            )
        )
    length = params["axis_length"]
    for name, index, color in AXES:
        ends = np.zeros((2, 4))
        ends[0, index], ends[1, index] = -length, length
        mesh.curves.append(Curve(name, ends, Material(color=color, line_width=2.0)))
    return mesh


def _view(distance: float, **changes) -> ViewState:
    # The hypersphere sits at w = +1 in view coordinates: rotations turn it about its centre,
    # and with the sensor at distance 2 the sensor touches it.
    base = ViewState(
        offset=(0.0, 0.0, 0.0, 1.0),
        eye_azimuth=0.35,
        eye_incidence=-1.05,
        half_height=1.6,
        eye_r=1 / 9,
    )
    return base.with_sensor_distance(distance).replace(**changes)


SCENE = Scene(
    name="hopf",
    title="Hopf tori on the hypersphere",
    caption=(
        "Every point of a 4D ball's surface lies on exactly one circle, and circles of one "
        "'latitude' fill a doughnut. Here are three such doughnuts and two circles. Bring the "
        "4D viewpoint closer and watch the green doughnut swell."
    ),
    labels=(
        ("torus Z=-√2/2", "green doughnut"),
        ("fibre Z=1", "circle"),
        ("fibre Z=-1", "circle"),
    ),
    objects=tuple(name for name, *_ in TORI + FIBRES + AXES),
    parameters=(Parameter("axis_length", 1.6, 0.1, 10.0, "half-length of the drawn axes"),),
    build_mesh=build,
    view=_view(math.inf),
    presets=(
        Preset("figure-6", _view(math.inf), caption="The sensor at infinity."),
        Preset("figure-7", _view(3.0, half_height=2.2), caption="The sensor at distance 3."),
        # Zoomed out: at distance 2 the green torus's image spans ten times its size at infinity.
        # Not framed: the green torus filling the world is the point of the figure.
        Preset(
            "figure-8",
            _view(2.0, front_distance=0.6, front_pitch=0.5, half_height=5.0),
            caption="The sensor at distance 2, with a tilted front clipping plane.",
            fit=False,
        ),
    ),
    default_resolution=64,
)
