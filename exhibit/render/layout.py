"""Where the HUD's panels sit on a screen of a given size, and what is left for the picture.

Pure layout (Pillow's font metrics, no GL), because three things must agree on it exactly: the
HUD that draws the panels (exhibit.render.hud), the framing that fits the 3D image into the
space the panels leave free (exhibit.geometry.framing, through :func:`free_rectangles`), and the
marker labels that must stay off the panels. Were each to guess the others' sizes, the picture
would slide under the caption as soon as someone changed a font size.

Text is sized for a room, as a fraction of the screen height: the caption's capital letters are
at least 1/45 of the height (24 px at 1080p, about 12 mm on a 55" screen, legible from 3 m), the
title's larger; both come from the kiosk config's [text] table (``TextSizes``). Sizes are chosen
by the measured cap height of the font (the height of "H"), not the nominal point size, because
that is what a reader sees.

Why one module of this size: the HUD's layout and the framing's free area must agree to the
pixel, so one module computes both."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from exhibit.render.text import ellipsize, font, line_height, text_width, units, wrap_balanced

if TYPE_CHECKING:
    from exhibit.geometry.view import ViewState

#: The smallest caption cap height the exhibit allows, as a fraction of the screen height.
MIN_CAPTION_CAP = 1.0 / 45.0
#: Beyond this sensor or eye distance the HUD shows ∞ (a number of 26163.17 means nothing).
INFINITY_BEYOND = 1000.0
#: A caption's comfortable line length, in font sizes (at least 0.42 of the width): about 60
#: characters, so a two-sentence caption is two lines, not a narrow column of three or four.
CAPTION_MEASURE = 28
#: The tallest check-config lets a title or caption make that panel (exhibit check-config).
PANEL_LIMIT = 0.4
#: The key under the numbers (the kiosk shows it; HudInfo.words carries its words in the
#: language on screen): every kind of mark the picture draws, each by its shape and colour
#: beside its words, only the kinds the frame has (exhibit.render.hud.Hud.key_entries).
#: The live Lemma 2 points are yellow discs on every solid surface. The words are short (the
#: paper's lemmas are for its readers, not for a visitor), so the hypersphere's key (discs,
#: outlines, axes) and the collision's without a slice take one line.
PINCH_KEY = "pinch point"
#: A labelled marker (exhibit.scenes.collision's first contact): a diamond, never a disc.
CONTACT_KEY = "first contact"
#: The live Lemma 3 outlines: a dark line along a surface, in the surface's colour darkened.
OUTLINE_KEY = "outline"
#: The glowing slice of the surfaces at one value of an axis (ViewState.slice_axis).
SLICE_KEY = "slice"
#: Coordinate axis lines drawn in the picture (the hypersphere's x, y, z, w axes).
AXES_KEY = "axes"
#: The key's entries in the order the key lists them (English; HudInfo.words translates).
KEY_WORDS = (PINCH_KEY, CONTACT_KEY, OUTLINE_KEY, SLICE_KEY, AXES_KEY)
#: The widest check-config lets a word of the numbers panel make it (the English panel is 45 %
#: of a 1280x720 screen, the German 55 %).
NUMBERS_LIMIT = 0.6


@dataclass(frozen=True)
class TextSizes:
    """The HUD's text sizes as fractions of the screen height (cap heights: the height of a
    capital letter, what the eye reads), and when a distance is shown as ∞."""

    caption_cap: float = 0.024
    title_cap: float = 0.034
    infinity_beyond: float = INFINITY_BEYOND

    def __post_init__(self) -> None:
        if not (MIN_CAPTION_CAP - 1e-9 <= self.caption_cap <= 0.1):
            raise ValueError(
                f"caption cap height {self.caption_cap:g} must lie in "
                f"[1/45, 0.1] of the screen height"
            )
        if not self.caption_cap < self.title_cap <= 0.15:
            raise ValueError(
                f"title cap height {self.title_cap:g} must be larger than the "
                f"caption's ({self.caption_cap:g}) and at most 0.15"
            )
        if not (1.0 <= self.infinity_beyond <= 1e6):
            raise ValueError(f"infinity_beyond {self.infinity_beyond:g} must lie in [1, 1e6]")


@lru_cache(maxsize=256)
def cap_height(style: str, px: int) -> int:
    """The height in pixels of a capital H in ``style`` at font size ``px``."""
    _, top, _, bottom = font(style, px).getbbox("H")
    return int(bottom - top)


@lru_cache(maxsize=256)
def size_for_cap(style: str, cap_px: float) -> int:
    """The smallest font size whose capitals are at least ``cap_px`` pixels tall."""
    px = max(6, int(cap_px / 0.8))
    while cap_height(style, px) < cap_px and px < 1000:
        px += 1
    while px > 6 and cap_height(style, px - 1) >= cap_px:
        px -= 1
    return px


class Rect(NamedTuple):
    """A rectangle in pixels, x right and y down from the top-left corner."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        return self.y1 - self.y0

    def grow(self, by: float) -> Rect:
        return Rect(self.x0 - by, self.y0 - by, self.x1 + by, self.y1 + by)

    def overlaps(self, other: Rect) -> bool:
        return (
            self.x0 < other.x1 and other.x0 < self.x1 and self.y0 < other.y1 and other.y0 < self.y1
        )

    def contains(self, other: Rect) -> bool:
        return (
            self.x0 <= other.x0
            and self.y0 <= other.y0
            and other.x1 <= self.x1
            and other.y1 <= self.y1
        )


def format_distance(distance: float, beyond: float = INFINITY_BEYOND) -> str:
    """A distance for people: ∞ beyond ``beyond``, else two decimals (fixed width 7)."""
    if not math.isfinite(distance) or distance > beyond:
        return f"{'∞':>7}"
    return f"{distance:7.2f}"


def format_angle(radians: float) -> str:
    """An angle in degrees within (-180, 180], one decimal, fixed width 6."""
    degrees = math.degrees(math.remainder(radians, 2 * math.pi))
    if degrees <= -179.95:
        degrees += 360.0
    return f"{degrees:6.1f}°"


def status_lines(
    view: ViewState, beyond: float = INFINITY_BEYOND, words: tuple[tuple[str, str], ...] = ()
) -> list[str]:
    """The numbers panel: six angles on two lines and the two distances, every field of fixed
    width so nothing jitters while a knob turns. θ with plain digits: subscripts are too small
    to read from a distance. ``words``: (English, shown) pairs for "sensor", "eye", "fov"."""
    a = [format_angle(x) for x in view.angles]
    eye = format_distance(view.eye_distance, beyond).strip()
    fov = None if view.eye_r == 0 else view.field_of_view
    return [
        _angles_line(a[:3], 1),
        _angles_line(a[3:], 4),
        _distances_line(dict(words), format_distance(view.sensor_distance, beyond), eye, fov),
    ]


def _angles_line(angles: list[str], first: int) -> str:
    return "  ".join(f"θ{first + i} {text}" for i, text in enumerate(angles))


def _distances_line(words: dict, sensor: str, eye: str, fov: float | None) -> str:
    """The sensor's and the eye's distance and the eye's field of view, labelled in the
    language on screen."""

    def word(english: str) -> str:
        return words.get(english, english)

    fov_text = "" if fov is None else f"  {word('fov')} {fov:3.0f}°"
    return f"{word('sensor')} {sensor}   {word('eye')} {eye:>5}{fov_text}"


def widest_status(
    words: tuple[tuple[str, str], ...] = (), beyond: float = INFINITY_BEYOND
) -> list[str]:
    """The widest lines the numbers panel can show in the language of ``words``, with
    distances up to ``beyond`` (farther is ∞): the panel is this wide whatever the numbers, so
    it never jitters while a knob turns."""
    farthest = format_distance(beyond, beyond)
    return [
        _angles_line(["-179.9°"] * 3, 1),
        _distances_line(dict(words), farthest, farthest.strip(), 180.0),
    ]


def key_swatch(body_px: int) -> float:
    """The room a key entry's swatch (its mark's shape) takes before its words."""
    return 1.2 * body_px


def key_entry_width(text: str, body_px: int) -> float:
    """A key entry's width: its swatch and its words."""
    return key_swatch(body_px) + text_width(text, "sans", body_px)


def key_lines(entries: Sequence[str], body_px: int, room: float) -> list[list[tuple[int, float]]]:
    """The key's entries flowed into lines ``room`` pixels wide, in order, as many on a line
    as fit (a gap of one font size between them), so the panel stays small: per line, each
    entry's index and its left edge from the panel's inner left. Leaving entries out never
    makes more lines (a line starting no earlier holds fewer or the same words)."""
    gap = float(body_px)
    lines: list[list[tuple[int, float]]] = []
    x = 0.0
    for i, text in enumerate(entries):
        w = key_entry_width(text, body_px)
        if lines and x > 0.0 and x + gap + w <= room:
            lines[-1].append((i, x + gap))
            x += gap + w
        else:
            lines.append([(i, 0.0)])
            x = w
    return lines


def key_texts(words: tuple[tuple[str, str], ...]) -> tuple[str, ...]:
    """Every key entry ``words`` (HudInfo.words) carry, in the language on screen: the most the
    key may show (what the framing keeps the picture clear of)."""
    shown = dict(words)
    return tuple(shown[k] for k in KEY_WORDS if k in shown)


def caption_wrap(paragraph: str, px: int, measure: float, room: float) -> list[str]:
    """A caption paragraph's lines: one line when it fits the ``room`` beside the gizmo (a
    short caption broken in two reads as a narrow column and costs the picture height);
    otherwise as few lines as the ``measure`` (a comfortable line length) needs, balanced
    across that many lines."""
    line = " ".join(paragraph.split())
    if text_width(line, "sans", px) <= room:
        return [line]
    return wrap_balanced(line, "sans", px, measure, break_words=True)


@dataclass(frozen=True)
class HudLayout:
    """The panels of one screen: rectangles in pixels, before the burn-in drift (``drift``
    is how far the panels may move right and down; ``panels`` are grown by it)."""

    size: tuple[int, int]
    margin: int
    title_px: int
    body_px: int
    pad: int
    title_lines: tuple[str, ...]
    caption_lines: tuple[str, ...]
    title_block: Rect | None
    status_block: Rect
    gizmo_center: tuple[float, float]
    gizmo_radius: float
    gizmo_block: Rect
    drift: float
    #: The key under the numbers: each entry's words and its swatch's top-left corner, in
    #: pixels from the numbers panel's top-left (exhibit.render.hud draws the swatches).
    key: tuple[tuple[str, float, float], ...] = ()

    @property
    def panels(self) -> list[Rect]:
        """Every panel, where it may be with the drift: nothing else should go there."""
        boxes = [self.status_block, self.gizmo_block]
        if self.title_block is not None:
            boxes.insert(0, self.title_block)
        return [
            Rect(b.x0, b.y0, b.x1 + self.drift, b.y1 + self.drift)
            if b is not self.status_block
            else Rect(b.x0, b.y0 - self.drift, b.x1 + self.drift, b.y1)
            for b in boxes
        ]


def _clip(
    lines: list[tuple[str, str, int]], room_h: float, room_w: float
) -> list[tuple[str, str, int]]:
    """The first lines that fit ``room_h`` pixels, the last of them ending in "…" when some
    are left out (at least one line)."""
    kept: list[tuple[str, str, int]] = []
    used = 0
    for line in lines:
        used += line_height(line[1], line[2])
        if used > room_h and kept:
            break
        kept.append(line)
    if len(kept) < len(lines):
        text, style, px = kept[-1]
        kept[-1] = (ellipsize(text, style, px, room_w), style, px)
    return kept


def hud_layout(
    size: tuple[int, int],
    title: str = "",
    captions: tuple[str, ...] = ("",),
    sizes: TextSizes = TextSizes(),
    drift: float = 0.0,
    words: tuple[tuple[str, str], ...] = (),
    clip: bool = True,
    key: tuple[str, ...] | None = None,
) -> HudLayout:
    """The panels for ``title`` and the caption paragraphs ``captions`` (the caption and a
    note, each wrapped on its own) on a ``size`` screen; ``words``: the numbers panel's words
    in the language on screen (HudInfo.words), which set its width; ``key``: the key entries
    the frame shows, in the language on screen (None: every one ``words`` carry, the largest
    the panel gets, as the framing lays it out). The panel is as wide for any ``key`` as for
    all of ``words``' entries, and so at most as tall: the picture framed clear of the largest
    key is clear of every smaller one.

    A word wider than the panel's room is broken by characters, and with ``clip`` the lines
    that would make the title and caption panel reach the numbers panel are left out ("…"):
    whatever text arrives, the panel stays on the screen (check-config refuses such text
    before it gets here: :func:`text_problems`)."""
    width, height = int(size[0]), int(size[1])
    margin = max(4, round(0.022 * height))
    title_px = size_for_cap("bold", sizes.title_cap * height)
    body_px = size_for_cap("sans", sizes.caption_cap * height)
    pad = max(3, body_px // 2)

    # The gizmo, top right: a disc of radius + body_px around the axes, "4D axes" under it.
    radius = max(14.0, 0.09 * height)
    extent = radius + body_px
    cx, cy = width - margin - extent, margin + extent
    gizmo = Rect(
        cx - extent,
        margin,
        width - margin,
        max(cy + extent, cy + radius + 0.1 * body_px + line_height("sans", body_px)),
    )

    # Title and caption, top left, short of the gizmo; captions a little narrower (a measure of
    # about 45 characters reads best).
    room = gizmo.x0 - 2 * margin - 2 * pad - margin
    title_lines = (
        tuple(wrap_balanced(title, "bold", title_px, room, break_words=True)) if title else ()
    )
    # The panel is at least as wide as the title: a caption uses that width before it wraps
    # into a column narrower than the heading above it.
    heading = max((text_width(t, "bold", title_px) for t in title_lines), default=0.0)
    measure = min(room, max(0.42 * width, CAPTION_MEASURE * body_px, heading))
    caption_lines: list[str] = []
    for paragraph in captions:
        if paragraph:
            caption_lines += caption_wrap(paragraph, body_px, measure, room)
    lines = [(t, "bold", title_px) for t in title_lines] + [
        (t, "sans", body_px) for t in caption_lines
    ]
    # The numbers, bottom left, in a fixed-width font, the key under them.
    advance = text_width("0", "mono", body_px)
    widest = widest_status(words, sizes.infinity_beyond)
    status_w = max(len(t) for t in widest) * advance + 2 + 2 * pad
    every = key_texts(words)
    entries = every if key is None else tuple(key)
    for text in dict.fromkeys((*every, *entries)):
        status_w = max(status_w, key_entry_width(text, body_px) + 2 * pad)
    flowed = key_lines(entries, body_px, status_w - 2 * pad)
    mono_h, sans_h = line_height("mono", body_px), line_height("sans", body_px)
    key_h = len(flowed) * sans_h
    status_h = 3 * mono_h + key_h + 2 * pad
    placed = tuple(
        (entries[i], pad + x, pad + 3 * mono_h + row * sans_h)
        for row, line in enumerate(flowed)
        for i, x in line
    )
    if clip:  # never over the numbers panel
        lines = _clip(lines, height - 3 * margin - status_h - 2 * pad, room)
        title_lines = tuple(t for t, s, _ in lines if s == "bold")
        caption_lines = [t for t, s, _ in lines if s == "sans"]
    block = None
    if lines:
        w = math.ceil(max(text_width(t, s, px) for t, s, px in lines)) + 2 * pad
        h = sum(line_height(s, px) for _, s, px in lines) + 2 * pad
        block = Rect(margin, margin, margin + w, margin + h)

    status = Rect(margin, height - margin - status_h, margin + status_w, height - margin)
    return HudLayout(
        (width, height),
        margin,
        title_px,
        body_px,
        pad,
        title_lines,
        tuple(caption_lines),
        block,
        status,
        (cx, cy),
        radius,
        gizmo,
        drift,
        placed,
    )


# ---------------------------------------------------------------------- for check-config

#: The screen check-config lays every text out on: the smallest a kiosk screen is expected to
#: be (text sizes are fractions of the height, so a 720-line screen is the narrowest room).
CHECK_SIZE = (1280, 720)


def text_problems(
    kind: str,
    text: str,
    sizes: TextSizes = TextSizes(),
    size: tuple[int, int] = CHECK_SIZE,
    word: str = "sensor",
) -> list[str]:
    """Why ``text`` cannot be laid out in its place on a ``size`` screen (empty when it can):
    ``kind`` is "title", "caption", "gizmo" (the line under the 4D axes), "numbers" (``word``
    of the numbers panel: "sensor", "eye", "fov" or an entry of the key, KEY_WORDS, the others
    in English), "label" (a marker label's words) or "key" (words that are both: the first
    contact's)."""
    if kind == "key":
        return text_problems("numbers", text, sizes, size, word) + text_problems(
            "label", text, sizes, size, word
        )
    width, height = size
    if kind in ("title", "caption"):
        layout = hud_layout(
            size,
            text if kind == "title" else "",
            ("",) if kind == "title" else (text,),
            sizes,
            clip=False,
        )
        style, px = ("bold", layout.title_px) if kind == "title" else ("sans", layout.body_px)
        room = layout.gizmo_block.x0 - 2 * layout.margin - 2 * layout.pad - layout.margin
        out = []
        widest = max((text_width(u, style, px) for u in units(text)), default=0.0)
        if widest > room:
            word = max(units(text), key=lambda u: text_width(u, style, px))
            out.append(
                f"the word {_short(word)} is {widest:.0f} px wide at {width}x{height}, "
                f"wider than the panel's {room:.0f} px"
            )
        block = layout.title_block
        if block is not None and block.height > PANEL_LIMIT * height:
            out.append(
                f"makes the {kind} panel {block.height:.0f} px tall at {width}x{height}"
                f" ({len(layout.title_lines) + len(layout.caption_lines)} lines), more "
                f"than {PANEL_LIMIT:.0%} of the screen"
            )
        return out
    layout = hud_layout(size, sizes=sizes)
    if kind == "gizmo":
        w = text_width(text, "sans", layout.body_px)
        if w > layout.gizmo_block.width:
            return [
                f"is {w:.0f} px wide at {width}x{height}, wider than the 4D axes' "
                f"{layout.gizmo_block.width:.0f} px"
            ]
        return []
    if kind == "numbers":
        panel = hud_layout(
            size,
            sizes=sizes,
            words=tuple(
                (english, text if english == word else english)
                for english in ("sensor", "eye", "fov", *KEY_WORDS)
            ),
        ).status_block
        if panel.width > NUMBERS_LIMIT * width:
            return [
                f"makes the numbers panel {panel.width:.0f} px wide at {width}x{height}, "
                f"more than {NUMBERS_LIMIT:.0%} of the screen"
            ]
        return []
    w = text_width(text, "bold", layout.body_px)
    if w > width / 2:
        return [f"is {w:.0f} px wide at {width}x{height}, more than half the screen"]
    return []


def _short(word: str) -> str:
    return repr(word) if len(word) <= 40 else repr(word[:30] + "…") + f" ({len(word)} characters)"


# ---------------------------------------------------------------------- the gizmo's letters


def free_rectangles(size: tuple[int, int], panels: list[Rect], margin: float) -> list[Rect]:
    """The largest rectangles of the screen (inset by ``margin``) that keep ``margin`` away from
    every panel: each is maximal (no side can move out without meeting a panel or the edge).
    The picture is fitted into one of them (exhibit.geometry.framing picks the one where it
    comes out largest)."""
    width, height = size
    screen = Rect(margin, margin, width - margin, height - margin)
    blocks = [p.grow(margin) for p in panels]
    xs = sorted(
        {
            screen.x0,
            screen.x1,
            *[v for b in blocks for v in (b.x0, b.x1) if screen.x0 < v < screen.x1],
        }
    )
    ys = sorted(
        {
            screen.y0,
            screen.y1,
            *[v for b in blocks for v in (b.y0, b.y1) if screen.y0 < v < screen.y1],
        }
    )
    # The grid of the blocks' edges cuts the screen into cells; a rectangle on the grid is free
    # when none of its cells meets a block, counted at once for every rectangle by a summed
    # table (i < k columns, j < m rows). Comparing rectangles one by one cost the kiosk a
    # millisecond a frame.
    cx = [(a + b) / 2 for a, b in zip(xs, xs[1:])]
    cy = [(a + b) / 2 for a, b in zip(ys, ys[1:])]
    blocked = np.zeros((len(xs), len(ys)), dtype=np.int32)
    for b in blocks:
        columns = [n for n, x in enumerate(cx) if b.x0 < x < b.x1]
        rows = [n for n, y in enumerate(cy) if b.y0 < y < b.y1]
        for n in columns:
            blocked[n + 1, [r + 1 for r in rows]] = 1
    table = blocked.cumsum(0).cumsum(1)  # table[k, m]: blocked cells left of k and above m
    i, k, j, m = np.ix_(*(np.arange(n) for n in (len(xs), len(xs), len(ys), len(ys))))
    inside = (table[k, m] - table[i, m] - table[k, j] + table[i, j]) == 0
    free = inside & (i < k) & (j < m)
    # Maximal: no step to the next grid line on any side is free (a larger free rectangle
    # would contain such a step, and the step would be free too).
    grows = np.zeros_like(free)
    grows[1:] |= free[:-1]  # (i - 1, k, j, m) free
    grows[:, :-1] |= free[:, 1:]  # (i, k + 1, j, m)
    grows[:, :, 1:] |= free[:, :, :-1]  # (i, k, j - 1, m)
    grows[:, :, :, :-1] |= free[:, :, :, 1:]  # (i, k, j, m + 1)
    maximal = [Rect(xs[a], ys[c], xs[b], ys[d]) for a, b, c, d in zip(*np.nonzero(free & ~grows))]
    return sorted(maximal, key=lambda r: -r.width * r.height)
