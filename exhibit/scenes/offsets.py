"""Offset curves as silhouettes of pipe surfaces (the paper's section 4.2, Figures 9-14).

A plane curve f(u, v) = 0 and the circle g = (x - u)² + (y - v)² - r² = 0 around each of its
points make a pipe-like 2-surface in XYUV space. Seen orthographically along u and v, its
silhouette (condition C, Lemma 3(c)) is exactly the offset curve at distance r: smooth in 4D even
where the offset curve in the plane has cusps and self-intersections. For the cusp y² = x³ the
points with u = v = 0 are singular: a circle of radius r that the envelope method wrongly adds.
Traced in XYT space from the parametrisation (t², t³), the pipe h = 0 is smooth and that circle
is another branch of the silhouette along t (Figures 13-14).
"""

from __future__ import annotations

import math

import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.scenes import palette
from exhibit.scenes.base import Parameter, Preset, Scene
from exhibit.scenes.implicit_scene import ImplicitPart, fixed_silhouette, mesh_implicit
from exhibit.surfaces.mesh import Curve, Material, Mesh4D

PIPE = "(x - u)^2 + (y - v)^2 - r^2"
PIPE_COLOR, OFFSET_COLOR, SINGULAR_COLOR = palette.SKY, palette.RED, palette.YELLOW
CURVE_COLOR = (0.1, 0.1, 0.1)
XYUV = ("x", "y", "u", "v")
PARAMETERS = (Parameter("r", 1.0, 0.1, 3.0, "offset distance"),)
#: The objects' names. The silhouettes are traced in pieces ("NAME 2", ...), and a branch
#: where the silhouette function touches zero is a second object, "NAME (touching)"
#: (exhibit.scenes.implicit_scene.fixed_silhouette).
OFFSET = "offset curve (silhouette along u, v)"
PARABOLA_PIPE, CUSP_PIPE = "pipe of y = x²", "pipe of y² = x³"
BASE, SINGULAR = "base curve", "circle of singular points"
TRACED_PIPE, TRACED_OUTLINE = "tracing surface h = 0", "silhouette along t"
TRACED_BASE = "base curve (t², t³, t)"


def _touching(name: str) -> str:
    return f"{name} (touching)"


def _box(u_range, v_range, r):
    margin = 1.05 * r
    return (
        [u_range[0] - margin, v_range[0] - margin, u_range[0], v_range[0]],
        [u_range[1] + margin, v_range[1] + margin, u_range[1], v_range[1]],
    )


def _base_curve(points_uv: np.ndarray) -> Curve:
    """The curve f = 0 itself, drawn where it lives on the surface's u, v face (x = u, y = v)."""
    u, v = points_uv.T
    return Curve(BASE, np.stack([u, v, u, v], -1), Material(color=CURVE_COLOR, line_width=2.0))


def build_pipe(
    name: str,
    f_text: str,
    u_range: tuple[float, float],
    v_range: tuple[float, float],
    base_points: np.ndarray,
    params: dict,
    resolution: int,
) -> tuple[ImplicitPart, Mesh4D]:
    lo, hi = _box(u_range, v_range, params["r"])
    part = mesh_implicit(
        name, PIPE, f_text, XYUV, params, lo, hi, resolution, Material(color=PIPE_COLOR)
    )
    mesh = Mesh4D([part.surface])
    mesh.curves += fixed_silhouette(
        part,
        (2, 3),
        OFFSET,
        Material(color=OFFSET_COLOR, line_width=3.5),
    )
    mesh.curves.append(_base_curve(base_points))
    return part, mesh


def build_parabola(params: dict, resolution: int) -> Mesh4D:
    s = np.linspace(-1.5, 1.5, 200)
    return build_pipe(
        PARABOLA_PIPE,
        "v - u^2",
        (-1.5, 1.5),
        (-0.05, 2.3),
        np.stack([s, s * s], -1),
        params,
        resolution,
    )[1]


def build_cusp(params: dict, resolution: int) -> Mesh4D:
    s = np.linspace(-1.2, 1.2, 201)
    part, mesh = build_pipe(
        CUSP_PIPE,
        "v^2 - u^3",
        (-0.05, 1.45),
        (-1.75, 1.75),
        np.stack([s**2, s**3], -1),
        params,
        resolution,
    )
    # The singular circle: found by the polygonizer, drawn from its analytic form.
    phi = np.linspace(0, 2 * math.pi, 96, endpoint=False)
    r = params["r"]
    circle = np.stack([r * np.cos(phi), r * np.sin(phi), 0 * phi, 0 * phi], -1)
    mesh.curves.append(
        Curve(
            SINGULAR,
            circle,
            Material(color=SINGULAR_COLOR, line_width=3.0),
            closed=True,
        )
    )
    return mesh


def build_traced(params: dict, resolution: int) -> Mesh4D:
    """h = (x - t²)² + (y - t³)² - r² = 0 in XYT (w = 0), and its silhouette along t."""
    r = params["r"]
    t_max = 1.2
    lo = [-r * 1.05, -(t_max**3) - 1.05 * r, -t_max, -0.05]
    hi = [t_max**2 + 1.05 * r, t_max**3 + 1.05 * r, t_max, 0.05]
    part = mesh_implicit(
        TRACED_PIPE,
        "(x - t^2)^2 + (y - t^3)^2 - r^2",
        "w",
        ("x", "y", "t", "w"),
        params,
        lo,
        hi,
        resolution,
        Material(color=PIPE_COLOR),
    )
    mesh = Mesh4D([part.surface])
    mesh.curves += fixed_silhouette(
        part, (2, 3), TRACED_OUTLINE, Material(color=OFFSET_COLOR, line_width=3.5)
    )
    s = np.linspace(-t_max, t_max, 200)
    mesh.curves.append(
        Curve(
            TRACED_BASE,
            np.stack([s**2, s**3, s, 0 * s], -1),
            Material(color=CURVE_COLOR, line_width=2.0),
        )
    )
    return mesh


def _ortho(**changes) -> ViewState:
    """Sensor at infinity along v's direction tilted a little, eye orthographic: Figures 9, 11."""
    return ViewState(
        angles=(0.3, -0.5, -0.35, 0.0, 0.0, 0.0),
        eye_azimuth=0.25,
        eye_incidence=-0.9,
        eye_r=0.0,
        half_height=2.4,
    ).replace(**changes)


def _perspective(**changes) -> ViewState:
    """Sensor and eye at finite distances: Figures 10, 12."""
    return ViewState(
        angles=(0.9, -0.8, -0.6, 0.0, 0.0, 0.0),
        eye_azimuth=-0.4,
        eye_incidence=-1.0,
        sensor_r=1 / 6,
        eye_r=1 / 9,
        half_height=2.6,
    ).replace(**changes)


PARABOLA = Scene(
    name="offset-parabola",
    title="The offset of a parabola, untangled in 4D",
    caption=(
        "Draw every point at distance 1 from the curve y = x² and you get a curve with "
        "sharp corners and a loop. Lifted into 4D it becomes the red outline of a smooth "
        "tube: no corners, no crossing."
    ),
    labels=(("offset curve", "offset curve"),),
    objects=(PARABOLA_PIPE, OFFSET, _touching(OFFSET), BASE),
    aliases={"offset curve": OFFSET, "pipe": PARABOLA_PIPE},
    parameters=PARAMETERS,
    build_mesh=build_parabola,
    view=_ortho(),
    presets=(
        Preset("figure-9", _ortho(), caption="Viewed orthographically."),
        Preset("figure-10", _perspective(), caption="Viewed in perspective."),
    ),
    axes=XYUV,
    default_resolution=48,
)

CUSP = Scene(
    name="offset-cusp",
    title="The offset of a cusp, and a circle that should not be there",
    caption=(
        "The curve y² = x³ has a sharp cusp. Its offset, traced in 4D, is again a smooth "
        "red curve, but the tube pinches along a yellow circle of singular points: the "
        "extra circle the usual equations wrongly add to the offset."
    ),
    labels=(("offset curve", "offset curve"), (SINGULAR, "singular points")),
    objects=(CUSP_PIPE, OFFSET, _touching(OFFSET), BASE, SINGULAR),
    aliases={"offset curve": OFFSET, "pipe": CUSP_PIPE},
    parameters=PARAMETERS,
    build_mesh=build_cusp,
    view=_ortho(),
    presets=(
        Preset("figure-11", _ortho(), caption="Viewed orthographically."),
        Preset("figure-12", _perspective(), caption="Viewed in perspective."),
    ),
    axes=XYUV,
    default_resolution=48,
)

TRACED = Scene(
    name="offset-cusp-traced",
    title="The cusp's offset traced in 3D",
    caption=(
        "Follow the cusp curve in time and sweep a circle along it: a smooth tube. Seen "
        "along the time axis its red outline has two kinds of branches: the offset curve, "
        "and the circle at t = 0."
    ),
    labels=((TRACED_OUTLINE, "outline along t"),),
    objects=(TRACED_PIPE, TRACED_OUTLINE, _touching(TRACED_OUTLINE), TRACED_BASE),
    parameters=PARAMETERS,
    build_mesh=build_traced,
    view=ViewState(eye_azimuth=0.5, eye_incidence=-1.1, eye_r=0.0, half_height=2.2),
    presets=(
        Preset(
            "figure-13",
            ViewState(eye_azimuth=0.5, eye_incidence=-1.1, eye_r=0.0, half_height=2.2),
            caption="Viewed orthographically.",
        ),
        Preset(
            "figure-14",
            ViewState(eye_azimuth=-0.6, eye_incidence=-1.2, eye_r=1 / 8, half_height=2.4),
            caption="Viewed in perspective.",
        ),
    ),
    axes=("x", "y", "t", "w"),
    default_resolution=48,
)
