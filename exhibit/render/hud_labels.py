"""The words the HUD puts on the picture: a labelled marker's label beside its diamond, and a
tag for each object a caption names, with a leader line to a point of the object in front.
Each is placed off the panels, off the other labels and, where there is room, off the picture;
a tag also where its leader crosses no other tag (exhibit.render.label_places)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from exhibit.geometry.occlusion import hidden
from exhibit.render.hud_key import marker_diamond
from exhibit.render.inset import inset_rect
from exhibit.render.label_places import marker_text, place_beside
from exhibit.render.layout import HudLayout, Rect
from exhibit.render.leaders import Segment, crosses, leader
from exhibit.render.marks import HALO, INK, legible
from exhibit.render.object_tags import TAGS_APART

#: The HUD whose labels these are (exhibit.render.hud.Hud, which imports this module).
Hud = Any


def marker_labels(
    hud: Hud,
    gpu,
    view,
    size,
    layout: HudLayout,
    rows: list,
    word=lambda english: english,
    picture: Rect | None = None,
    diamonds: list | None = None,
) -> list[tuple]:
    """Labelled markers above the surfaces, labels placed on screen and off the panels;
    ``word`` translates their words (HudInfo.word). Returns the leaders' capsules; the
    markers' diamonds go to ``diamonds`` (a, a, rgba, tip-to-tip width)."""
    if diamonds is None:
        diamonds = []
    hud.labels = []
    markers = [m for m in gpu.mesh.markers if m.label]
    if not markers:
        return []
    width, height = size
    ct = hud.pipeline.clip_transform(view, size)
    positions = np.array([m.position for m in markers])
    pixels, ok = ct.to_pixels(positions, width, height)
    behind = hidden(positions, gpu.mesh.surfaces, ct)
    body = layout.body_px
    scale = height / 720.0
    taken = [p.grow(0.3 * body) for p in boxes(view, size, layout)]
    items: list[tuple] = []
    for m, (x, y), visible, covered in zip(markers, pixels, ok, behind):
        if not visible:
            continue
        color = (*m.material.color, 1.0)
        tips = marker_diamond(scale)
        text = marker_text(m.label, word)
        label = place_beside(text, (x, y), body, layout, taken, picture)
        taken.append(label.grow(0.3 * body))
        # The leader: from the point to the label's nearest edge, when not right beside it.
        nx, ny = min(max(x, label.x0), label.x1), min(max(y, label.y0), label.y1)
        if covered or math.hypot(nx - x, ny - y) > 0.9 * body:
            items.append(((x, y), (nx, ny), HALO, max(4.0, 5.0 * scale)))
            items.append(((x, y), (nx, ny), color, max(2.0, 2.2 * scale)))
        # a dark rim about 2 px wide along its edges (tip to tip: 2 x 2 x sqrt 2 more)
        diamonds.append(((x, y), (x, y), HALO, tips + max(5.6, 5.6 * scale)))
        diamonds.append(((x, y), (x, y), color, tips))
        if covered:  # behind a sheet: hollow, the halo showing through its middle
            diamonds.append(((x, y), (x, y), HALO, 0.5 * tips))
        hud._halo_text(
            "marker label", text, "bold", body, label.x0 + 0.25 * body, label.y0, color, rows
        )
        hud.labels.append((text, label, (float(x), float(y)), bool(covered)))
    return items


def object_tags(
    hud: Hud, gpu, view, size, layout: HudLayout, rows: list, tags, picture: Rect | None
) -> list[tuple]:
    """A short label for each object a caption names (``tags``: (object name, or the
    start of names, words in the language on screen)): words, not colour alone. The tag
    sits off the panels and, where there is room, off the picture, with a leader line to
    a point of the object that is in front (exhibit.render.object_tags)."""
    hud.tags, hud.tag_objects, hud.tag_dots = [], [], []
    if not tags:
        return []
    width, height = size
    ct = hud.pipeline.clip_transform(view, size)
    body = layout.body_px
    scale = height / 720.0
    taken = [p.grow(0.3 * body) for p in boxes(view, size, layout)] + [
        rect.grow(0.3 * body) for _, rect, _, _ in hud.labels
    ]
    items: list[tuple] = []
    ends: list[tuple[str, tuple[float, float]]] = []
    # What a new tag's leader must not run through, and the leaders it must not lie on.
    solid = boxes(view, size, layout) + [rect for _, rect, _, _ in hud.labels]
    segments: list[Segment] = []
    lines = np.zeros((0, 2))  # the named curves' points: words would hide a thin line
    for name, words in tags:
        avoid = [p for other, p in ends if other != name]
        anchor = hud.anchors.anchor(gpu, name, ct, size, taken, avoid, TAGS_APART * scale)
        if anchor is None:
            continue
        (x, y), rgb, covered = anchor
        ends.append((name, (x, y)))
        color = (*legible(rgb), 1.0)
        lines = np.concatenate([lines, hud.anchors.line_points(gpu, name, ct, size)])

        def clear(
            rect: Rect, point: tuple[float, float] = (x, y), named: np.ndarray = lines
        ) -> bool:
            line = leader(point, rect)
            off = rect.grow(0.2 * body)
            on_line = (named[:, 0] >= off.x0) & (named[:, 0] <= off.x1)
            on_line &= (named[:, 1] >= off.y0) & (named[:, 1] <= off.y1)
            return (
                not on_line.any()
                and not any(crosses(s, rect) for s in segments)
                and not any(crosses(line, t) for t in solid)
            )

        label = place_beside(words, (x, y), body, layout, taken, picture, clear)
        taken.append(label.grow(0.3 * body))
        solid.append(label)
        segments.append(leader((x, y), label))
        nx, ny = min(max(x, label.x0), label.x1), min(max(y, label.y0), label.y1)
        items.append(((x, y), (nx, ny), HALO, max(4.0, 5.0 * scale)))
        items.append(((x, y), (nx, ny), color, max(2.0, 2.2 * scale)))
        dot = max(7.0, 8.0 * scale)
        ring = ((x, y), (x, y), HALO, dot + max(4.0, 4.0 * scale))
        items += [ring, ((x, y), (x, y), color, dot)]
        hud.tag_dots.append(ring[:2])
        if covered:
            items.append(((x, y), (x, y), HALO, 0.5 * dot))
        hud._halo_text(
            "object tag", words, "bold", body, label.x0 + 0.25 * body, label.y0, INK, rows
        )
        hud.tags.append((words, label, (float(x), float(y)), bool(covered)))
        hud.tag_objects.append(name)
    return items


def boxes(view, size: tuple[int, int], layout: HudLayout) -> list[Rect]:
    """What labels keep off: the panels, and with a slice the inset of the 3D world at that
    moment in the bottom-right corner (exhibit.render.inset)."""
    out = list(layout.panels)
    if view.slice_axis is not None:
        out.append(inset_rect(size, layout.margin))
    return out
