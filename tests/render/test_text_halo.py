"""Text halos drawn as one baked image per glyph (GlyphAtlas.halo) leave the picture that
sixteen copies of the glyph, moved and blended over each other, leave (the way halos were drawn
before, kept here as the oracle), to within 8-bit rounding (sixteen blends round sixteen
times: at most 4 levels)."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from exhibit.render.hud import HALO, halo_rows
from exhibit.render.glyph_atlas import HALO_DIRECTIONS, halo_steps

SIZE = (360, 90)


def picture(gl, rows: list) -> np.ndarray:
    target = gl.target(SIZE, 0)
    target.framebuffer.use()
    ctx, renderer = gl.ctx, gl.renderer
    ctx.viewport = (0, 0, *SIZE)
    target.framebuffer.clear(0.9, 0.85, 0.6, 1.0)  # a bright surface behind the words
    ctx.disable(moderngl.DEPTH_TEST)
    ctx.enable(moderngl.BLEND)
    renderer.drawing.atlas_quads(rows, tuple(map(float, SIZE)))
    ctx.disable(moderngl.BLEND)
    return target.read().astype(int)


@pytest.mark.parametrize(
    ("text", "style", "px"), [("first contact, t = 0.42", "bold", 22), ("w", "sans", 40)]
)
def test_baked_halo_matches_sixteen_copies(gl, text, style, px):
    drawing = gl.renderer.drawing
    reach = max(2, round(px / 10))
    copies: list = []
    for step in halo_steps(reach):
        for ox, oy in HALO_DIRECTIONS:
            drawing.glyph_rows(text, style, px, 12 + ox * step, 20 + oy * step, HALO, copies)
    baked: list = []
    halo_rows(drawing, text, style, px, 12, 20, baked)
    assert len(baked) == sum(not c.isspace() for c in text)  # one quad per glyph
    old, new = picture(gl, copies), picture(gl, baked)
    # Sixteen 8-bit blends round sixteen times, the baked halo once.
    assert np.abs(old - new).max() <= 4
    assert np.abs(old - new).mean() < 0.05
    assert (old != picture(gl, [])).any()  # the halo is there at all


def test_halo_survives_the_atlas_emptying(gl):
    """A halo asked for as the atlas fills comes back whole from the emptied atlas."""
    atlas = gl.renderer.atlas
    resets = atlas.resets
    n = 0
    while atlas.resets == resets:
        atlas.glyph(chr(0x4E00 + n), "sans", 60)
        n += 1
    out = atlas.halo_layout("halo", "sans", 30, 3, HALO[3])
    assert [g.width for _, g in out] == [
        atlas.halo(c, "sans", 30, 3, HALO[3]).width for c in "halo"
    ]
    assert all(g.height == out[0][1].height for _, g in out)


def test_a_line_too_large_for_the_atlas_grows_it(gl):
    """Text hundreds of pixels tall (an 8192 x 8192 render): a line whose glyphs and halos do
    not fit in an empty atlas doubles it instead of emptying it forever."""
    from exhibit.render.glyph_atlas import GlyphAtlas

    atlas = GlyphAtlas(gl.ctx, size=160)
    try:
        laid = atlas.halo_layout("halo", "sans", 70, 7, HALO[3])
        assert laid is not None and atlas.size > 160
        glyphs = atlas.layout("halo", "sans", 70)
        for _, g in [*laid, *glyphs]:
            assert g.width > 0 and g.u + g.width <= atlas.size and g.v + g.height <= atlas.size
        assert atlas.halo_layout("halo", "sans", 70, 7, HALO[3]) == laid  # all still there
        assert gl.ctx.error == "GL_NO_ERROR"
    finally:
        atlas.release()


def test_halos_that_cannot_fit_are_sixteen_moved_glyphs(gl, monkeypatch):
    """At the GL's largest atlas, a line whose halos do not fit beside its glyphs gets the
    halo as sixteen moved copies of its glyphs."""
    from exhibit.render.glyph_atlas import GlyphAtlas

    small = GlyphAtlas(gl.ctx, size=160)
    try:
        monkeypatch.setattr(small, "_grow", lambda: False)
        assert small.halo_layout("halo", "sans", 60, 6, HALO[3]) is None
        drawing = gl.renderer.drawing
        monkeypatch.setattr(drawing, "atlas", small)
        rows: list = []
        halo_rows(drawing, "halo", "sans", 60, 0, 0, rows)
        assert len(rows) == 16 * 4  # each glyph moved in 8 directions by 2 distances
        assert all(tuple(row[8:]) == HALO for row in rows)
    finally:
        small.release()
