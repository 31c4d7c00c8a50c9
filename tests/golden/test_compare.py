"""The golden-image comparison and the image checks can fail: planted faults on a stored golden
image (no GL needed, so this runs in the default, fast suite)."""

from __future__ import annotations

import numpy as np
import pytest

from exhibit import scenes
from exhibit.render.layout import Rect, TextSizes, hud_layout
from exhibit.render.text import line_height
from tests.golden.images import (
    GOLDEN_DIR,
    caption_cap_height,
    compare,
    label_problems,
    load,
    min_cap_height,
    surface_pixels_in_the_margin,
    surface_pixels_under_panels,
)

NAME = "figure-15"


@pytest.fixture
def golden():
    return load(GOLDEN_DIR / f"{NAME}.png")


def mesa_noise(image, seed=1):
    """What another Mesa may do: edge pixels off by up to 6 levels, every pixel by 1."""
    rng = np.random.default_rng(seed)
    g = image.astype(int)
    step = np.abs(np.diff(g.sum(-1), axis=1)) > 30
    edges = np.zeros(image.shape[:2], bool)
    edges[:, 1:] |= step
    edges[:, :-1] |= step
    noise = rng.integers(-6, 7, image.shape) * edges[..., None] + rng.integers(-1, 2, image.shape)
    return np.clip(g + noise, 0, 255).astype(np.uint8)


def test_noise_passes_and_small_changes_fail(golden, tmp_path):
    compare(NAME, golden, False, tmp_path)
    compare(NAME, mesa_noise(golden), False, tmp_path)
    moved = np.roll(golden, 1, axis=1)
    with pytest.raises(AssertionError, match=r"figure-15: SSIM 0\.\d+ < 0\.985"):
        compare(NAME, moved, False, tmp_path / "out")
    assert (tmp_path / "out" / f"{NAME}.png").exists()
    assert (tmp_path / "out" / f"{NAME}-diff.png").exists()
    # a short curve of 12 pixels drawn in a corner: the whole frame hardly changes, the tile does
    curve = golden.copy()
    curve[150, 300:312] = (220, 40, 40)
    with pytest.raises(AssertionError, match=r"in the 24x24 tile at \(29\d, 1[45]\d\)"):
        compare(NAME, curve, False, tmp_path / "out")
    with pytest.raises(AssertionError, match="size 240x270"):
        compare(NAME, golden[:, :240], False, tmp_path / "out")
    with pytest.raises(AssertionError, match="no golden image"):
        compare("figure-99", golden, False, tmp_path / "out")


def test_updating_writes_the_golden_image(golden, tmp_path, monkeypatch):
    import tests.golden.images as images

    monkeypatch.setattr(images, "GOLDEN_DIR", tmp_path)
    images.compare("new", golden, True, tmp_path / "out")
    assert (load(tmp_path / "new.png") == golden).all()


def figure_layout(number=15, size=(480, 270)):
    scene, preset = scenes.figure(number)
    return hud_layout(
        size, scene.title, (scene.caption, f"Figure {number}. {preset.caption}"), TextSizes()
    )


def test_caption_capitals_are_measured_on_the_pixels(golden):
    layout = figure_layout()
    cap = caption_cap_height(golden, layout, (0.0, 0.0))
    assert min_cap_height(270) <= cap <= 12
    # the top of the caption's first line painted over with the panel: shorter capitals
    cut = golden.copy()
    top = round(layout.title_block.y0) + layout.pad + line_height("bold", layout.title_px)
    cut[top : top + 5, 8:200] = golden[top - 1, 8]
    assert caption_cap_height(cut, layout, (0.0, 0.0)) < min_cap_height(270)


def test_surface_under_a_panel_and_labels_off_screen_are_found():
    surfaces = np.zeros((270, 480, 3), np.uint8)
    surfaces[100:120, 300:320] = 200
    panels = [Rect(6, 6, 200, 60), Rect(290, 110, 330, 115)]
    assert surface_pixels_under_panels(surfaces, panels) == [
        "100 surface pixels under the panel (290, 110, 330, 115)"
    ]
    assert surface_pixels_in_the_margin(surfaces, 6) == []
    surfaces[262:268, 300:310] = 200
    assert surface_pixels_in_the_margin(surfaces, 6) == [
        "the surfaces span (300, 100, 319, 267), into the 6 px margin of the 480x270 screen"
    ]
    assert surface_pixels_in_the_margin(surfaces * 0, 6) == ["no surface drawn"]
    image = np.zeros((270, 480, 3), np.uint8)
    image[250:262, 400:470] = (255, 255, 0)
    inside = ("first contact", Rect(400, 250, 470, 262), (395, 255), False)
    assert label_problems(image, [inside], (1, 1, 0)) == []
    outside = ("first contact", Rect(440, 250, 510, 262), (435, 255), False)
    assert "is not inside the 480x270 screen" in label_problems(image, [outside], (1, 1, 0))[0]
    blank = ("first contact", Rect(10, 100, 80, 112), (5, 105), False)
    assert "in its colour" in label_problems(image, [blank], (1, 1, 0))[0]
