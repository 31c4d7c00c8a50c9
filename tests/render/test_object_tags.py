"""Words, not colour alone: a caption's named objects are tagged on screen, the tag's leader
ends on the object where it is in front, and the pinch points' key stands under the numbers."""

from __future__ import annotations

import numpy as np

from exhibit import scenes
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.layout import PINCH_KEY
from exhibit.render.passes.ids import object_names

SIZE = (960, 540)
GREEN, RED, WHITE = "torus Z=-√2/2", "torus Z=√2/2", "torus Z=0"
TAGS = ((GREEN, "green doughnut"), (WHITE, "white doughnut"), (RED, "red doughnut"))


def _hopf(gl, resolution=24):
    scene = scenes.get("hopf")
    preset = scene.preset("figure-6")
    mesh = scene.build(scene.resolve(dict(preset.params)), resolution)
    return gl.renderer.upload(mesh), preset.view


def test_each_tag_points_at_its_own_object_and_keeps_off_the_panels(gl):
    """Each leader ends on a pixel of the object it names (read back through the object-id
    pass, never by colour), and no tag lies on a panel or on another tag."""
    gpu, view = _hopf(gl)
    try:
        hud = HudInfo(title="Hopf tori", caption="Three doughnuts.", tags=TAGS)
        gl.image(gpu, view, SIZE, RenderOptions(), hud, samples=0)
        drawn = list(gl.renderer.hud.tags)
        layout = gl.renderer.hud.layout
        id_image = gl.renderer.ids.image(gpu, view, SIZE)
        names = object_names(gpu)
    finally:
        gpu.release()
    assert [words for words, *_ in drawn] == [w for _, w in TAGS]
    for (words, rect, (x, y), covered), (name, _) in zip(drawn, TAGS):
        assert not covered, words
        x0, y0 = int(round(x)), int(round(y))
        near = id_image[max(0, y0 - 2) : y0 + 3, max(0, x0 - 2) : x0 + 3]
        seen = {names[i - 1] for i in np.unique(near) if i}
        assert name in seen, (words, seen)
        assert not any(rect.overlaps(p) for p in layout.panels), words
    rects = [rect for _, rect, *_ in drawn]
    assert not any(a.overlaps(b) for i, a in enumerate(rects) for b in rects[i + 1 :])


def test_a_tag_for_an_object_off_the_screen_is_left_out(gl):
    gpu, view = _hopf(gl, 12)
    try:
        far = view.replace(center=(1000.0, 0.0))  # the lens shifted far from the picture
        hud = HudInfo(caption="Three doughnuts.", tags=((GREEN, "green doughnut"),))
        gl.image(gpu, far, SIZE, RenderOptions(), hud, samples=0)
        assert gl.renderer.hud.tags == []
        hud = HudInfo(caption="Nothing.", tags=(("no such object", "moon"),))
        gl.image(gpu, view, SIZE, RenderOptions(), hud, samples=0)
        assert gl.renderer.hud.tags == []
    finally:
        gpu.release()


def test_the_pinch_points_key_stands_under_the_numbers_in_the_language_shown(gl):
    """The kiosk's HUD words carry the key: a yellow disc and its words, inside the numbers
    panel; without them (a figure rendered for the paper) there is no key."""
    gpu, view = _hopf(gl, 12)
    try:
        german = "Zwickelpunkt"
        hud = HudInfo(caption="Drei Donuts.", words=((PINCH_KEY, german),))
        gl.image(gpu, view, SIZE, RenderOptions(), hud, samples=0)
        keys = [t for t in gl.renderer.hud.texts if t.kind == "key"]
        status = gl.renderer.hud.layout.status_block
        gl.image(gpu, view, SIZE, RenderOptions(), HudInfo(caption="Drei Donuts."), samples=0)
        none = [t for t in gl.renderer.hud.texts if t.kind == "key"]
    finally:
        gpu.release()
    assert [k.text for k in keys] == [german]
    box = keys[0].rect
    assert status.x0 <= box.x0 and box.x1 <= status.x1 and status.y0 <= box.y0
    assert box.y1 <= status.y1
    assert none == []


def test_the_hud_cover_is_what_the_hud_drew_over_the_picture(gl):
    """The cover mask (exhibit.render.hud_cover) marks the pixels the HUD changed: drawn with
    and without the HUD, the frames differ only where the mask says (and nearly everywhere it
    says), at the screen's size and at the id pass's smaller one."""
    gpu, view = _hopf(gl)
    try:
        bare = gl.image(gpu, view, SIZE, RenderOptions(), None, samples=0).astype(int)
        hud = HudInfo(title="Hopf tori", caption="Three doughnuts.", tags=TAGS)
        drawn = gl.image(gpu, view, SIZE, RenderOptions(), hud, samples=0).astype(int)
        cover = gl.renderer.hud.cover
        assert gl.renderer.hud.tag_objects == [name for name, _ in TAGS]
    finally:
        gpu.release()
    changed = np.abs(drawn[..., :3] - bare[..., :3]).max(axis=2) > 8
    mask = cover.mask(SIZE, SIZE)
    assert changed.sum() > 0.1 * changed.size  # the panels alone are that much
    assert (changed & ~mask).sum() <= 0.002 * changed.size
    assert (mask & ~changed).sum() <= 0.2 * mask.sum()  # dark halos on dark ground
    small = cover.mask(SIZE, (SIZE[0] // 3, SIZE[1] // 3))
    assert abs(small.mean() - mask.mean()) < 0.01


def test_no_tag_points_into_the_sheet_that_passes_the_sensor(headless):
    """01-hypersphere in reduced motion, held at distance 2 as the viewpoint moves back out:
    the green doughnut passes by the sensor, drawn huge from triangles with a vertex behind the
    eye, and hides the white one. The white doughnut's tag pointed into the green (the
    occlusion test skipped those triangles); now every tag's leader ends on its own object in
    the id pass, or the tag is left out."""
    import dataclasses

    from exhibit.resources import shipped
    from exhibit.review.player import KioskPlayer
    from exhibit.review.setup import base_config

    size = (1280, 720)
    path = shipped("configs", "attract", "01-hypersphere.toml")
    config = dataclasses.replace(base_config(), reduced_motion=True)
    with KioskPlayer(size, timeline=path, config=config, headless=headless) as player:
        player.run_to(38.6, 5)
        gpu, view = player.kiosk.shown
        hud = headless.renderer.hud
        tags = list(zip(hud.tags, hud.tag_objects))
        image = headless.renderer.ids.image(gpu, view, size)
        names = object_names(gpu)
    assert tags and WHITE not in [name for _, name in tags]
    for (words, _, (x, y), _), name in tags:
        near = image[int(y) - 3 : int(y) + 4, int(x) - 3 : int(x) + 4]
        assert name in {names[k - 1] for k in np.unique(near) if k}, words
