"""A moving cylinder meets a moving sphere (the paper's section 4.3, Figures 15-17).

In XYZT space each moving boundary is a hypersurface; their intersection is a 2-surface that
exists exactly while the two touch. The cylinder (radius rc, about the x-axis) moves along +y at
speed vc, the sphere (radius rs) along -z at speed vs; both are at the origin at t = 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.scenes import palette
from exhibit.scenes.base import Parameter, Preset, Scene
from exhibit.scenes.implicit_scene import ImplicitPart, fixed_silhouette, mesh_implicit
from exhibit.surfaces.mesh import Curve, Marker, Material, Mesh4D
from exhibit.surfaces.parametric import Interval, tessellate
from exhibit.surfaces.slice import SLICE_MATERIAL

AXES = ("x", "y", "z", "t")
CYLINDER = "(y - vc*t)^2 + z^2 - rc^2"
SPHERE = "x^2 + y^2 + (z + vs*t)^2 - rs^2"
SURFACE_COLOR, SILHOUETTE_COLOR, WIRE_COLOR = palette.ORANGE, palette.BLUE, palette.WIRE


def check(params: dict) -> str | None:
    """Why these parameters give no collision surface (None: they give one)."""
    if params["vc"] == 0 and params["vs"] == 0:
        return (
            "vc and vs cannot both be 0: with no motion the cylinder and sphere never "
            "move, so there is no collision surface"
        )
    return None


def contact_interval(params: dict) -> float:
    """|t| beyond which the two never touch: the centres are |t|·√(vc² + vs²) apart."""
    speed = math.hypot(params["vc"], params["vs"])
    return (params["rc"] + params["rs"]) / speed


def box(params: dict) -> tuple[list[float], list[float]]:
    rc, rs = params["rc"], params["rs"]
    big = 1.04
    T = big * contact_interval(params)
    lo = [-big * rs, -big * rs, -big * rc, -T]
    return lo, [-v for v in lo]


def initial_colliding_point_closed_form(params: dict) -> dict:
    """First contact: the centres are rc + rs apart at t0 = -(rc + rs)/v, and the contact point
    lies on the line between the sphere's centre and the cylinder's axis."""
    rc, rs, vc, vs = params["rc"], params["rs"], params["vc"], params["vs"]
    v = math.hypot(vc, vs)
    return {"t": -(rc + rs) / v, "x": 0.0, "y": -rs * vc / v, "z": vs * rc / v}


def refine_colliding_point(part: ImplicitPart, start: np.ndarray) -> np.ndarray | None:
    """Newton on the paper's condition C with Lagrange multipliers: minimise t on f = g = 0, i.e.
    e_t = λ∇f + μ∇g, f = 0, g = 0 (six equations in x, y, z, t, λ, μ)."""
    f, g = part.f1, part.f2
    x = np.concatenate([start, [0.0, 0.0]])
    gf, gg = f.gradient(start[None])[0], g.gradient(start[None])[0]
    lam, *_ = np.linalg.lstsq(np.stack([gf, gg], 1), np.array([0, 0, 0, 1.0]), rcond=None)
    x[4:] = lam

    def residual(z):
        p = z[None, :4]
        return np.concatenate(
            [
                z[4] * f.gradient(p)[0] + z[5] * g.gradient(p)[0] - [0, 0, 0, 1],
                [f.value(p)[0], g.value(p)[0]],
            ]
        )

    for _ in range(50):
        r = residual(x)
        if np.max(np.abs(r)) < 1e-13:
            break
        jac = np.empty((6, 6))
        for k in range(6):
            step = 1e-7 * max(1.0, abs(x[k]))
            dz = np.zeros(6)
            dz[k] = step
            jac[:, k] = (residual(x + dz) - residual(x - dz)) / (2 * step)
        x = x - np.linalg.lstsq(jac, r, rcond=None)[0]
    return x[:4] if np.max(np.abs(residual(x))) < 1e-9 else None


def colliding_point(part: ImplicitPart) -> np.ndarray | None:
    """The point of the collision surface with the smallest t, refined from the lowest vertex."""
    vertices = part.surface.positions
    if len(vertices) == 0:
        return None
    refined = refine_colliding_point(part, vertices[np.argmin(vertices[:, 3])])
    if refined is None or refined[3] > vertices[:, 3].min() + 1e-6:
        return vertices[np.argmin(vertices[:, 3])]
    return refined


def cylinder_at_rest(params: dict, length: float) -> list[Curve]:
    """The cylinder at t = 0 as a green wire mesh: circles along x and lines along its side."""
    rc = params["rc"]
    wire = Material(color=WIRE_COLOR, style="wire", line_width=1.5)
    curves: list[Curve] = []

    def piece() -> str:
        """One object, the wire pipe, in pieces: "wire pipe", "wire pipe 2", ... (a tag or a
        claim names it once, exhibit.timelines.object_names)."""
        return "wire pipe" if not curves else f"wire pipe {len(curves) + 1}"

    phi = np.linspace(0, 2 * math.pi, 48, endpoint=False)
    for x in np.linspace(-length, length, 7):
        ring = np.stack([np.full_like(phi, x), rc * np.cos(phi), rc * np.sin(phi), 0 * phi], -1)
        curves.append(Curve(piece(), ring, wire, closed=True))
    for angle in np.linspace(0, 2 * math.pi, 12, endpoint=False):
        line = np.array(
            [
                [-length, rc * math.cos(angle), rc * math.sin(angle), 0.0],
                [length, rc * math.cos(angle), rc * math.sin(angle), 0.0],
            ]
        )
        curves.append(Curve(piece(), line, wire))
    return curves


def world_at(params: dict, c: float) -> Mesh4D:
    """The 3D world at the moment t = c, in the hyperplane t = c: the pipe (its axis at
    y = vc·c) as a wire, so the ball inside it stays visible, and the ball (centre z = -vs·c)
    as a solid. Their intersection is the collision surface's slice at t = c."""
    rc, rs, vc, vs = params["rc"], params["rs"], params["vc"], params["vs"]
    length = 1.3 * max(rs, rc)
    pipe = []
    for curve in cylinder_at_rest(params, length):
        points = curve.points.copy()
        points[:, 1] += vc * c
        points[:, 3] = c
        pipe.append(Curve(curve.name, points, curve.material, curve.closed))

    def ball(theta, phi):
        return np.stack(
            [
                rs * np.sin(theta) * np.cos(phi),
                rs * np.sin(theta) * np.sin(phi),
                -vs * c + rs * np.cos(theta),
                np.full_like(theta, c),
            ],
            axis=-1,
        )

    def tangents(theta, phi):
        zero = np.zeros_like(theta)
        d_theta = np.stack(
            [
                rs * np.cos(theta) * np.cos(phi),
                rs * np.cos(theta) * np.sin(phi),
                -rs * np.sin(theta),
                zero,
            ],
            axis=-1,
        )
        d_phi = np.stack(
            [-rs * np.sin(theta) * np.sin(phi), rs * np.sin(theta) * np.cos(phi), zero, zero],
            axis=-1,
        )
        return d_theta, d_phi

    sphere = tessellate(
        "ball",
        ball,
        Interval(1e-3, math.pi - 1e-3),
        Interval(0.0, 2 * math.pi, periodic=True),
        (24, 48),
        tangents,
        Material(color=(0.75, 0.78, 0.85)),
        adaptive=False,
    )
    # The touching curve first: curves are layered in the mesh's order (render/gpu.py LAYERS),
    # and at the tangency moment it lies on the pipe's wire circle x = 0, which drew over it
    # every few pixels (a dashed curve in the inset).
    return Mesh4D([sphere], touching_curves(params, c) + pipe)


#: |g| at most this (relative to the radii squared) at every angle: the ball touches the pipe
#: along the whole circle. Round-off leaves about 1e-16; any motion away from c = 0 leaves
#: 2·rc·|c|·√(vc² + vs²).
TANGENCY_TOLERANCE = 1e-12


def _zero(g, outside: float, inside: float) -> float:
    """Where g changes sign between two angles (bisection: g is smooth, one crossing)."""
    for _ in range(60):
        middle = 0.5 * (outside + inside)
        if g(np.array(middle)) > 0:
            inside = middle
        else:
            outside = middle
    return inside


def touching_curves(params: dict, c: float, samples: int = 720) -> list[Curve]:
    """Where pipe and ball touch at the moment t = c, in closed form (the collision surface's
    slice at t = c, without tracing a mesh): around the pipe, at angle φ, the point
    (x, vc·c + rc cos φ, rc sin φ) is on the ball where x² = g(φ) = rs² - y² - (z + vs·c)².
    Where g > 0 for every φ the ball sticks out of both sides of the pipe: two loops, x > 0 and
    x < 0 (the paper's hole). Else each arc of φ with g > 0 is one loop, x = +√g out and -√g
    back, closing where g = 0 (found by interpolation)."""
    rc, rs, vc, vs = params["rc"], params["rs"], params["vc"], params["vs"]

    def g(phi):
        y, z = vc * c + rc * np.cos(phi), rc * np.sin(phi)
        return rs * rs - y * y - (z + vs * c) ** 2

    def point(phi, sign):
        return np.stack(
            [
                sign * np.sqrt(np.maximum(g(phi), 0.0)),
                vc * c + rc * np.cos(phi),
                rc * np.sin(phi),
                np.full_like(phi, c),
            ],
            axis=-1,
        )

    phi = np.linspace(0.0, 2 * math.pi, samples, endpoint=False)
    values = g(phi)
    if np.abs(values).max() <= TANGENCY_TOLERANCE * max(rs * rs, rc * rc):
        # g vanishes identically (c = 0 with rs = rc): the ball touches the pipe along the whole
        # circle x = 0, a tangency; round-off's signs would cut it into fragments.
        return [Curve("slice", point(phi, 0.0), SLICE_MATERIAL, True)]
    inside = values > 0
    if not inside.any():
        return []
    if inside.all():
        return [
            Curve(f"slice {i + 1}" if i else "slice", point(phi, sign), SLICE_MATERIAL, True)
            for i, sign in enumerate((1.0, -1.0))
        ]
    curves: list[Curve] = []
    start = int(np.argmin(inside))  # an index outside: arcs do not wrap past it
    order = np.roll(np.arange(samples), -start)
    step = 2 * math.pi / samples
    i = 0
    while i < samples:
        if not inside[order[i]]:
            i += 1
            continue
        j = i
        while j + 1 < samples and inside[order[j + 1]]:
            j += 1
        a, b = phi[order[i]], phi[order[j]]
        # the arc's ends, where g crosses 0 between the last sample outside and the first in
        end_a, end_b = _zero(g, a - step, a), _zero(g, b + step, b)
        arc = np.unwrap(np.concatenate([[end_a], phi[order[i : j + 1]], [end_b]]))
        loop = np.concatenate([point(arc, 1.0), point(arc[-2:0:-1], -1.0)])
        curves.append(
            Curve(f"slice {len(curves) + 1}" if curves else "slice", loop, SLICE_MATERIAL, True)
        )
        i = j + 1
    return curves


def build_part(
    params: dict, resolution: int, progress: Callable[[str], None] | None = None
) -> ImplicitPart:
    lo, hi = box(params)
    return mesh_implicit(
        "collision surface",
        CYLINDER,
        SPHERE,
        AXES,
        params,
        lo,
        hi,
        resolution,
        Material(color=SURFACE_COLOR),
        progress,
    )


def build(params: dict, resolution: int) -> Mesh4D:
    part = build_part(params, resolution)
    mesh = Mesh4D([part.surface])
    mesh.curves += fixed_silhouette(
        part, (0, 1), "silhouette along x and y", Material(color=SILHOUETTE_COLOR, line_width=3.0)
    )
    mesh.curves += cylinder_at_rest(params, 1.3 * max(params["rs"], params["rc"]))
    point = colliding_point(part)
    if point is not None:
        mesh.markers.append(
            Marker("initial colliding point", point, label=f"first contact, t = {point[3]:.3f}")
        )
    return mesh


def _view(**changes) -> ViewState:
    # "The sensor's position is just a little off the t axis": θ2, θ3 tilt it slightly. The eye
    # looks down from above the pipe, rolled (twist = π) so that z points up on the screen: the
    # ball moves along -z, so it falls on screen, in the inset (which keeps this eye) too.
    base = ViewState(
        angles=(0.0, -0.12, -0.1, 0.0, 0.0, 0.0),
        eye_azimuth=0.6,
        eye_incidence=-1.15,
        half_height=2.0,
        eye_r=1 / 10,
        twist=math.pi,
    )
    return base.replace(**changes)


FIGURE_PARAMS = {
    15: {"rc": 1.0, "rs": 1.0, "vc": 0.0, "vs": 1.0},
    16: {"rc": 1.0, "rs": 0.7, "vc": 0.2, "vs": 1.0},
    17: {"rc": 1.0, "rs": 1.2, "vc": 0.0, "vs": 1.0},
}

SCENE = Scene(
    name="collision",
    title="When a ball meets a pipe",
    caption=(
        "A ball falls through a pipe. Stack every moment of the motion along a fourth "
        "direction, time, and the places where they touch form this surface. Its earliest "
        "point, marked, is the very first touch."
    ),
    parameters=(
        Parameter("rc", 1.0, 0.1, 5.0, "cylinder radius"),
        Parameter("rs", 1.2, 0.1, 5.0, "sphere radius"),
        Parameter("vc", 0.0, -5.0, 5.0, "cylinder speed along +y"),
        Parameter("vs", 1.0, -5.0, 5.0, "sphere speed along -z"),
    ),
    build_mesh=build,
    view=_view(),
    presets=tuple(
        Preset(f"figure-{n}", _view(), params, caption)
        for n, params, caption in (
            (15, FIGURE_PARAMS[15], "Equal radii, only the sphere moves."),
            (16, FIGURE_PARAMS[16], "A smaller sphere: two separate pieces."),
            (17, FIGURE_PARAMS[17], "A larger sphere: one piece with a hole."),
        )
    ),
    # the wire cylinder is one object in pieces, "wire pipe" .. "wire pipe 19" (7 rings, then 12
    # lines); the silhouette's pieces and its touching branches, "NAME (touching)", as
    # exhibit.scenes.implicit_scene.fixed_silhouette names them
    objects=(
        "collision surface",
        "silhouette along x and y",
        "silhouette along x and y (touching)",
        "wire pipe",
        "initial colliding point",
    ),
    axes=AXES,
    default_resolution=48,
    slice_axis=3,
    world_at=world_at,
    check=check,
)
