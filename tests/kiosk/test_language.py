"""Captions in the visitor's language (exhibit/kiosk/language.py): catalogues keyed by the
English text, the kiosk switching language from a button or a timer, and check-config holding
every shown text to a translation in glyphs the font has."""

from __future__ import annotations

from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.errors import ConfigError
from exhibit.kiosk.config import load_kiosk_config
from exhibit.kiosk.language import (
    PREPARING,
    SOURCE,
    Catalogue,
    Translator,
    coverage_problems,
    load_catalogue,
)
from exhibit.render.target import Key

SHIPPED = Path(__file__).resolve().parents[2] / "configs"


def test_the_translator_cycles_and_falls_back_to_english():
    catalogues = {
        SOURCE: Catalogue(SOURCE, "English"),
        "de": Catalogue("de", "Deutsch", {"Closer still.": "Noch näher."}),
    }
    tr = Translator(catalogues, ["en", "de", "fr"])  # fr has no catalogue: not offered
    assert tr.order == ["en", "de"] and tr("Closer still.") == "Closer still."
    assert tr.next() == "de" and tr("Closer still.") == "Noch näher."
    assert tr("Not translated.") == "Not translated." and tr("") == ""
    assert tr.next() == "en"


def test_the_shipped_german_catalogue_covers_every_text_the_kiosk_shows():
    config = load_kiosk_config()
    assert config.languages == ("en", "de")
    assert coverage_problems(config) == []
    de = load_catalogue(SHIPPED / "languages" / "de.toml")
    assert de.text["When a ball meets a pipe"] == "Wenn eine Kugel auf ein Rohr trifft"
    # issue 31: a title ending in a relative clause needs no comma inside German quotes
    title = de.text["The offset of a cusp, and a circle that should not be there"]
    assert de.text[PREPARING].replace("{title}", title) == (
        "„Die Parallelkurve einer Spitze und ein Kreis, der nicht dazugehört“ wird vorbereitet …"
    )


def site(tmp_path: Path, catalogue: str, code: str = "xx", extra: str = "") -> Path:
    folder = tmp_path / "languages"
    folder.mkdir(exist_ok=True)
    (folder / f"{code}.toml").write_text(catalogue)
    path = tmp_path / "kiosk.toml"
    path.write_text(f'[languages]\nshown = ["en", "{code}"]\ncatalogues = "languages"\n{extra}')
    return path


def test_check_config_names_a_missing_translation_and_a_glyph_the_font_lacks(tmp_path, capsys):
    german = (SHIPPED / "languages" / "de.toml").read_text()
    german = german.replace('language = "de"', 'language = "xx"')
    german = german.replace('"Closer still." = "Noch näher."\n', "")
    german = german.replace('"4D axes" = "4D-Achsen"', '"4D axes" = "4D 軸"')
    path = site(tmp_path, german)
    assert main(["check-config", str(path)]) == 2
    out = capsys.readouterr().out
    catalogue = tmp_path / "languages" / "xx.toml"
    assert f"{catalogue}: text: no translation of 'Closer still.' (from " in out
    assert "01-hypersphere.toml: keyframe[" in out
    assert f"{catalogue}: text.'4D axes': the font has no glyph for '軸'" in out


@pytest.mark.parametrize(
    "catalogue, fragment",
    [
        ('language = "yy"\nname = "X"\n', "language: 'yy' does not match the file name (xx.toml)"),
        ('language = "xx"\n', "name"),
        ('language = "xx"\nname = "X"\n[text]\n"a" = 3\n', "text.a"),
        ('language = "xx"\nname = "X"\n[text]\n"a" = "b\\u0007"\n', "text.a"),
    ],
)
def test_a_broken_catalogue_is_named_by_file_and_key(tmp_path, catalogue, fragment):
    with pytest.raises(ConfigError) as info:
        load_kiosk_config(site(tmp_path, catalogue))
    assert any(
        str(tmp_path / "languages" / "xx.toml") in p and fragment in p for p in info.value.problems
    ), info.value.problems


@pytest.mark.parametrize(
    "text, key",
    [
        ('shown = ["en", "deutsch"]', "languages.shown"),
        ("switch_after_s = 1e-9", "languages.switch_after_s: must be 0 (buttons only) or at least"),
        ("switch_after_s = nan", "languages.switch_after_s"),
    ],
)
def test_the_languages_section_is_checked(tmp_path, text, key):
    path = tmp_path / "kiosk.toml"
    path.write_text(f"[languages]\n{text}\n")
    with pytest.raises(ConfigError) as info:
        load_kiosk_config(path)
    assert any(key in p for p in info.value.problems), info.value.problems


def test_the_language_button_shows_the_kiosk_in_german(headless, tmp_path):
    from tests.kiosk.support import HeadlessKiosk

    run = HeadlessKiosk(headless, tmp_path)
    run.run(0.5)
    assert run.target.drawn[3].title == "The flat doughnut"
    run.target.post(Key("l", True))
    run.target.post(Key("l", False))
    run.run(0.5)
    hud = run.target.drawn[3]
    assert run.kiosk.translate.language == "de"
    assert hud.title == "Der flache Donut" and hud.axes_label == "4D-Achsen"
    assert hud.word("sensor") == "Sensor" and hud.word("first contact") == "erste Berührung"


def test_attract_mode_changes_language_on_its_timer(headless, tmp_path):
    from tests.kiosk.support import HeadlessKiosk

    run = HeadlessKiosk(headless, tmp_path, "[languages]\nswitch_after_s = 10\n")
    run.run(9.0)
    assert run.kiosk.translate.language == "en"
    run.run(1.5)
    assert run.kiosk.translate.language == "de"
    assert run.target.drawn[3].caption == "Noch näher."  # the test timeline's caption


def test_the_health_file_says_the_language_and_the_session_writer_counts(headless, tmp_path):
    import json

    from exhibit.operations.sessions import SessionLog, SessionWriter
    from tests.kiosk.support import HeadlessKiosk

    run = HeadlessKiosk(headless, tmp_path)
    writer = SessionWriter(tmp_path / "sessions.db")
    run.kiosk.sessions = SessionLog(writer)
    run.kiosk.parts.reporter.health_path = tmp_path / "health.json"
    run.target.post(Key("l", True))
    run.run(1.5)
    assert writer.ready.wait(5.0)  # recording only once the database is open
    run.kiosk.report(run.clock())
    health = json.loads((tmp_path / "health.json").read_text())
    assert health["language"] == "de" and health["sessions"]["recording"]
    assert set(health["sessions"]) >= {"written", "dropped", "failed"}
    writer.close()


def test_the_next_visitor_finds_the_museums_language(headless, tmp_path):
    """Attract mode, a visitor who takes over and switches to German, then walks away: when
    attract mode returns, so does the first language shown (English), on screen and in the
    session the visitor left (which keeps the German they read)."""
    from tests.kiosk.support import IDLE_S, HeadlessKiosk

    run = HeadlessKiosk(headless, tmp_path)
    run.run(1.0)
    assert run.frame.mode == "attract" and run.target.drawn[3].caption == "Closer still."
    for name in ("q", "l"):  # turn θ1 (the takeover), then the language key
        run.target.post(Key(name, True))
        run.target.post(Key(name, False))
        run.run(0.3)
    assert run.frame.mode == "visitor" and run.kiosk.translate.language == "de"
    assert run.target.drawn[3].title == "Der flache Donut"
    run.run(IDLE_S + 1.0)
    assert run.frame.mode == "attract"
    assert run.kiosk.translate.language == "en"
    assert run.target.drawn[3].caption == "Closer still."
    assert run.target.drawn[3].axes_label == "4D axes"


@pytest.mark.parametrize("blank", ['""', '"   "', '"\\n\\t "'])
def test_an_empty_translation_is_refused_by_its_english_key(tmp_path, capsys, blank):
    german = (
        (SHIPPED / "languages" / "de.toml")
        .read_text()
        .replace('language = "de"', 'language = "xx"')
    )
    line = '"When a ball meets a pipe" = "Wenn eine Kugel auf ein Rohr trifft"'
    assert line in german
    german = german.replace(line, f'"When a ball meets a pipe" = {blank}')
    path = site(tmp_path, german)
    assert main(["check-config", str(path)]) == 2
    out = capsys.readouterr().out
    catalogue = tmp_path / "languages" / "xx.toml"
    assert f"{catalogue}: text.'When a ball meets a pipe': the translation is empty" in out, out
    assert "internal error" not in out
