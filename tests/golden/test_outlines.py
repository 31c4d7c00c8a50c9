"""Outlines drawn solid (issue 32, item 3): the offset curve of Figures 9 and 11 runs along the
tube's outline, and the renderer cut it into dashes there (the live silhouette ink drawn over it
by turns; the kiosk frames' centre test hiding its segment ends by turns).

Measured against a reference computed without the renderer (tests/golden/outline_pieces.py:
the paper's equations, Newton on the points that share a curve point's screen position): each
run of the curve that is visible must be one piece on screen, in the picture at every quality
level that draws curves (by its colour, which nothing else in these figures has) and in the
object-id pass (by its id).
"""

from __future__ import annotations

import numpy as np
import pytest

from exhibit import scenes
from exhibit.geometry.pipeline import clip_transform
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.framer import Framer
from exhibit.render.passes.ids import object_names
from exhibit.render.quality import LADDER, mesh_resolution
from tests.golden.outline_pieces import (
    expected_runs,
    near,
    pieces,
    pipe_equations,
    samples,
    visible,
    whole,
)

pytestmark = pytest.mark.slow

SIZE = (1280, 720)
FIGURES = {9: "parabola", 11: "cusp"}
#: The picture's levels that draw curves, by name: (quality level or None for the still
#: `exhibit render` writes, mesh level).
LEVELS = {"still": (None, 0), "fxaa": (LADDER[1], 0), "mesh-50": (LADDER[3], 2)}
LEVELS["direct"] = (LADDER[5], 0)


@pytest.fixture(autouse=True)
def _own_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "meshes"))


_built: dict[tuple[int, int], tuple] = {}


def figure(number: int, mesh_level: int):
    """(mesh, view, hud, [(curve name, pixels, expected runs)]) for a figure as `exhibit render
    --figure N` frames it, its mesh at a kiosk mesh level; the reference computed once."""
    key = (number, mesh_level)
    if key not in _built:
        scene, preset = scenes.figure(number)
        params = dict(preset.params)
        resolution = mesh_resolution(scene.default_resolution, mesh_level)
        mesh = scene.build(params, resolution)
        note = f"Figure {number}. {preset.caption}".strip()
        view = Framer(SIZE, RenderOptions().text, hud=True).view(
            mesh, preset.view, scene.title, [(scene.caption, note)]
        )
        ct = clip_transform(view, SIZE[0] / SIZE[1])
        pixel = 2.0 * view.half_height / SIZE[1]
        f, grad = pipe_equations(FIGURES[number], float(scene.resolve(params)["r"]))
        surface = next(s for s in mesh.surfaces if s.material.style != "wire")
        curves = []
        for curve in mesh.curves:
            if not curve.name.startswith("offset curve"):
                continue
            points = samples(curve.points, curve.closed, pixel / 2.0)
            pixels, ok = ct.to_pixels(points, *SIZE)
            flags = ok & visible(points, f, grad, surface, ct, same=pixel)
            curves.append((curve.name, pixels, expected_runs(flags, pixels)))
        hud = HudInfo(scene.title, scene.caption, tuple(scene.axes), note)
        _built[key] = (mesh, view, hud, curves)
    return _built[key]


def report(counts) -> str:
    return "; ".join(f"{name}: {c}" for name, c in counts.items())


@pytest.mark.parametrize("number", sorted(FIGURES))
@pytest.mark.parametrize("level", list(LEVELS))
def test_the_offset_curve_is_one_piece_where_it_is_visible(headless, number, level):
    quality, mesh_level = LEVELS[level]
    mesh, view, hud, curves = figure(number, mesh_level)
    assert sum(len(runs) for _, _, runs in curves) >= 2, "the reference found nothing to test"
    headless.activate()  # other golden tests make contexts of their own current
    gpu = headless.renderer.upload(mesh)
    try:
        options = RenderOptions()
        image = (
            headless.still(gpu, view, SIZE, options, hud)
            if quality is None
            else headless.frame(gpu, view, SIZE, options.at_quality(quality), hud, quality)
        )
    finally:
        gpu.release()
    colour = np.array(next(c.material.color for c in mesh.curves if c.name == curves[0][0]))
    counts = {}
    for name, pixels, runs in curves:
        shown = near(
            image.astype(float) / 255.0,
            pixels,
            lambda rgb: np.abs(rgb - colour).max(axis=-1) < 0.15,
        )
        counts[name] = pieces(shown, runs)
    assert whole(counts), (
        f"Figure {number} at {level}: (pieces, share shown) per visible run: {report(counts)}"
    )


@pytest.mark.parametrize("number", sorted(FIGURES))
def test_the_offset_curve_is_one_piece_in_the_object_ids(headless, number):
    mesh, view, _, curves = figure(number, 0)
    headless.activate()
    gpu = headless.renderer.upload(mesh)
    try:
        ids = headless.renderer.ids.image(gpu, view, SIZE, RenderOptions())
        names = object_names(gpu)
    finally:
        gpu.release()
    counts = {}
    for name, pixels, runs in curves:
        index = names.index(name) + 1
        shown = near(ids, pixels, lambda value, i=index: value == i)
        counts[name] = pieces(shown, runs)
    assert whole(counts), (
        f"Figure {number}, object ids: (pieces, share shown) per visible run: {report(counts)}"
    )
