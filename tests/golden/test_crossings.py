"""Crossings inked solid (issue 32, item 3): where two sheets of the 3D image cross, the ink is
one piece along every run of the crossing that is visible and steep enough for the ink to be at
least LEAST of its full strength, in the picture at the levels that draw intersection ink.

Figure 16: the crossing on the orange components runs at a sine of 0.12-0.24, near the old
hard limit (0.2), and the facets' noise drew it in dashes. The clifford-torus takeover frame
(`exhibit render --takeover clifford-torus`): the double curves running into its pinch points
were drawn on one side of the sheets' boundary only, in beads. The reference is computed
without the renderer: tests/golden/crossing_pieces.py.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from exhibit import scenes
from exhibit.geometry.pipeline import clip_transform
from exhibit.render import RenderOptions
from exhibit.render.framer import Framer
from exhibit.render.quality import LADDER
from exhibit.render.passes.intersections import FULL_CROSSING, MIN_CROSSING, screen_extent
from tests.golden.crossing_pieces import (
    Pairs,
    curves,
    front,
    ink_pieces,
    jacobian,
    screen,
    seeds,
    sine,
)
from tests.golden.outline_pieces import whole

pytestmark = pytest.mark.slow

SIZE = (1280, 720)
#: Runs where the ink's strength (0 at MIN_CROSSING, 1 from FULL_CROSSING on) is at least this
#: must be inked whole.
LEAST = 0.25
#: Pixels of scaled depth a sheet may lie in front of a crossing and not hide it (the mesh's
#: triangles are within their sag of the true sheets).
SPARE = 4.0


@pytest.fixture(autouse=True)
def _own_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "meshes"))


def reference(pairs: Pairs, ct, scale: float, mesh_points, triangles, seed_us):
    """[(pixels, visible flags, strong flags)] for each double curve through the seeds."""

    def image(p):
        return screen(ct, SIZE, scale, p)

    def pixel(p):
        return image(p)[..., :2]

    out = []
    mesh_image = image(mesh_points)
    for curve in curves(pairs, seed_us, pixel, image):
        ps = np.array([pairs.pair(u) for u in curve])
        points = image(ps[:, 0])
        sines = np.array([sine(pairs, lambda x: jacobian(image, x), p, q) for p, q in ps])
        strength = np.clip((sines - MIN_CROSSING) / (FULL_CROSSING - MIN_CROSSING), 0.0, 1.0)
        flags = front(points, mesh_image, triangles, SPARE)
        out.append((points[:, :2], flags, strength))
    return out


def bare(options: RenderOptions) -> RenderOptions:
    """The surfaces and their intersection ink alone: curves, outlines, discs and the HUD
    drawn over the ink would hide it from the measure (they hide it in the picture too)."""
    return replace(options, curves=False, silhouettes=False, hud=False)


def measure(ref, inked, plain):
    return {
        f"crossing {i + 1}": ink_pieces(pixels, flags, strength, inked, plain, LEAST)
        for i, (pixels, flags, strength) in enumerate(ref)
    }


# ---------------------------------------------------------------------------- Figure 16


def figure_16(headless, gpu, mesh, view):
    params = dict(scenes.figure(16)[1].params)
    rc, rs, vc, vs = params["rc"], params["rs"], params["vc"], params["vs"]

    def f(p):  # the paper's cylinder and ball, (x, y, z, t)
        x, y, z, t = p
        return np.array([(y - vc * t) ** 2 + z**2 - rc**2, x**2 + y**2 + (z + vs * t) ** 2 - rs**2])

    ct = clip_transform(view, SIZE[0] / SIZE[1])
    scale = screen_extent(headless.renderer.pipeline, gpu, view, SIZE)[0]

    def residual(u):
        return np.concatenate(
            [f(u[:4]), f(u[4:]), screen(ct, SIZE, scale, u[:4]) - screen(ct, SIZE, scale, u[4:])]
        )

    def tangents(p):
        return np.linalg.svd(jacobian(f, p))[2][2:].T

    pairs = Pairs(lambda u: (u[:4], u[4:]), residual, tangents)
    surface = next(s for s in mesh.surfaces if s.material.style != "wire")
    v = surface.positions
    found = seeds(v, screen(ct, SIZE, scale, v))
    return reference(
        pairs, ct, scale, v, surface.triangles, [np.concatenate([v[i], v[j]]) for i, j in found]
    )


@pytest.mark.parametrize("level", ["still", "fxaa"])
def test_figure_16s_crossing_is_one_piece(headless, level):
    scene, preset = scenes.figure(16)
    mesh = scene.build(dict(preset.params), scene.default_resolution)
    note = f"Figure 16. {preset.caption}".strip()
    view = Framer(SIZE, RenderOptions().text, hud=True).view(
        mesh, preset.view, scene.title, [(scene.caption, note)]
    )
    headless.activate()
    gpu = headless.renderer.upload(mesh)
    try:
        ref = figure_16(headless, gpu, mesh, view)
        options = bare(RenderOptions())
        pictures = []
        for o in (options, replace(options, intersections=False)):
            if level == "still":
                pictures.append(headless.still(gpu, view, SIZE, o))
            else:
                pictures.append(
                    headless.frame(gpu, view, SIZE, o.at_quality(LADDER[1]), None, LADDER[1])
                )
    finally:
        gpu.release()
    counts = measure(ref, *pictures)
    assert sum(len(c) for c in counts.values()) >= 2, f"the reference found too little: {counts}"
    assert whole(counts), f"Figure 16 at {level}: (pieces, share shown) per strong run: {counts}"


# ---------------------------------------------------------------------------- the takeover


def torus_pairs(ct, scale, radius: float) -> Pairs:
    r = radius / math.sqrt(2)

    def point(a, b):
        return r * np.array([np.cos(a), np.sin(a), np.cos(b), np.sin(b)])

    def residual(u):
        return screen(ct, SIZE, scale, point(u[0], u[1])) - screen(
            ct, SIZE, scale, point(u[2], u[3])
        )

    def tangents(p):
        a, b = math.atan2(p[1], p[0]), math.atan2(p[3], p[2])
        return r * np.array(
            [[-math.sin(a), 0], [math.cos(a), 0], [0, -math.sin(b)], [0, math.cos(b)]]
        )

    return Pairs(lambda u: (point(u[0], u[1]), point(u[2], u[3])), residual, tangents)


def test_the_clifford_torus_takeover_crossings_are_one_piece(headless, mesh_cache):
    from exhibit.review.player import KioskPlayer
    from exhibit.review.setup import base_config, shipped_timeline

    config = base_config()
    player = KioskPlayer(
        SIZE,
        timeline=shipped_timeline("clifford-torus"),
        scene="clifford-torus",
        language="en",
        config=config,
        headless=headless,
    )
    try:
        player.takeover(2.0, 10.0)  # as `exhibit render --takeover clifford-torus` draws it
        gpu, view, options, _ = player.window.drawn
        quality = options.quality
        ct = clip_transform(view, SIZE[0] / SIZE[1])
        scale = screen_extent(headless.renderer.pipeline, gpu, view, SIZE)[0]
        params = dict(player.kiosk.state.frame.params)
        pairs = torus_pairs(ct, scale, params["radius"])
        surface = gpu.mesh.surfaces[0]
        v = surface.positions
        found = seeds(v, screen(ct, SIZE, scale, v))
        ab = np.stack([np.arctan2(v[:, 1], v[:, 0]), np.arctan2(v[:, 3], v[:, 2])], axis=-1)
        ref = reference(
            pairs,
            ct,
            scale,
            v,
            surface.triangles,
            [np.concatenate([ab[i], ab[j]]) for i, j in found],
        )
        inked = headless.frame(gpu, view, SIZE, bare(options), None, quality)
        plain = headless.frame(
            gpu, view, SIZE, replace(bare(options), intersections=False), None, quality
        )
    finally:
        player.close()
    counts = measure(ref, inked, plain)
    assert sum(len(c) for c in counts.values()) >= 2, f"the reference found too little: {counts}"
    assert whole(counts), f"the takeover frame: (pieces, share shown) per strong run: {counts}"
