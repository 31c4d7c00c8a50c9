"""What a visitor sees, checked on rendered pixels at 1920x1080 and 1280x720 (issue 14): framed
scenes and figures keep every surface pixel in the free area, off the title, caption, numbers and
gizmo panels (Figure 8 opts out); every marker label is on the screen and off the panels, and the
marker is drawn above the surfaces; the caption's capitals are at least 1/45 of the height."""

import math

import numpy as np
import pytest

from exhibit import scenes
from exhibit.geometry import clip_transform
from exhibit.geometry.occlusion import hidden
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.framer import Framer
from exhibit.render.layout import MIN_CAPTION_CAP, TextSizes, cap_height, hud_layout

SIZES = [(1920, 1080), (1280, 720)]
DRIFT = 12.0
BLACK = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
#: Surfaces only, on black: every lit pixel is a surface pixel.
SURFACES_ONLY = RenderOptions(
    hud=False,
    curves=False,
    silhouettes=False,
    pinch_points=False,
    intersections=False,
    background=BLACK,
)
#: (scene, preset or None for the start view, extra turn of θ1, θ2 in degrees).
CASES = [
    ("offset-parabola", "figure-9", 0, 0),
    ("offset-parabola", "figure-10", 0, 0),
    ("offset-parabola", None, 60, -20),
    ("offset-cusp", "figure-11", 0, 0),
    ("offset-cusp", "figure-12", 0, 0),
    ("offset-cusp", None, 0, 0),
    ("offset-cusp", None, 120, -30),
    ("offset-cusp-traced", "figure-14", 0, 0),
    ("collision", "figure-15", 0, 0),
    ("collision", "figure-17", 80, -35),
    ("clifford-torus", None, 45, 10),
    ("complex-square", None, 0, 0),
    ("hopf", "figure-7", 0, 0),
]
MESHES: dict = {}


def mesh_for(scene, params):
    key = (scene.name, tuple(sorted(params.items())))
    if key not in MESHES:
        MESHES[key] = scene.build(params, 20)
    return MESHES[key]


def case_view(scene, preset, turn1, turn2):
    view = scene.view if preset is None else scene.preset(preset).view
    angles = list(view.angles)
    angles[0] += math.radians(turn1)
    angles[1] += math.radians(turn2)
    return view.replace(angles=tuple(angles))


@pytest.mark.slow
@pytest.mark.parametrize("size", SIZES, ids=["1080p", "720p"])
@pytest.mark.parametrize(
    "name, preset, turn1, turn2", CASES, ids=[f"{c[0]}-{c[1] or 'start'}-{c[2]}" for c in CASES]
)
def test_framed_surfaces_stay_in_the_free_area(gl, size, name, preset, turn1, turn2):
    scene = scenes.get(name)
    params = dict(scene.preset(preset).params) if preset else {}
    mesh = mesh_for(scene, params)
    note = f"Figure. {scene.preset(preset).caption}" if preset else ""
    framer = Framer(size, TextSizes(), DRIFT)
    view = framer.scene_view(scene, mesh, case_view(scene, preset, turn1, turn2), note)
    gpu = gl.renderer.upload(mesh)
    try:
        image = gl.frame(gpu, view, size, SURFACES_ONLY)
    finally:
        gpu.release()
    lit = image.max(axis=-1) > 8
    assert lit.mean() > 0.02, "the surface is (nearly) gone"
    layout = hud_layout(size, scene.title, (scene.caption, note), TextSizes(), DRIFT)
    ys, xs = np.nonzero(lit)
    for panel in layout.panels:
        # The fit keeps the layout's margin; 2 px for rasterising and FXAA.
        guard = panel.grow(layout.margin - 2)
        inside = (xs >= guard.x0) & (xs < guard.x1) & (ys >= guard.y0) & (ys < guard.y1)
        assert not inside.any(), f"{inside.sum()} surface pixels near the panel {panel}"
    edge = layout.margin - 2
    assert xs.min() >= edge and ys.min() >= edge
    assert xs.max() < size[0] - edge and ys.max() < size[1] - edge
    # ... and the picture is not timid: it fills its area along one side, nearly.
    height, width = ys.max() - ys.min(), xs.max() - xs.min()
    assert max(width / size[0], height / size[1]) > 0.3


def test_figure_8_is_not_framed():
    """Figure 8's point is that the torus fills the world: its preset opts out."""
    scene, preset = scenes.figure(8)
    mesh = mesh_for(scene, dict(preset.params))
    framer = Framer((1920, 1080))
    assert framer.scene_view(scene, mesh, preset.view, fit=preset.fit) == preset.view
    figure6 = scene.preset("figure-6")
    assert framer.scene_view(scene, mesh, figure6.view, fit=figure6.fit) != figure6.view


def collision_poses():
    """Collision figures at poses where the first contact is in front and where it is hidden
    (found on the CPU, so the test covers both)."""
    out = []
    for number in (15, 16, 17):
        scene, preset = scenes.figure(number)
        mesh = mesh_for(scene, dict(preset.params))
        found = {}
        for turn in range(0, 360, 20):
            for tilt in (0, -35, 35):
                view = case_view(scene, f"figure-{number}", turn, tilt)
                ct = clip_transform(view, 16 / 9)
                behind = bool(hidden(np.array([mesh.markers[0].position]), mesh.surfaces, ct)[0])
                found.setdefault(behind, (turn, tilt))
        out += [(number, *found[b], b) for b in sorted(found)]
    return out


POSES = collision_poses()


@pytest.mark.slow
@pytest.mark.parametrize("size", SIZES, ids=["1080p", "720p"])
@pytest.mark.parametrize(
    "number, turn, tilt, behind",
    POSES,
    ids=[f"fig{p[0]}-{p[1]}-{p[2]}{'-hidden' if p[3] else ''}" for p in POSES],
)
def test_marker_labels_are_on_screen_off_the_panels_and_above_the_surfaces(
    gl, size, number, turn, tilt, behind
):
    scene, preset = scenes.figure(number)
    mesh = mesh_for(scene, dict(preset.params))
    view = Framer(size, TextSizes(), DRIFT).scene_view(
        scene, mesh, case_view(scene, preset.name, turn, tilt)
    )
    hud = HudInfo(scene.title, scene.caption, scene.axes)
    gpu = gl.renderer.upload(mesh)
    try:
        image = gl.frame(gpu, view, size, RenderOptions(hud_drift=(DRIFT, DRIFT)), hud)
    finally:
        gpu.release()
    labels = gl.renderer.hud.labels
    assert [label for label, *_ in labels] == [m.label for m in mesh.markers if m.label]
    layout = gl.renderer.hud.layout
    for text, rect, (x, y), covered in labels:
        assert rect.x0 >= 0 and rect.x1 <= size[0] and rect.y0 >= 0 and rect.y1 <= size[1]
        for panel in layout.panels:
            assert not rect.overlaps(panel), (text, rect, panel)
        assert covered == behind
        # The marker's disc is drawn over whatever is there: its colour at its rim, even when
        # the point is behind a sheet (then a ring around a dark centre).
        color = np.array(mesh.markers[0].material.color) * 255
        r = max(9.0, 11.0 * size[1] / 720) * 0.4
        rim = image[int(round(y - 0.5)), int(round(x - 0.5 + r))].astype(float)
        assert np.abs(rim - color).max() < 70, (rim, color)
        # The label's glyphs are in the label's colour, on their halo.
        box = image[int(rect.y0) : int(rect.y1), int(rect.x0) : int(rect.x1)].astype(float)
        ink = (np.abs(box - color).max(axis=-1) < 40).sum()
        assert ink > 0.05 * box.shape[0] * box.shape[1]


@pytest.mark.parametrize("size", SIZES + [(3840, 2160), (1024, 768)])
def test_caption_capitals_are_at_least_a_45th_of_the_height(gl, size):
    """Measured on the drawn pixels: the caption's H is at least height / 45 tall, the title's
    taller; the numbers' digits use the same size."""
    layout = hud_layout(size, "H", ("HHHH",))
    assert cap_height("sans", layout.body_px) >= size[1] * MIN_CAPTION_CAP
    assert cap_height("mono", layout.body_px) >= size[1] * MIN_CAPTION_CAP
    assert cap_height("bold", layout.title_px) > cap_height("sans", layout.body_px)
    gpu = gl.renderer.upload(mesh_for(scenes.get("complex-square"), {}))
    try:
        caption = gl.image(
            gpu,
            scenes.get("hopf").view,
            size,
            RenderOptions(background=BLACK, surfaces=False, curves=False),
            HudInfo(caption="HHHH"),
            samples=0,
        )
    finally:
        gpu.release()
    block = layout.title_block
    region = caption[int(block.y0) : int(block.y1), int(block.x0) : int(block.x1)].max(axis=-1)
    rows = np.nonzero((region > 128).any(axis=1))[0]
    assert rows.max() - rows.min() + 1 >= math.floor(size[1] / 45)


def test_every_word_of_the_hud_meets_the_size_rule(gl):
    """Numbers, gizmo labels, "4D axes" and marker labels: every glyph the HUD draws (from the
    atlas; the title block is checked above) has capitals of at least height / 45."""
    scene, preset = scenes.figure(16)
    mesh = mesh_for(scene, dict(preset.params))
    gpu = gl.renderer.upload(mesh)
    try:
        for size in SIZES:
            gl.renderer.atlas._clear()
            gl.frame(
                gpu,
                preset.view,
                size,
                RenderOptions(),
                HudInfo(scene.title, scene.caption, scene.axes),
            )
            used = {(style, px) for style, px, _ in gl.renderer.atlas._glyphs}
            assert {"mono", "bold", "sans"} <= {style for style, _ in used}
            for style, px in used:
                assert cap_height(style, px) >= size[1] * MIN_CAPTION_CAP, (style, px, size)
    finally:
        gpu.release()
