"""Every word on the HUD in the language on screen: the numbers panel's labels and the words of
marker labels (formulas stay as they are), with the numbers panel wide enough for them."""

import math

import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.label_places import marker_text
from exhibit.render.layout import TextSizes, hud_layout, status_lines
from exhibit.render.text import text_width
from exhibit.surfaces.mesh import Marker, Mesh4D

GERMAN = (
    ("4D axes", "4D-Achsen"),
    ("sensor", "Sensor"),
    ("eye", "Auge"),
    ("fov", "Sichtfeld"),
    ("first contact", "erste Berührung"),
)


def test_the_numbers_panel_speaks_the_language_on_screen():
    view = ViewState(eye_r=1 / 5)
    english, german = status_lines(view)[2], status_lines(view, words=GERMAN)[2]
    assert english.split()[::2] == ["sensor", "eye", "fov"]
    assert german.split()[::2] == ["Sensor", "Auge", "Sichtfeld"]


def test_the_numbers_panel_is_wide_enough_for_its_words_and_keeps_its_width():
    rng = np.random.default_rng(3)
    for words, beyond in (
        ((), 1000.0),
        (GERMAN, 1000.0),
        ((), 1e6),
        ((("fov", "Öffnungswinkel des Auges"),), 50.0),
    ):
        layout = hud_layout((1920, 1080), sizes=TextSizes(infinity_beyond=beyond), words=words)
        px, pad = layout.body_px, layout.pad
        for _ in range(50):
            view = ViewState(
                angles=tuple(rng.uniform(-math.pi, math.pi, 6)),
                sensor_r=1 / float(rng.choice([np.inf, beyond, 0.99 * beyond, 3])),
                eye_r=1 / float(rng.choice([np.inf, beyond, 0.99 * beyond, 2])),
            )
            for line in status_lines(view, beyond, words):
                assert text_width(line, "mono", px) + 2 * pad <= layout.status_block.width
    assert (
        hud_layout((1920, 1080), words=GERMAN).status_block.width
        > hud_layout((1920, 1080)).status_block.width
    )


def test_marker_labels_translate_their_words_not_their_formula():
    word = dict(GERMAN).get
    assert (
        marker_text("first contact, t = -0.250", lambda w: word(w, w))
        == "erste Berührung, t = -0.250"
    )
    assert marker_text("first contact", lambda w: word(w, w)) == "erste Berührung"
    assert marker_text("a point, x = 1", lambda w: word(w, w)) == "a point, x = 1"


def test_the_hud_draws_a_marker_label_in_the_language_on_screen(gl):
    mesh = Mesh4D(markers=[Marker("m", np.zeros(4), label="first contact, t = 0.500")])
    gpu = gl.renderer.upload(mesh)
    view = ViewState(eye_r=0.0)
    try:
        gl.image(gpu, view, (480, 270), RenderOptions(), HudInfo(words=GERMAN), samples=0)
        german = [text for text, *_ in gl.renderer.hud.labels]
        gl.image(gpu, view, (480, 270), RenderOptions(), HudInfo(), samples=0)
        english = [text for text, *_ in gl.renderer.hud.labels]
    finally:
        gpu.release()
    assert german == ["erste Berührung, t = 0.500"]
    assert english == ["first contact, t = 0.500"]
