"""Tags checked on the frame (`exhibit render --timeline --verify`): a caption's tag is a promise
that these words name that object, so each tag the HUD drew is held to the picture.

- its leader ends on a pixel of its object in the object-id pass (never by colour);
- its words and its leader cross no panel, no other words and no other tag;
- two tags for different objects do not end within NEAR_PX of each other (at 720 lines): two
  leaders ending where two rings meet tell a visitor nothing, least of all one who cannot tell
  the rings' colours apart.

Measured per frame (:func:`tag_faults`, from the HUD's record of what it drew: exhibit.render.hud)
and reported per caption (:func:`tag_problems`), one line per tag and fault with the times."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from exhibit.render.layout import Rect
from exhibit.render.leaders import crosses as _crosses
from exhibit.render.leaders import leader as _leader
from exhibit.render.object_tags import TAGS_APART
from exhibit.timelines.claims.base import matching, time_spans

#: Two tags for different objects end at least this far apart, in pixels of a 720-line screen
#: (the HUD keeps them so: exhibit.render.object_tags).
NEAR_PX = TAGS_APART
#: A leader ends on its object when the object shows under the dot drawn at its end: within
#: this many pixels (at 720 lines: the dot's radius), and one pixel of the id pass (read at a
#: lower resolution, where an outline drawn over the object's rim is relatively wider).
ON_OBJECT_PX = 4.0


@dataclass(frozen=True)
class TagFault:
    """One way a tag is wrong in one frame: the tag's words, what is wrong (``kind``: "off its
    object", "crosses", "near") and with what (a panel, words, another tag)."""

    words: str
    kind: str
    what: str = ""


def tag_faults(
    hud, id_image: np.ndarray, names: Sequence[str], screen: tuple[int, int], panels: list[Rect]
) -> tuple[TagFault, ...]:
    """The faults of the tags ``hud`` (exhibit.render.hud.Hud) drew on a ``screen``-sized frame
    whose object ids are ``id_image`` (ids index ``names`` from 1, at any size); ``panels``:
    where the HUD's panels are."""
    faults: list[TagFault] = []
    tags = list(zip(hud.tags, hud.tag_objects))
    sy = id_image.shape[0] / float(screen[1])
    sx = id_image.shape[1] / float(screen[0])
    reach = math.ceil(ON_OBJECT_PX * screen[1] / 720.0 * max(sx, sy)) + 1
    leaders = [_leader(point, rect) for (_, rect, point, _), _ in tags]
    for i, ((words, rect, (x, y), _), name) in enumerate(tags):
        wanted = set(matching(name, names))
        cx, cy = int(x * sx), int(y * sy)
        near = id_image[max(0, cy - reach) : cy + reach + 1, max(0, cx - reach) : cx + reach + 1]
        if not any(names[k - 1] in wanted for k in np.unique(near) if k):
            faults.append(TagFault(words, "off its object", name))
        own = _leader((x, y), rect)
        for kind, other in _obstacles(hud, panels, i, tags):
            if rect.overlaps(other) or _crosses(own, other):
                faults.append(TagFault(words, "crosses", kind))
        for j, ((other_words, other_rect, _, _), _) in enumerate(tags):
            if j != i and _crosses(own, other_rect):
                faults.append(TagFault(words, "crosses", f"the tag {other_words!r}"))
            if j != i and _crosses(leaders[j], rect):
                faults.append(TagFault(words, "crosses", f"the leader of {other_words!r}"))
    scale = screen[1] / 720.0
    for i, ((words, _, (x, y), _), name) in enumerate(tags):
        for (other_words, _, (u, v), _), other in tags[i + 1 :]:
            if other != name and math.hypot(x - u, y - v) < NEAR_PX * scale:
                faults.append(TagFault(words, "near", other_words))
    return tuple(dict.fromkeys(faults))


def tag_problems(head: str, times: list[float], faults: Sequence[Sequence[TagFault]]) -> list[str]:
    """One line per tag fault found in a caption's frames (``faults[j]``: those of the frame at
    ``times[j]``), with when; a fault in no two samples in a row is left out (a kept anchor is
    re-tested every quarter second, so a tag may lag its object that long)."""
    when: dict[TagFault, list[int]] = {}
    for j, frame in enumerate(faults):
        for fault in frame:
            when.setdefault(fault, []).append(j)
    out = []
    for fault, frames in when.items():
        if not any(b == a + 1 for a, b in zip(frames, frames[1:])):
            continue  # one sample at a time: the anchor's re-test lag (object_tags.CHECK_S)
        at = f"at t = {time_spans(times, frames)}"
        if fault.kind == "off its object":
            what = f"its leader ends off {fault.what!r} (the id pass has none of it there)"
        elif fault.kind == "crosses":
            what = f"its words or leader cross {fault.what}"
        else:
            what = (
                f"it ends within {NEAR_PX:g} px (at 720 lines) of the tag {fault.what!r}, "
                "which names another object"
            )
        out.append(f"{head}: tag {fault.words!r}: {what} {at}")
    return out


def _obstacles(hud, panels: list[Rect], i: int, tags) -> list[tuple[str, Rect]]:
    """What tag ``i`` must keep off: the panels and every piece of text but its own words."""
    own = tags[i][0]
    out = [("a panel", p) for p in panels]
    for mark in hud.texts:
        if mark.kind == "object tag" and mark.text == own[0] and own[1].contains(mark.rect):
            continue
        if mark.kind in ("object tag", "title", "caption", "numbers"):
            continue  # the tags and panels are held to their own rectangles
        out.append((f"the words {mark.text!r} ({mark.kind})", mark.rect))
    return out
