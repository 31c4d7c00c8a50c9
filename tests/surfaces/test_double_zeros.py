"""Silhouette branches where s touches zero without changing sign (issue 22): sign changes cannot
see them, so they are found where |s| dips along the surface and refined like the others."""

import json

import numpy as np

from exhibit import cli
from exhibit.scenes.implicit_scene import cell_size, mesh_implicit
from exhibit.surfaces.double_zeros import touching_silhouette
from exhibit.surfaces.mesh import Material


def _angle_gap(angles, special):
    d = np.abs((angles[:, None] - np.asarray(special)[None] + np.pi) % (2 * np.pi) - np.pi)
    return d.min(axis=1)


def test_the_tangency_circle_of_figure_15_is_a_silhouette_along_y_z(capsys):
    """rc = rs = 1, vc = 0, vs = 1: s = 4yt along y, z, and t ≤ 0 on the sheet z > 0 (t ≥ 0 on
    z < 0), so s keeps its sign across the circle t = 0, x = 0, y² + z² = 1. Before, no exported
    point was nearer than 1.38 to it."""
    argv = [
        "silhouette",
        "collision",
        "--along",
        "y,z",
        "--param",
        "rc=1",
        "--param",
        "rs=1",
        "--param",
        "vc=0",
        "--param",
        "vs=1",
        "--resolution",
        "24",
        "--json",
    ]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    points = np.concatenate([np.array(c) for c in out["curves"]])
    x, y, z, t = points.T
    # on both moving boundaries and on Lemma 3's condition, written out here
    assert np.abs(y**2 + z**2 - 1).max() < 1e-9
    assert np.abs(x**2 + y**2 + (z + t) ** 2 - 1).max() < 1e-9
    on_circle = (np.abs(t) < 1e-9) & (np.abs(x) < 1e-5)
    assert on_circle.sum() > 20
    # the circle is covered, except next to the two singular points (y = ±1) and where it
    # crosses the branch y = 0
    phi = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    phi = phi[_angle_gap(phi, [0, np.pi / 2, np.pi, -np.pi / 2]) > 0.25]
    circle = np.stack([0 * phi, np.cos(phi), np.sin(phi), 0 * phi], 1)
    gap = np.linalg.norm(circle[:, None] - points[on_circle][None], axis=-1).min(axis=1)
    assert gap.max() < 0.1


def test_no_fragment_of_the_touching_circle_is_exported():
    """At the scene's resolution the mesh that follows the surface put vertices on the singular
    points, and a touching piece 0.018 long (two points) was exported beside the circle's arcs:
    every curve is now at least a cell long."""
    argv = ["silhouette", "collision", "--along", "y,z", "--json"]
    argv += ["--param", "rc=1", "--param", "rs=1", "--param", "vc=0", "--param", "vs=1"]
    out = cli_json(argv)
    lengths = [np.linalg.norm(np.diff(np.array(c), axis=0), axis=1).sum() for c in out["curves"]]
    assert len(lengths) == 6 and min(lengths) > 4.0 / 48


def cli_json(argv) -> dict:
    """`exhibit ARGV` in this process, its JSON output."""
    import contextlib
    import io

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        assert cli.main(argv) == 0
    return json.loads(buffer.getvalue())


def test_a_planted_double_zero_is_found_and_nothing_else():
    """x² + y² = 1, v = (u - x)³/3: along x, u, s = (∇f1·e_x)(∇f2·e_u) - (∇f1·e_u)(∇f2·e_x)
    = -2x(u - x)², a double zero on the curve u = x, v = 0 (and a simple one at x = 0, which
    the sign-change tracer finds)."""
    part = mesh_implicit(
        "planted",
        "x^2 + y^2 - 1",
        "v - (u - x)^3/3",
        ("x", "y", "u", "v"),
        {},
        [-1.2, -1.2, -1.3, -4.0],
        [1.2, 1.2, 1.3, 4.0],
        16,
        Material(),
    )
    curves = touching_silhouette(part.f1, part.f2, part.surface, (0, 2), cell_size(part))
    assert curves
    points = np.concatenate([c.points for c in curves])
    x, y, u, v = points.T
    assert np.abs(x**2 + y**2 - 1).max() < 1e-9
    assert np.abs(u - x).max() < 1e-4 and np.abs(v).max() < 1e-9
    # it covers the curve (cos θ, sin θ, cos θ, 0) away from x = 0
    theta = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    theta = theta[np.abs(np.cos(theta)) > 0.3]
    curve = np.stack([np.cos(theta), np.sin(theta), np.cos(theta), 0 * theta], 1)
    gap = np.linalg.norm(curve[:, None] - points[None], axis=-1).min(axis=1)
    assert gap.max() < 2 * cell_size(part)


def test_a_simple_zero_is_not_reported_as_touching():
    """x² + y² = 1, v = u: along x, u, s = 2x changes sign: nothing touches zero."""
    part = mesh_implicit(
        "simple",
        "x^2 + y^2 - 1",
        "v - u",
        ("x", "y", "u", "v"),
        {},
        [-1.2, -1.2, -1.2, -1.2],
        [1.2, 1.2, 1.2, 1.2],
        12,
        Material(),
    )
    assert touching_silhouette(part.f1, part.f2, part.surface, (0, 2), cell_size(part)) == []


def test_the_drawn_silhouette_has_the_touching_branch_too():
    """The drawn scenes' fixed_silhouette (what the collision and offset scenes draw) finds the
    touching circle of Figure 15's scene along y, z itself, with the same refinement as
    `exhibit silhouette`. Before, it drew nothing nearer than 1.38 to it."""
    from exhibit.scenes import collision
    from exhibit.scenes.implicit_scene import fixed_silhouette

    part = collision.build_part({"rc": 1.0, "rs": 1.0, "vc": 0.0, "vs": 1.0}, 24)
    curves = fixed_silhouette(part, (1, 2), "silhouette along y and z", Material())
    touching = [c for c in curves if "(touching)" in c.name]
    assert touching
    points = np.concatenate([c.points for c in touching])
    x, y, z, t = points.T
    # every point of the touching curves lies on the circle t = 0, x = 0, y² + z² = 1
    distance = np.sqrt(x**2 + t**2 + (np.hypot(y, z) - 1) ** 2)
    assert distance.max() < 1e-6
    # and they cover it, except next to the singular points (y = ±1) and the crossings with
    # the branch y = 0
    phi = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    phi = phi[_angle_gap(phi, [0, np.pi / 2, np.pi, -np.pi / 2]) > 0.25]
    circle = np.stack([0 * phi, np.cos(phi), np.sin(phi), 0 * phi], 1)
    gap = np.linalg.norm(circle[:, None] - points[None], axis=-1).min(axis=1)
    assert gap.max() < 0.1
