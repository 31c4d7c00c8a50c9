"""Kiosk frames at every quality level (exhibit.render.frame): the right size, the background
under the scene, FXAA that softens surface edges and leaves lines and flat areas alone, a lower
render scale with a HUD as crisp as at full scale, and the frame timer."""

from dataclasses import replace

import numpy as np
import pytest

from exhibit import scenes
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.frame import FrameTimer
from exhibit.render.frame_request import FrameRequest
from exhibit.render.quality import LADDER, Quality, ladder, mesh_resolution
from exhibit.render.ssim import edge_mask, ssim
from tests.render.conftest import marker_mesh, square

SIZE = (240, 160)
BLACK = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


@pytest.fixture(scope="module")
def hopf(headless):
    scene, preset = scenes.figure(6)
    gpu = headless.renderer.upload(scene.build(preset.params, 16))
    yield gpu, preset.view
    gpu.release()


@pytest.mark.parametrize("quality", LADDER, ids=[q.name for q in LADDER])
def test_every_level_draws_a_frame(gl, hopf, quality):
    gpu, view = hopf
    image = gl.frame(gpu, view, SIZE, RenderOptions(), HudInfo(title="Hopf"), quality)
    assert image.shape == (SIZE[1], SIZE[0], 3)
    assert len(np.unique(image.reshape(-1, 3) // 32, axis=0)) >= 4


def test_the_background_is_the_gradient(gl, hopf):
    gpu, view = hopf
    options = RenderOptions(hud=False, surfaces=False, curves=False, silhouettes=False)
    direct = gl.image(gpu, view, SIZE, options, samples=0)
    for quality in (LADDER[1], Quality("x", "none", scale=0.5), LADDER[0]):
        framed = gl.frame(gpu, view, SIZE, options, None, quality)
        assert np.abs(framed.astype(int) - direct.astype(int)).max() <= 2, quality.name


def test_fxaa_softens_surface_edges_only(gl):
    """A tilted square: FXAA changes pixels along its edges, towards the MSAA picture, and
    nowhere else."""
    tilt = np.radians(17)
    u = (np.cos(tilt), np.sin(tilt), 0.0, 0.0)
    v = (-np.sin(tilt), np.cos(tilt), 0.0, 0.0)
    from exhibit.surfaces.mesh import Mesh4D

    gpu = gl.renderer.upload(
        Mesh4D(surfaces=[square("s", (0, 0, 0, 0), u, v, (0.9, 0.9, 0.9), half=1.0)])
    )
    view = scenes.get("hopf").view.replace(angles=(0.0,) * 6)
    options = RenderOptions(hud=False, silhouettes=False, background=BLACK)
    plain = gl.frame(gpu, view, SIZE, options, None, Quality("n", "none"))
    fxaa = gl.frame(gpu, view, SIZE, options, None, Quality("f", "fxaa"))
    msaa = gl.frame(gpu, view, SIZE, options, None, Quality("m", "msaa"))
    gpu.release()
    changed = np.abs(fxaa.astype(int) - plain.astype(int)).max(axis=-1) > 0
    shifted = np.roll(plain, 1, axis=0), np.roll(plain, 1, axis=1)
    steps = np.zeros(changed.shape, dtype=bool)
    for other in shifted:
        steps |= np.abs(plain.astype(int) - other.astype(int)).max(axis=-1) > 20
    edges = edge_mask(steps.astype(np.uint8) * 255, np.zeros_like(steps, dtype=np.uint8), grow=2)
    assert changed.any() and (changed & ~edges).sum() == 0
    mask = edge_mask(msaa, plain)
    assert ssim(fxaa, msaa, mask=mask) > ssim(plain, msaa, mask=mask)


def test_fxaa_leaves_lines_alone(gl):
    gpu = gl.renderer.upload(marker_mesh((0.3, 0.2, 0.0, 0.0)))
    view = scenes.get("hopf").view
    options = RenderOptions(hud=False, background=BLACK)
    plain = gl.frame(gpu, view, SIZE, options, None, Quality("n", "none", scale=1.0))
    fxaa = gl.frame(gpu, view, SIZE, options, None, Quality("f", "fxaa"))
    gpu.release()
    assert plain.max() > 100 and np.array_equal(plain, fxaa)


def test_a_lower_render_scale_keeps_the_hud_crisp(gl):
    from exhibit.surfaces.mesh import Mesh4D

    gpu = gl.renderer.upload(Mesh4D())
    view = scenes.get("hopf").view
    options = RenderOptions(background=BLACK)
    hud = HudInfo(title="Crisp")
    full = gl.frame(gpu, view, SIZE, options, hud, Quality("a", "fxaa", scale=1.0))
    half = gl.frame(gpu, view, SIZE, options, hud, Quality("b", "fxaa", scale=0.5))
    gpu.release()
    assert np.array_equal(full, half)  # nothing in the scene: only the HUD, at full size


def test_the_direct_level_is_lean_without_the_fxaa_pass(gl, hopf):
    """The direct level draws straight into the destination (no scene target, no post pass):
    its picture is lean's but for what FXAA would soften, and its HUD is laid out by the same
    [text] sizes as every other level's (the direct path once left them out)."""
    from exhibit.render.layout import TextSizes

    gpu, view = hopf
    levels = {q.name: q for q in LADDER}
    direct, lean = levels["direct"], levels["lean"]
    assert (direct.antialiasing, direct.mesh, direct.effects, direct.scale) == (
        "none",
        lean.mesh,
        lean.effects,
        1.0,
    )
    options = RenderOptions(text=TextSizes(caption_cap=0.05, title_cap=0.08))
    hud = HudInfo(title="Hopf", caption="A torus on the hypersphere")
    size = (480, 320)
    pictures, layouts = {}, {}
    for q in (direct, lean):
        pictures[q.name] = gl.frame(gpu, view, size, options, hud, q)
        layouts[q.name] = gl.renderer.hud.layout
    assert layouts["direct"] == layouts["lean"]
    assert layouts["direct"].body_px > gl.renderer.hud.layout_for(size, hud, TextSizes()).body_px
    assert ssim(pictures["direct"], pictures["lean"]) > 0.98


def test_the_background_pass_is_the_clear(gl):
    """The direct path has no clear: its background pass writes every pixel's colour and a
    depth of 1.0 (the far plane), so nothing of the last frame survives, in colour or depth."""
    from exhibit.surfaces.mesh import Mesh4D

    target = gl.target((16, 8), 0)
    fb = target.framebuffer
    fb.use()
    fb.clear(0.2, 0.4, 0.6, 1.0, depth=0.25)
    gpu = gl.renderer.upload(Mesh4D(surfaces=[]))
    view = scenes.get("hopf").view
    gl.renderer.render(gpu, view, fb, RenderOptions(hud=False, background=((1.0, 0.0, 0.0),) * 2))
    gpu.release()
    assert np.all(target.read() == (255, 0, 0))
    depth = np.frombuffer(fb.read(components=1, attachment=-1, dtype="f4"), dtype=np.float32)
    assert np.all(depth == 1.0)


def test_ladder_pins_and_mesh_resolution():
    assert [q.name for q in ladder()] == [q.name for q in LADDER]
    pinned = ladder(antialiasing="fxaa", mesh=0, effects="full", scale=1.0)
    assert len(pinned) == 1 and pinned[0].settings == ("fxaa", 0, "full", 1.0)
    assert mesh_resolution(48, 0) == 48 and mesh_resolution(48, 1) == 36
    assert mesh_resolution(48, 2) == 24 and mesh_resolution(6, 2) == 4
    lean = RenderOptions().at_quality(LADDER[4])
    # lean gives up the intersection curves alone: thinner lines and a flat background saved
    # nothing measurable (docs/PERFORMANCE.md)
    assert lean == replace(RenderOptions(), intersections=False)
    assert not lean.intersections and RenderOptions().at_quality(LADDER[3]).intersections
    assert RenderOptions().at_quality(LADDER[3]) == RenderOptions()


def test_ssim():
    rng = np.random.default_rng(1)
    a = np.broadcast_to(np.linspace(0, 250, 50)[None, :, None], (40, 50, 3)).astype(np.uint8)
    assert ssim(a, a) == pytest.approx(1.0)
    noisy = np.clip(a + rng.normal(0, 30, a.shape), 0, 255).astype(np.uint8)
    assert 0 < ssim(a, noisy) < 0.9
    with pytest.raises(ValueError):
        ssim(a, a[:-1])


@pytest.mark.parametrize("wall", [True, False])
def test_frame_timer(gl, hopf, wall):
    gpu, view = hopf
    timer = FrameTimer(gl.ctx, wall=wall)
    got = []
    for _ in range(4):
        timer.begin()
        gl.draw_frame(gpu, view, SIZE, RenderOptions(), None, LADDER[1])
        got.append(timer.end())
    timer.release()
    assert timer.mode == ("wall" if wall else "gpu")
    assert all(ms is not None and ms > 0 for ms in got[2 if not wall else 0 :])


@pytest.mark.parametrize("level", ["fxaa", "direct"])
def test_crossfade_mixes_the_pictures_and_never_the_words(gl, hopf, level):
    """capture() then draw(fade=a): the pictures mix a·old + (1 − a)·new per pixel; the words
    never cross-dissolve: the old HUD fades out while a > 1/2, the new one fades in below it,
    and at a = 1/2 neither is there. Fade 1 is the old frame, fade 0 the new one, exactly
    (never a black frame in between). The direct level draws the captured picture straight
    into the snapshot, which needs its own depth."""
    gpu, view = hopf
    quality = next(q for q in LADDER if q.name == level)
    turned = view.replace(angles=(1.0, 0.5, 0, 0, 0, 0))
    old_hud, new_hud = HudInfo(title="Old"), HudInfo(title="New", caption="another one")
    bare = RenderOptions(hud=False)
    old = gl.frame(gpu, view, SIZE, RenderOptions(), old_hud, quality).astype(float)
    new = gl.frame(gpu, turned, SIZE, RenderOptions(), new_hud, quality).astype(float)
    old_picture = gl.frame(gpu, view, SIZE, bare, None, quality).astype(float)
    new_picture = gl.frame(gpu, turned, SIZE, bare, None, quality).astype(float)
    words = (np.abs(old - old_picture).max(axis=2) > 0) | (
        np.abs(new - new_picture).max(axis=2) > 0
    )
    pipeline = gl.pipeline
    options = RenderOptions(quality=quality)
    pipeline.capture(FrameRequest(gpu, view, options, old_hud), SIZE)
    target = gl.target(SIZE, 0)

    def drawn(alpha):
        pipeline.draw(
            FrameRequest(gpu, turned, options, new_hud, fade=alpha), target.framebuffer, SIZE
        )
        return target.read().astype(float)

    assert np.abs(drawn(0.0) - new).max() <= 1.5
    assert np.abs(drawn(1.0) - old).max() <= 1.5
    for alpha in (0.25, 0.5, 0.75):
        mixed = drawn(alpha)
        pictures = alpha * old_picture + (1 - alpha) * new_picture
        assert np.abs(mixed - pictures)[~words].max() <= 1.5, alpha
        if alpha == 0.5:  # no words at all: neither title is legible
            assert np.abs(mixed - pictures).max() <= 1.5
    assert words.any() and np.abs(old - new).max() > 100  # the two frames do differ
    assert mixed.mean() > 5  # not black
