"""Every mark explained: the key under the numbers lists each kind of mark the frame has, by
shape and colour, in the visitor's language, and Hud.explained names the id pass's objects it
explains; the first contact is a diamond, told from a Lemma 2 disc by shape in every vision."""

from __future__ import annotations

import numpy as np
import pytest
from colorspacious import cspace_convert

from exhibit import scenes
from exhibit.kiosk.language import HUD_WORDS, Translator, load_catalogues, shipped_catalogues
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.layout import (
    AXES_KEY,
    CONTACT_KEY,
    KEY_WORDS,
    NUMBERS_LIMIT,
    OUTLINE_KEY,
    PINCH_KEY,
    SLICE_KEY,
    hud_layout,
    key_swatch,
)
from exhibit.render.passes.ids import object_names
from exhibit.render.text import line_height

SIZE = (1280, 720)
LANGUAGES = ("en", "de", "fr")
VISIONS = (None, "protanomaly", "deuteranomaly", "tritanomaly")


@pytest.fixture(scope="module")
def translator():
    return Translator(load_catalogues(shipped_catalogues(), LANGUAGES[1:]), LANGUAGES)


def _draw(gl, name, preset, translator, language="en", **view_changes):
    """The scene's preset drawn with the kiosk's HUD words; (image, hud, object names)."""
    scene = scenes.get(name)
    p = scene.preset(preset)
    mesh = scene.build(scene.resolve(dict(p.params)), 24)
    gpu = gl.renderer.upload(mesh)
    try:
        view = p.view.replace(**view_changes)
        hud = HudInfo(title="t", caption="c", words=translator.hud_words(language))
        image = gl.image(gpu, view, SIZE, RenderOptions(), hud, samples=0)
        return image, gl.renderer.hud, object_names(gpu)
    finally:
        gpu.release()


def test_the_key_lists_the_kinds_of_mark_the_frame_has_in_the_language_shown(gl, translator):
    """The collision frame: Lemma 2 discs, the first contact, outlines, and the slice only
    while the view slices; the hypersphere: discs, outlines and its axis lines. Every entry's
    words in the language on screen, inside the numbers panel, no wider than its limit."""
    for language in LANGUAGES:
        _, hud, _ = _draw(gl, "collision", "figure-15", translator, language)
        plain = [e.english for e in hud.key]
        _, hud, _ = _draw(gl, "collision", "figure-15", translator, language, slice_axis=3)
        sliced = [e.english for e in hud.key]
        texts = [t for t in hud.texts if t.kind == "key"]
        status = hud.layout.status_block
        assert [t.text for t in texts] == [translator(e.english, language) for e in hud.key]
        for t in texts:
            assert status.x0 <= t.rect.x0 and t.rect.x1 <= status.x1, (language, t.text)
            assert status.y0 <= t.rect.y0 and t.rect.y1 <= status.y1, (language, t.text)
        assert status.width <= NUMBERS_LIMIT * SIZE[0]
        _, hud, _ = _draw(gl, "hopf", "figure-6", translator, language)
        hopf = [e.english for e in hud.key]
        assert plain == [PINCH_KEY, CONTACT_KEY, OUTLINE_KEY], language
        assert sliced == [PINCH_KEY, CONTACT_KEY, OUTLINE_KEY, SLICE_KEY], language
        assert hopf == [PINCH_KEY, OUTLINE_KEY, AXES_KEY], language
    assert {e.shape for e in hud.key} == {"disc", "ink", "axes"}


def test_a_frame_without_the_kiosks_words_has_no_key(gl, translator):
    """A figure rendered for the paper carries no HUD words: no key, nothing explained."""
    scene = scenes.get("collision")
    p = scene.preset("figure-15")
    gpu = gl.renderer.upload(scene.build(scene.resolve(dict(p.params)), 12))
    try:
        gl.image(gpu, p.view, SIZE, RenderOptions(), HudInfo(caption="c"), samples=0)
    finally:
        gpu.release()
    assert gl.renderer.hud.key == [] and gl.renderer.hud.explained == []
    assert [t for t in gl.renderer.hud.texts if t.kind == "key"] == []


def test_the_hud_records_the_objects_its_key_explains(gl, translator):
    """Hud.explained: the id pass's names of what each key entry drawn stands for, and only
    those; each entry's swatch and words are in what the HUD covers."""
    _, hud, names = _draw(gl, "collision", "figure-15", translator, "de", slice_axis=3)
    assert hud.explained == ["pinch points", "initial colliding point", "outline", "slice"]
    assert set(hud.explained) <= set(names)
    assert list(dict.fromkeys(n for e in hud.key for n in e.objects)) == hud.explained
    mask = hud.cover.mask(SIZE, SIZE)
    for x, y in _swatch_centres(hud):
        assert mask[int(y), int(x)]
    _, hud, names = _draw(gl, "hopf", "figure-6", translator, "en")
    assert hud.explained == ["pinch points", "outline", "x axis", "y axis", "z axis", "w axis"]
    assert set(hud.explained) <= set(names)
    _, hud, names = _draw(gl, "collision", "figure-15", translator, "en")
    assert "slice" not in hud.explained  # no slice in the view: no slice in the key


def test_a_smaller_key_never_makes_the_numbers_panel_larger():
    """The framing keeps the picture clear of the panel with every key entry the words carry;
    the key a frame shows (fewer entries) lies inside it, in every language shipped, and the
    whole key takes at most two lines."""
    translator = Translator(load_catalogues(shipped_catalogues(), LANGUAGES[1:]), LANGUAGES)
    for language in LANGUAGES:
        words = translator.hud_words(language)
        full = hud_layout(SIZE, words=words).status_block
        line = line_height("sans", hud_layout(SIZE).body_px)
        bare = hud_layout(SIZE, words=words, key=()).status_block
        assert full.height - bare.height <= 2 * line, language
        assert full.width <= NUMBERS_LIMIT * SIZE[0], language
        every = [translator(w, language) for w in KEY_WORDS]
        for n in range(1 << len(every)):
            key = tuple(w for i, w in enumerate(every) if n >> i & 1)
            box = hud_layout(SIZE, words=words, key=key).status_block
            assert full.x0 <= box.x0 and box.x1 <= full.x1 and full.y0 <= box.y0, (language, key)
    assert all(word in HUD_WORDS for word in KEY_WORDS)


def _swatch_centres(hud):
    layout, status = hud.layout, hud.layout.status_block
    body = layout.body_px
    return [
        (status.x0 + x + 0.45 * key_swatch(body), status.y0 + y + 0.55 * line_height("sans", body))
        for _, x, y in layout.key
    ]


def _shape(image: np.ndarray, centre: tuple[float, float], reach: int) -> np.ndarray:
    """The mark at ``centre``: the pixels brighter than halfway between its dark rim and its
    brightest pixel, connected to its middle, as (dx, dy) from the centre."""
    cx, cy = int(round(centre[0])), int(round(centre[1]))
    crop = image[cy - reach : cy + reach + 1, cx - reach : cx + reach + 1, :3] / 255.0
    lum = crop @ np.array([0.2126, 0.7152, 0.0722])
    bright = lum > 0.5 * (lum[reach - 2 : reach + 3, reach - 2 : reach + 3].max() + lum.min())
    seen = np.zeros_like(bright)
    todo = [(reach, reach)]
    while todo:
        y, x = todo.pop()
        inside = 0 <= y < bright.shape[0] and 0 <= x < bright.shape[1]
        if inside and bright[y, x] and not seen[y, x]:
            seen[y, x] = True
            todo += [(y + 1, x), (y - 1, x), (y, x + 1), (y, x - 1)]
    ys, xs = np.nonzero(seen)
    return np.stack([xs - reach, ys - reach], axis=-1).astype(float)


def _corners(points: np.ndarray) -> float:
    """How far the mark reaches along the axes over how far along the diagonals: about 1 for a
    disc, about 1.4 for a diamond (a square on its corner)."""
    x, y = points[:, 0], points[:, 1]
    along = (
        np.abs(np.where(np.abs(y) <= 0.5, x, 0)).max()
        + np.abs(np.where(np.abs(x) <= 0.5, y, 0)).max()
    )
    diagonal = (
        np.abs(np.where(np.abs(x - y) <= 0.5, x, 0)).max()
        + np.abs(np.where(np.abs(x + y) <= 0.5, x, 0)).max()
    )
    return float(along / (np.sqrt(2.0) * diagonal))


def test_the_first_contact_is_a_diamond_a_pinch_point_a_disc_in_every_vision(gl, translator):
    """The first contact's marker and the key's Lemma 2 disc seen with normal vision,
    protanopia, deuteranopia and tritanopia (Machado et al. 2009 at full severity): the marker
    reaches farther along the axes than along its diagonals (corners), the disc does not."""
    image, hud, _ = _draw(gl, "collision", "figure-15", translator)
    ((_, _, point, covered),) = hud.labels
    assert not covered
    disc = _swatch_centres(hud)[[e.english for e in hud.key].index(PINCH_KEY)]
    contact = _swatch_centres(hud)[[e.english for e in hud.key].index(CONTACT_KEY)]
    for vision in VISIONS:
        seen = image[..., :3].astype(float)
        if vision is not None:
            cvd = {"name": "sRGB1+CVD", "cvd_type": vision, "severity": 100}
            seen = np.clip(cspace_convert(seen / 255.0, cvd, "sRGB1"), 0, 1) * 255.0
        marker = _shape(seen, point, 14)
        assert len(marker) >= 40, vision  # the mark stands out from its rim
        assert _corners(marker) > 1.2, vision
        assert _corners(_shape(seen, contact, 16)) > 1.2, vision
        assert _corners(_shape(seen, disc, 14)) < 1.12, vision
