"""The HUD's fixed costs: the title and caption panel is wrapped and drawn once until its words
change, and changing numbers reuse the glyph atlas (no new texture, no new glyph)."""

import numpy as np

from exhibit import scenes
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.text import block_image, rasterise
from exhibit.surfaces.mesh import Mesh4D

SIZE = (320, 240)
BLACK = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


def test_numbers_cost_no_new_texture(gl):
    gpu = gl.renderer.upload(Mesh4D())
    view = scenes.get("hopf").view
    hud = HudInfo(title="Hopf", caption="three tori")
    every_digit = view.replace(angles=tuple(np.radians([123.4, 56.7, 89.1, -1.0, 0.0, 0.0])))
    gl.image(gpu, every_digit, SIZE, RenderOptions(background=BLACK), hud, samples=0)
    panels = gl.renderer.hud.rasterised
    glyphs = len(gl.renderer.atlas._glyphs)
    textures = len(gl.renderer.text._items)
    pictures = []
    for degrees in (10.0, 20.0, 30.0):  # digits already in the atlas
        turned = view.replace(angles=(np.radians(degrees),) + view.angles[1:])
        pictures.append(
            gl.image(gpu, turned, SIZE, RenderOptions(background=BLACK), hud, samples=0)
        )
    gpu.release()
    assert gl.renderer.hud.rasterised == panels, "the title panel was redrawn"
    assert len(gl.renderer.atlas._glyphs) == glyphs
    assert len(gl.renderer.text._items) == textures
    assert not np.array_equal(pictures[0], pictures[1])  # the numbers did change


def test_title_panel_changes_with_its_words(gl):
    gpu = gl.renderer.upload(Mesh4D())
    view = scenes.get("hopf").view
    a = gl.image(gpu, view, SIZE, RenderOptions(background=BLACK), HudInfo(title="One"), samples=0)
    b = gl.image(gpu, view, SIZE, RenderOptions(background=BLACK), HudInfo(title="Two"), samples=0)
    gpu.release()
    assert not np.array_equal(a, b)


def test_warmed_panels_are_not_rasterised_again(gl):
    """The kiosk warms every scene's and caption's panel at start-up: a scene change or a new
    caption then costs no wrapping or rasterising."""
    gpu = gl.renderer.upload(Mesh4D())
    view = scenes.get("hopf").view
    huds = [HudInfo(title="One", caption="first words"), HudInfo(title="Two", caption="more")]
    gl.renderer.hud.warm(SIZE, huds, RenderOptions().text)
    before = gl.renderer.hud.rasterised
    for hud in huds + huds:
        gl.image(gpu, view, SIZE, RenderOptions(background=BLACK), hud, samples=0)
    gpu.release()
    assert gl.renderer.hud.rasterised == before


def test_block_image_is_panel_then_text_over_it():
    panel = (0.0, 0.0, 0.0, 0.45)
    image = block_image([("Hi", "bold", 20, (1.0, 1.0, 1.0, 1.0))], 3, panel).astype(int)
    coverage = rasterise("Hi", "bold", 20).astype(float) / 255
    h, w = coverage.shape
    alpha = image[3 : 3 + h, 3 : 3 + w, 3] / 255
    assert np.allclose(alpha, coverage + 0.45 * (1 - coverage), atol=1 / 255 + 1e-9)
    assert image[0, 0, 3] == round(0.45 * 255) and image[0, 0, :3].max() == 0


def test_atlas_text_matches_pillow_for_monospaced_digits(gl):
    """A digit from the atlas has exactly Pillow's coverage for that digit."""
    atlas = gl.renderer.atlas
    ((x, glyph),) = atlas.layout("7", "mono", 17)
    data = np.frombuffer(atlas.texture.read(alignment=1), dtype=np.uint8).reshape(
        atlas.size, atlas.size
    )
    cell = data[glyph.v : glyph.v + glyph.height, glyph.u : glyph.u + glyph.width]
    expected = rasterise("7", "mono", 17)
    trim = lambda a: a[a.any(axis=1)][:, a.any(axis=0)]  # noqa: E731
    assert np.array_equal(trim(cell), trim(expected))
