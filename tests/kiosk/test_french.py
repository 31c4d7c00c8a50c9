"""French, the third shipped language (issue 43, step 6): a language is data, its catalogue
holds its words and its voice, and check-config holds it to every text the kiosk shows."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.kiosk.config import load_kiosk_config
from exhibit.kiosk.language import PREPARING, coverage_problems, load_catalogues
from exhibit.narration import speech

SHIPPED = Path(__file__).resolve().parents[2] / "configs"


def french_site(tmp_path: Path) -> Path:
    path = tmp_path / "kiosk.toml"
    path.write_text(
        f'[languages]\nshown = ["en", "de", "fr"]\ncatalogues = "{SHIPPED / "languages"}"\n'
    )
    return path


def test_french_covers_every_text_the_kiosk_shows(tmp_path):
    config = load_kiosk_config(french_site(tmp_path))
    assert config.languages == ("en", "de", "fr")
    assert coverage_problems(config) == []
    fr = load_catalogues(config.catalogues_dir, ["fr"])["fr"]
    assert fr.name == "Français" and fr.text["When a ball meets a pipe"] == (
        "Quand une boule rencontre un tuyau"
    )
    assert fr.text[PREPARING].format(title="Le tore plat") == "« Le tore plat » en préparation…"


def test_french_has_its_voice_from_its_catalogue():
    catalogues = load_catalogues(None, ["de", "fr"])
    assert catalogues["fr"].voice == speech.Voice("fr-fr", 150)
    assert speech.voice_for("fr") == speech.Voice("fr-fr", 150)
    assert speech.voice_for("de") == speech.Voice("de", 150)


@pytest.mark.skipif(not speech.available(), reason="espeak-ng is not installed")
def test_french_is_spoken():
    sound = speech.synthesise("Le tore vert grandit bien plus que le rouge.", "fr")
    assert 1.5 < sound.duration < 8.0


def test_check_config_passes_with_french_shown(tmp_path, capsys):
    assert main(["check-config", str(french_site(tmp_path))]) == 0
    out = capsys.readouterr().out
    assert "no espeak-ng voice" not in out and ": OK " in out, out


def test_the_shipped_default_languages_stay_english_and_german():
    assert load_kiosk_config().languages == ("en", "de")


#: The word for the doughnut (torus) in each shipped language, and words that must not name it.
DOUGHNUT = {"de": ("Donut", ("Tori", "Torus")), "fr": ("tore", ("beignet", "donut"))}


@pytest.mark.parametrize("code", sorted(DOUGHNUT))
def test_each_language_names_the_doughnut_one_way(code):
    """Every text whose English names a doughnut or torus names it with the one word, in
    titles, captions, descriptions and labels alike (the German title once said "Hopf-Tori"
    where every caption and tag said "Donut")."""
    word, never = DOUGHNUT[code]
    catalogue = load_catalogues(None, [code])[code]
    for english, text in catalogue.text.items():
        if re.search(r"doughnut|tor(i|us)\b", english, re.I):
            assert word.lower() in text.lower(), (english, text)
        assert not any(w.lower() in text.lower() for w in never), (english, text)
