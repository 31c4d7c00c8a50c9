"""What a visitor reads in the caption panel: lines never start with a dash, a short caption is
one line, a long one uses the fewest lines its measure needs, evened out (pure: no GL)."""

import pytest

from exhibit import scenes
from exhibit.render.layout import CAPTION_MEASURE, hud_layout
from exhibit.render.text import text_width, wrap, wrap_balanced

SPACED = (
    "Take every line through the centre of a ball and turn it into one point. The shadow "
    "you see crosses itself {dash} turn the knobs and watch the crossings move {dash} "
    "and again."
)


@pytest.mark.parametrize("dash", ["–", "—", "-"])
@pytest.mark.parametrize("wrapper", [wrap, wrap_balanced])
def test_no_line_starts_with_a_dash(dash, wrapper):
    text = SPACED.format(dash=dash)
    for width in range(120, 1400, 7):
        lines = wrapper(text, "sans", 24, width)
        assert " ".join(lines) == text
        for line in lines[1:]:
            assert not line.startswith(dash), (width, lines)


def test_a_hyphen_in_a_word_or_a_minus_sign_still_breaks_normally():
    text = "a well-known surface at t = -0.50 and more words after it"
    for width in range(40, 600, 5):
        lines = wrap(text, "sans", 24, width)
        assert " ".join(lines) == text
    assert any(
        line.startswith("-0.50")
        for width in range(40, 600, 5)
        for line in wrap(text, "sans", 24, width)
    )


def test_a_caption_that_fits_beside_the_gizmo_is_one_line():
    """The issue's case: this note became a narrow column of two lines at 1080p."""
    note = "Figure 15. Equal radii, only the sphere moves."
    for size in ((1920, 1080), (1280, 720), (480, 270)):
        layout = hud_layout(size, "Colliding a ball with a pipe", ("", note))
        assert layout.caption_lines == (note,)
        assert layout.title_block.x1 + layout.margin <= layout.gizmo_block.x0


@pytest.mark.parametrize("size", [(1920, 1080), (1280, 720), (1024, 768), (480, 270)])
def test_a_long_caption_takes_the_fewest_lines_of_its_measure_evened(size):
    caption = scenes.get("collision").caption * 2
    layout = hud_layout(size, "A title", (caption,))
    px = layout.body_px
    measure = max(0.42 * size[0], CAPTION_MEASURE * px)
    lines = layout.caption_lines
    assert " ".join(lines) == " ".join(caption.split())
    assert len(lines) == len(wrap(caption, "sans", px, measure)) > 1
    widths = [text_width(line, "sans", px) for line in lines]
    assert max(widths) <= measure
    assert min(widths[:-1]) > 0.8 * max(widths)  # no ragged column
    assert layout.title_block.x1 + layout.margin <= layout.gizmo_block.x0
