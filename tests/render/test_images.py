"""Whole pictures: no GL errors, deterministic, responsive to the angles, every figure non-blank,
crisp HUD text."""

import math

import numpy as np
import pytest
from PIL import Image

from exhibit import scenes
from exhibit.cli import main
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.layout import hud_layout
from exhibit.render.text import rasterise
from exhibit.surfaces.mesh import Mesh4D

SIZE = (200, 150)


@pytest.fixture(scope="module")
def hopf(headless):
    scene, preset = scenes.figure(7)
    gpu = headless.renderer.upload(scene.build(preset.params, 16))
    yield scene, preset, gpu
    gpu.release()


def test_identical_inputs_give_identical_images(gl, hopf):
    scene, preset, gpu = hopf
    hud = HudInfo(scene.title, scene.caption)
    first = gl.image(gpu, preset.view, SIZE, hud=hud)
    second = gl.image(gpu, preset.view, SIZE, hud=hud)
    assert np.array_equal(first, second)


@pytest.mark.parametrize("angle", range(6))
def test_every_angle_changes_the_image(gl, hopf, angle):
    scene, preset, gpu = hopf
    options = RenderOptions(hud=False)
    base = gl.image(gpu, preset.view, SIZE, options)
    angles = list(preset.view.angles)
    angles[angle] += math.radians(25)
    turned = gl.image(gpu, preset.view.replace(angles=tuple(angles)), SIZE, options)
    changed = np.any(np.abs(base.astype(int) - turned.astype(int)) > 24, axis=-1).mean()
    assert changed > 0.02


def test_depth_colour_differs_from_material_colour(gl, hopf):
    scene, preset, gpu = hopf
    plain = gl.image(gpu, preset.view, SIZE, RenderOptions(hud=False))
    depth = gl.image(gpu, preset.view, SIZE, RenderOptions(hud=False, depth_colour=True))
    assert np.abs(plain.astype(int) - depth.astype(int)).max() > 60


@pytest.mark.parametrize("number", sorted(scenes.FIGURES))
def test_every_figure_renders_non_blank(gl, tmp_path, number):
    out = tmp_path / f"figure-{number}.png"
    assert (
        main(
            [
                "render",
                "--figure",
                str(number),
                "--size",
                "160x120",
                "--resolution",
                "12",
                "--no-hud",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    with Image.open(out) as picture:
        image = np.asarray(picture.convert("RGB")).astype(int)
    background = np.array([[0.16, 0.18, 0.23]]) * 255  # the gradient's top colour, roughly
    far_from_background = np.abs(image - background).max(axis=-1) > 60
    assert far_from_background.mean() > 0.03, f"figure {number} is blank"
    assert len(np.unique(image.reshape(-1, 3) // 32, axis=0)) >= 4, "one flat colour only"


def test_hud_text_is_placed_texel_for_pixel(gl):
    """Crisp text: the HUD's title pixels are exactly Pillow's glyph coverage, not resampled."""
    size = (320, 240)
    black = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    gpu = gl.renderer.upload(Mesh4D())
    with_title = gl.image(
        gpu,
        scenes.get("hopf").view,
        size,
        RenderOptions(background=black),
        HudInfo(title="Hopf"),
        samples=0,
    )
    without = gl.image(
        gpu,
        scenes.get("hopf").view,
        size,
        RenderOptions(background=black),
        HudInfo(title=""),
        samples=0,
    )
    gpu.release()
    diff = np.abs(with_title.astype(int) - without.astype(int)).max(axis=-1)
    ys, xs = np.nonzero(diff)
    glyphs = rasterise("Hopf", "bold", hud_layout(size, "Hopf").title_px)
    gy, gx = np.nonzero(glyphs)  # the ink's bounding box (letters may have gaps between)
    coverage = glyphs[gy.min() : gy.max() + 1, gx.min() : gx.max() + 1]
    drawn = diff[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]
    assert drawn.shape == coverage.shape
    # The title colour is near white on a 45% black panel: coverage maps monotonically.
    assert np.corrcoef(drawn.ravel(), coverage.ravel())[0, 1] > 0.99
