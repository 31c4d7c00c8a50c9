"""docs/KIOSK.md's "add a language" steps, run literally (read from the doc), and a site's
catalogue adding to the shipped one line by line (issue 43, step 6)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from exhibit.kiosk.language import load_catalogues

ROOT = Path(__file__).resolve().parents[2]


def steps() -> str:
    """The ```sh block after "To add a language" in docs/KIOSK.md."""
    doc = (ROOT / "docs" / "KIOSK.md").read_text(encoding="utf-8")
    after = doc[doc.index("To add a language") :]
    found = re.search(r"```sh\n(.*?)```", after, re.S)
    assert found, "KIOSK.md: no ```sh block after 'To add a language'"
    return found.group(1)


def test_the_add_a_language_steps_run_as_written(tmp_path):
    script = steps()
    assert "exhibit check-config" in script
    bin_dir = Path(sys.executable).parent
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"}
    env.pop("EXHIBIT_CONFIG", None)
    done = subprocess.run(
        ["bash", "-e", "-c", script],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    out = done.stdout + done.stderr
    # a new language: check-config lists what is left to translate, in the new file, by name
    assert done.returncode == 2, out
    assert "languages/it.toml: text: no translation of 'Closer still.'" in out, out
    assert "no translation of 'When a ball meets a pipe'" not in out, out
    assert "voice" not in out, out
    it = load_catalogues(tmp_path / "languages", ["it"])["it"]
    assert it.voice.name == "it" and it.name == "Italiano"


def test_a_site_catalogue_adds_its_lines_to_the_shipped_one(tmp_path):
    folder = tmp_path / "languages"
    folder.mkdir()
    (folder / "de.toml").write_text(
        'language = "de"\nname = "Deutsch"\n[voice]\nrate_wpm = 170\n[text]\n'
        '"A new caption." = "Eine neue Bildunterschrift."\n'
        '"Closer still." = "Noch viel näher."\n'
    )
    de = load_catalogues(folder, ["de"])["de"]
    shipped = load_catalogues(ROOT / "configs" / "languages", ["de"])["de"]
    assert de.text["A new caption."] == "Eine neue Bildunterschrift."
    assert de.text["Closer still."] == "Noch viel näher."  # the site's line wins
    assert de.text["When a ball meets a pipe"] == "Wenn eine Kugel auf ein Rohr trifft"
    assert set(de.text) == set(shipped.text) | {"A new caption."}
    assert (de.voice.name, de.voice.rate_wpm) == ("de", 170)  # [voice] key by key
    assert de.path == folder / "de.toml"
