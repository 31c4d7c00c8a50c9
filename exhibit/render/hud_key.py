"""The key under the numbers: one entry for each kind of mark the frame shows (the Lemma 2
points, a labelled marker such as the first contact, the outlines, the slice, the axes), each
with its shape and colour as the picture draws it and the objects of the id pass it explains
(Hud.explained), so `--verify` can hold every mark on screen to a word.

Why apart from exhibit.render.hud: what the key lists is a question of the mesh and the view;
how the HUD lays out its panels is another."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render.gpu import GpuMesh
from exhibit.render.hud_info import HudInfo
from exhibit.render.layout import (
    AXES_KEY,
    CONTACT_KEY,
    OUTLINE_KEY,
    PINCH_KEY,
    SLICE_KEY,
    KEY_WORDS,
)
from exhibit.render.marks import HALO, PINCH_COLOR, darker
from exhibit.surfaces.slice import SLICE_MATERIAL


class KeyEntry(NamedTuple):
    """One entry of the key under the numbers: its English words (layout.KEY_WORDS, or a
    marker label's words), the words shown, its swatch (``shape``: "disc" for the Lemma 2
    points, "diamond" for a labelled marker, "ink" for the outlines, "slice", "axes"), the
    colours the swatch is drawn in, and the id pass's objects it explains (object_names)."""

    english: str
    text: str
    shape: str
    colors: tuple[tuple[float, float, float], ...]
    objects: tuple[str, ...]


def key_entries(
    gpu: GpuMesh, view: ViewState, hud: HudInfo, ct, size: tuple[int, int]
) -> list[KeyEntry]:
    """The key's entries for this frame: only the kinds of mark it has, in KEY_WORDS'
    order, in the language on screen; none when ``hud.words`` carry no key (a figure
    rendered for the paper). The Lemma 2 discs and the outlines come with every solid
    surface (the kiosk always draws them), the slice when the view slices the surfaces
    within their extent, a labelled marker's entry while the marker is on the screen, the
    axes' while the mesh has axis lines ("x axis": curves named for an axis)."""
    shown = dict(hud.words)
    if not any(word in shown for word in KEY_WORDS):
        return []
    mesh = gpu.mesh
    solid = [s for s in mesh.surfaces if s.material.style != "wire"]
    out: list[KeyEntry] = []

    def add(english, shape, colors, objects, words=None):
        if objects and (english in shown or words is not None):
            text = hud.word(english) if words is None else words
            out.append(KeyEntry(english, text, shape, tuple(colors), tuple(objects)))

    if solid:
        add(PINCH_KEY, "disc", [PINCH_COLOR], ["pinch points"])
    width, height = size
    kinds: dict[str, list] = {}
    for m in mesh.markers:
        if not m.label:
            continue
        pixels, ok = ct.to_pixels(m.position[None], width, height)
        x, y = pixels[0]
        if bool(ok[0]) and 0 <= x < width and 0 <= y < height:
            kinds.setdefault(m.label.partition(", ")[0], []).append(m)
    for english, markers in kinds.items():
        words = hud.word(english) if english in shown or english == CONTACT_KEY else english
        add(english, "diamond", [markers[0].material.color], [m.name for m in markers], words)
    if solid:
        add(OUTLINE_KEY, "ink", [solid[0].material.color], ["outline"])
    slices = [c.name for c in mesh.curves if c.material.color == SLICE_MATERIAL.color]
    if view.slice_axis is not None and any(
        _spans(s.positions[:, view.slice_axis], view.slice_at) for s in solid
    ):
        slices.insert(0, "slice")
    add(SLICE_KEY, "slice", [SLICE_MATERIAL.color], slices)
    axes = [c for c in mesh.curves if c.name.endswith(" axis")]
    add(AXES_KEY, "axes", [c.material.color for c in axes], [c.name for c in axes])
    return out


def marker_diamond(scale: float) -> float:
    """A labelled marker's diamond, tip to tip in pixels (``scale``: the screen height / 720):
    as much area as the disc it was (11 px across at 720 lines), so it covers the picture's
    own disc of the marker (exhibit.render.gpu.MARKER_SCALE) with its halo."""
    return max(13.0, 15.5 * scale)


def _spans(values: np.ndarray, at: float) -> bool:
    """Whether ``at`` lies within the range of ``values`` (a surface's coordinates along the
    slicing axis): the slice of the surface there is not empty."""
    return bool(len(values)) and float(values.min()) <= at <= float(values.max())


def key_swatch_items(
    entry: KeyEntry, centre: tuple[float, float], body: int, diamonds: list
) -> list[tuple]:
    """The capsules of a key entry's swatch, centred on ``centre`` (within key_swatch(body)):
    the mark's shape and colour as the picture draws it. A diamond goes to ``diamonds``."""
    cx, cy = centre
    reach = 0.42 * body  # half the swatch's length
    rgb = entry.colors
    if entry.shape == "disc":  # a Lemma 2 point, yellow, on a dark rim
        return [
            (centre, centre, HALO, 0.62 * body + 3.0),
            (centre, centre, (*rgb[0], 1.0), 0.62 * body),
        ]
    if entry.shape == "diamond":  # a labelled marker, as drawn over the picture
        diamonds.append((centre, centre, HALO, 0.95 * body + 4.0))
        diamonds.append((centre, centre, (*rgb[0], 1.0), 0.95 * body))
        return []
    if entry.shape == "ink":  # a dark outline along a patch of the surface it bounds
        a, b = (cx - 0.3 * reach, cy), (cx + 0.3 * reach, cy)
        return [
            (a, b, (*rgb[0], 1.0), 0.62 * body),
            (
                (a[0], cy + 0.1 * body),
                (b[0], cy + 0.1 * body),
                (*darker(rgb[0]), 1.0),
                max(2.0, 0.12 * body),
            ),
        ]
    if entry.shape == "slice":  # the bright, wide slice line
        a, b = (cx - reach, cy + 0.3 * reach), (cx + reach, cy - 0.3 * reach)
        return [
            (a, b, HALO, max(3.0, 0.2 * body) + 3.0),
            (a, b, (*rgb[0], 1.0), max(3.0, 0.2 * body)),
        ]
    # axis lines: one short line per axis, in its colour, crossing like the gizmo's
    out = []
    for i, color in enumerate(rgb[:4]):
        angle = math.pi * i / max(len(rgb[:4]), 1)
        ux, uy = math.cos(angle) * reach, math.sin(angle) * reach
        out.append(((cx - ux, cy - uy), (cx + ux, cy + uy), (*color, 1.0), max(2.0, 0.1 * body)))
    return out
