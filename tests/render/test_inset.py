"""The time-slice inset (exhibit/render/inset.py) and `exhibit render --slice A=C --inset`."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from exhibit import scenes
from exhibit.render.inset import BORDER, inset_mesh, inset_rect, inset_view


@pytest.fixture(scope="module")
def collision():
    scenes.load()
    return scenes.get("collision")


def test_the_collision_world_at_a_moment_lies_in_that_hyperplane(collision):
    params = collision.resolve({"vc": 0.3})
    mesh = collision.build(params, 24)
    world = inset_mesh(collision, params, mesh, 3, -1.0)
    ball = world.surfaces[0].positions
    assert np.all(ball[:, 3] == -1.0)
    centre = np.array([0.0, 0.0, 1.0])  # the ball falls along -z: at t = -1 it is at z = vs
    assert np.abs(np.linalg.norm(ball[:, :3] - centre, axis=1) - params["rs"]).max() < 1e-12
    pipe = [c for c in world.curves if c.name.startswith("cylinder")]
    for curve in pipe:  # the pipe's axis has moved to y = vc * t
        y, z = curve.points[:, 1] + 0.3, curve.points[:, 2]
        assert np.allclose(np.hypot(y, z), params["rc"]) and np.all(curve.points[:, 3] == -1.0)
    slices = [c for c in world.curves if c.name.startswith("slice")]
    assert len(slices) == 1 and np.all(slices[0].points[:, 3] == -1.0)


def test_a_scene_without_a_world_shows_its_slice_curves_with_the_axis_projected_away():
    scenes.load()
    hopf = scenes.get("hopf")
    mesh = hopf.build({}, 24)
    world = inset_mesh(hopf, hopf.resolve({}), mesh, 1, 0.2)  # slice y = 0.2
    assert not world.surfaces and world.curves
    for curve in world.curves:
        assert np.allclose(curve.points[:, 3], 0.2)  # y moved last: the sensor drops it


def test_the_inset_sits_in_the_bottom_right_and_keeps_its_view_to_the_eye(collision):
    size = (1920, 1080)
    rect = inset_rect(size, 24)
    assert rect.x1 == 1920 - 24 and rect.y1 == 1080 - 24
    assert rect.height == pytest.approx(0.36 * 1080, abs=1)
    main = collision.view.replace(angles=(0.3, 0.2, 0.1, 0.5, 0.4, 0.2), eye_azimuth=0.7)
    world = inset_mesh(collision, collision.resolve({}), collision.build({}, 24), 3, 0.0)
    view = inset_view(main, world, (int(rect.width), int(rect.height)))
    assert view.angles == (0.0,) * 6 and view.sensor_r == 0.0
    assert view.eye_azimuth == main.eye_azimuth and view.eye_incidence == main.eye_incidence


def test_render_draws_the_inset_beside_the_framed_picture(cli, tmp_path):
    out = tmp_path / "inset.png"
    result = cli(
        "render",
        "collision",
        "--slice",
        "t=-1.2",
        "--inset",
        "--size",
        "640x360",
        "--samples",
        "0",
        "--resolution",
        "24",
        "--out",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    picture = np.asarray(Image.open(out).convert("RGB")).astype(int)
    rect = inset_rect((640, 360), 8)
    # its border, at the rectangle's left edge, whatever the margin: find the border column
    row = picture[int(rect.y0 + rect.height / 2)]
    border = np.flatnonzero(np.abs(row - 255 * np.array(BORDER[:3])).max(axis=1) < 12)
    assert len(border) and border.min() > 640 * 0.4
    inside = picture[int(rect.y0) + 10 :, border.min() + 3 : -12]
    assert np.unique(inside.reshape(-1, 3), axis=0).shape[0] > 200  # a picture, not a panel
    # the glowing slice: bright warm pixels in the main picture, left of the inset
    main = picture[:, : border.min() - 2]
    glow = (main[..., 0] > 200) & (main[..., 1] > 180) & (main[..., 2] > 80) & (main[..., 2] < 190)
    assert glow.sum() > 50


@pytest.mark.parametrize(
    "args, message",
    [
        (("--inset",), "--inset shows the 3D world at a slice: give --slice AXIS=C too"),
        (("--slice", "w=0"), "is not AXIS=C with AXIS one of x, y, z, t"),
        (("--slice", "t=nan"), "must be a finite number"),
        (("--slice", "t=abc"), "'abc' is not a number"),
    ],
)
def test_bad_slice_arguments_get_one_line(cli, tmp_path, args, message):
    result = cli("render", "collision", *args, "--out", str(tmp_path / "x.png"))
    assert result.returncode == 2 and message in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("c, loops", [(-2.5, 0), (-2.0, 1), (-0.1, 2), (0.0, 2), (1.5, 1)])
def test_the_touching_curve_in_closed_form(c, loops):
    """collision.touching_curves (what the kiosk's inset draws every frame): on the pipe and
    the ball at the moment c to 1e-9, one loop per arc of contact, two while the hole is open
    (rc = 1, rs = 1.2, vs = 1: contact for |c| < 2.2, the hole for |c| < 0.2)."""
    from exhibit.scenes.collision import touching_curves

    p = {"rc": 1.0, "rs": 1.2, "vc": 0.0, "vs": 1.0}
    curves = touching_curves(p, c)
    assert len(curves) == loops
    for curve in curves:
        x, y, z, t = curve.points.T
        assert curve.closed and len(curve.points) > 20 and np.all(t == c)
        assert np.abs(np.hypot(y, z) - 1.0).max() < 1e-9
        assert np.abs(np.sqrt(x**2 + y**2 + (z + c) ** 2) - 1.2).max() < 1e-9


def _screen_y(view, points):
    """Pixel rows (down the screen) of 4D points in ``view``."""
    from exhibit.geometry.pipeline import clip_transform

    projected = clip_transform(view, 1.0).to_pixels(np.asarray(points, float), 100, 100)
    xy = np.asarray(projected[0] if isinstance(projected, tuple) else projected.points)
    return xy[:, 1]


def test_the_ball_falls_on_screen_in_the_inset_and_the_main_view(collision):
    """The ball moves along -z (centre z = -vs·t): z must point up on the screen, so the ball
    seen in the inset falls as the captions say, and the main view's first contact (the top of
    the pipe, where the falling ball meets it) is drawn at the top of the surface."""
    params = collision.resolve({})
    world = {c: inset_mesh(collision, params, None, 3, c) for c in (-1.5, 1.5)}
    view = inset_view(
        collision.view,
        np.concatenate([w.surfaces[0].positions for w in world.values()]),
        (400, 300),
    )
    early, late = (_screen_y(view, world[c].surfaces[0].positions).mean() for c in (-1.5, 1.5))
    pipe = _screen_y(view, [[0, 0, 0, 0]])[0]
    assert early < pipe < late  # above the pipe, then below it: falling
    mesh = collision.build(params, 24)
    first = mesh.markers[0].position
    rows = _screen_y(collision.view, mesh.surfaces[0].positions)
    assert _screen_y(collision.view, [first])[0] < rows.min() + 0.1 * (rows.max() - rows.min())


def test_the_touching_curve_at_tangency_is_drawn_whole_over_the_pipe(collision, gl):
    """At rc = rs = 1, vc = 0, t = 0 the ball touches the pipe along its wire circle x = 0; the
    touching curve comes first in the mesh's layers, so the pipe's wire no longer cuts it into
    dashes. Along its projected front half, 98% of the samples have the slice colour (7% before)."""
    from exhibit.geometry import clip_transform
    from exhibit.render import RenderOptions
    from exhibit.surfaces.slice import SLICE_MATERIAL

    params = collision.resolve({"rc": 1, "rs": 1, "vc": 0, "vs": 1})
    world = inset_mesh(collision, params, collision.build(params, 24), 3, 0.0)
    size = (320, 320)
    view = inset_view(collision.view, world, size)
    gpu = gl.renderer.upload(world)
    options = RenderOptions(hud=False, silhouettes=False, pinch_points=False)
    image = gl.image(gpu, view, size, options, samples=0).astype(int)
    gpu.release()
    colour = np.array(SLICE_MATERIAL.color) * 255
    near = np.abs(image - colour).max(axis=2) < 60
    phi = np.linspace(0.0, 2 * np.pi, 400, endpoint=False)
    circle = np.stack([0 * phi, np.cos(phi), np.sin(phi), 0 * phi], axis=1)
    ct = clip_transform(view, 1.0)
    pixels, ok = ct.to_pixels(circle, *size)
    depth = ct.to_ndc(circle)[0][:, 2]
    front = ok & (depth <= np.median(depth))  # the half nearer the eye
    cover = [near[int(y), int(x)] for x, y in pixels[front]]  # y down, pixel i: [i, i + 1)
    print("covered", np.mean(cover))
    assert np.mean(cover) > 0.9, np.mean(cover)
