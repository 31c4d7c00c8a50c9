"""Text no panel can hold: check-config refuses it (file: key: reason), and the renderer,
should any arrive, breaks an over-long word and shortens the panel ("…") without a GL error."""

from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.render.layout import hud_layout, text_problems
from exhibit.render.text import text_width, wrap, wrap_balanced

SHIPPED = Path(__file__).resolve().parents[2] / "configs"
WORD = "x" * 2000


def test_a_word_wider_than_the_line_is_broken_by_characters():
    for lines in (
        wrap(WORD, "sans", 20, 300, break_words=True),
        wrap_balanced(f"a {WORD} b", "sans", 20, 300, break_words=True),
    ):
        assert len(lines) > 5 and "".join(lines).replace(" ", "").count("x") == 2000
        assert all(text_width(line, "sans", 20) <= 300 for line in lines)


@pytest.mark.parametrize(
    "title, caption",
    [(WORD, ""), ("Title", WORD), ("Wort " * 400, ""), ("Zeile\n" * 300, "Zeile " * 300)],
)
def test_the_panel_is_shortened_to_stay_on_the_screen(title, caption):
    size = (1280, 720)
    layout = hud_layout(size, title, (caption,))
    block = layout.title_block
    assert block.x1 <= size[0] and block.y1 <= layout.status_block.y0
    assert (layout.caption_lines or layout.title_lines)[-1].endswith("…")


def test_normal_text_is_laid_out_as_before():
    layout = hud_layout((1280, 720), "When a ball meets a pipe", ("Closer still.",))
    assert layout.title_lines == ("When a ball meets a pipe",)
    assert layout.caption_lines == ("Closer still.",)


@pytest.mark.parametrize(
    "kind, text, fragment",
    [
        ("title", WORD, "wider than the panel's"),
        ("title", "Ein langer Titel " * 120, "more than 40% of the screen"),
        ("title", "Zeile\n" * 300, "more than 40% of the screen"),
        ("caption", WORD, "wider than the panel's"),
        ("gizmo", "4D-Achsen " * 100, "wider than the 4D axes'"),
        ("numbers", "Sensor" * 20, "of the screen"),
    ],
)
def test_text_that_does_not_fit_is_a_problem(kind, text, fragment):
    assert any(fragment in p for p in text_problems(kind, text)), text_problems(kind, text)
    assert text_problems(kind, "Kurz") == []


def _site(tmp_path, replace: dict[str, str]) -> Path:
    german = (
        (SHIPPED / "languages" / "de.toml")
        .read_text()
        .replace('language = "de"', 'language = "xx"')
    )
    for old, new in replace.items():
        assert old in german
        german = german.replace(old, new)
    (tmp_path / "languages").mkdir()
    (tmp_path / "languages" / "xx.toml").write_text(german)
    site = tmp_path / "kiosk.toml"
    site.write_text('[languages]\nshown = ["en", "xx"]\ncatalogues = "languages"\n')
    return site


def test_check_config_refuses_translations_the_panels_cannot_hold(tmp_path, capsys):
    site = _site(
        tmp_path,
        {
            '"4D axes" = "4D-Achsen"': '"4D axes" = "' + "4D-Achsen " * 100 + '"',
            '"When a ball meets a pipe" = "Wenn eine Kugel auf ein Rohr trifft"': (
                '"When a ball meets a pipe" = "' + "y" * 2000 + '"'
            ),
        },
    )
    assert main(["check-config", str(site)]) == 2
    out = capsys.readouterr().out
    catalogue = tmp_path / "languages" / "xx.toml"
    assert f"{catalogue}: text.'4D axes': is " in out and "wider than the 4D axes'" in out
    assert f"{catalogue}: text.'When a ball meets a pipe': the word " in out
    assert "internal error" not in out


def test_check_config_refuses_an_english_caption_with_an_over_long_word(tmp_path, capsys):
    import shutil

    shutil.copytree(SHIPPED / "attract", tmp_path / "attract")
    timeline = tmp_path / "attract" / "04-collision-15.toml"
    text = timeline.read_text()
    first = text.index('caption = "') + len('caption = "')
    timeline.write_text(text[:first] + "z" * 1800 + " " + text[first:])
    site = tmp_path / "kiosk.toml"
    site.write_text('[attract]\ntimelines = "attract"\n')
    assert main(["check-config", str(site)]) == 2
    out = capsys.readouterr().out
    assert f"{timeline}: keyframe[" in out and "wider than the panel's" in out, out


def test_a_kiosk_frame_with_a_2000_character_word_has_no_gl_error(headless, tmp_path):
    from exhibit.kiosk import app
    from exhibit.kiosk.config import load_kiosk_config
    from tests.kiosk.support import HeadlessKiosk

    run = HeadlessKiosk(headless, tmp_path)
    run.kiosk.release()
    (tmp_path / "attract" / "torus.toml").write_text(
        f'name = "Torus"\nscene = "clifford-torus"\n[[keyframe]]\nt = 0\ncaption = "{WORD}"\n'
        "[[keyframe]]\nt = 30\nangles = [90, -40, 0, 0, 0, 0]\n"
    )
    run.kiosk = app.Kiosk(load_kiosk_config(tmp_path / "kiosk.toml"), run.target, clock=run.clock)
    try:
        run.ctx = run.target.ctx
        run.ctx.error  # noqa: B018 - clear any earlier error
        run.run(2.0)
        assert run.ctx.error == "GL_NO_ERROR"
        layout = run.target.renderer.hud.layout
        width, height = run.target.size
        block = layout.title_block
        assert block is not None and layout.caption_lines[-1].endswith("…")
        assert block.x1 <= width and block.y1 <= layout.status_block.y0
    finally:
        run.kiosk.release()
