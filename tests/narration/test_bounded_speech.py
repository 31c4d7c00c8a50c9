"""A hung espeak-ng (issue 40, item 5): check-config, prepare, a narrated review and the kiosk
wait for it once, at most exhibit.tools.ESPEAK_CALL_S, then skip the rest of the run's segments
at once, saying so on one line that names the engine; and no espeak-ng outlives the command or
the kiosk that started it, however that ends.

The engine is a fake espeak-ng on PATH (where speech.py looks it up) that writes its pid and
sleeps; limits are made small through exhibit.tools; time bounds are 10 times generous."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from exhibit import tools
from exhibit.cli import main
from tests.processes import alive, outlived

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
TIMELINE = """scene = "clifford-torus"
[[keyframe]]
t = 0
caption = "A torus that never stretches."
describe = "A ring in the middle of the screen."
[[keyframe]]
t = 20
caption = "Only its shadow does."
[[keyframe]]
t = 40
caption = "Watch the shadow fold."
[[keyframe]]
t = 60
"""
#: Answers --version (so the hang is in speaking), hangs on everything else.
HANGS = """case "$1" in
--version) echo "eSpeak NG text-to-speech: 9.99  Data at: nowhere";;
*) echo $$ >> "{pids}"; exec sleep 1000;;
esac"""


@pytest.fixture
def site(tmp_path, monkeypatch):
    """A site of one timeline, three spoken segments in English, a fresh speech cache, and a
    hanging espeak-ng first on PATH; its pids in ``tmp_path/pids`` (killed at the end)."""
    tree = tmp_path / "configs"
    shutil.copytree(CONFIGS, tree)
    for old in (tree / "attract").glob("*.toml"):
        old.unlink()
    (tree / "attract" / "01-torus.toml").write_text(TIMELINE)
    kiosk = tree / "kiosk.toml"
    kiosk.write_text(kiosk.read_text().replace('shown = ["en", "de"]', 'shown = ["en"]'))
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake = bin_dir / "espeak-ng"
    fake.write_text("#!/bin/sh\n" + HANGS.format(pids=tmp_path / "pids") + "\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(tools, "ESPEAK_CALL_S", 0.5)
    yield kiosk
    record = tmp_path / "pids"
    for pid in map(int, record.read_text().split()) if record.exists() else ():
        if alive(pid):
            os.kill(pid, signal.SIGKILL)


def test_check_config_waits_once_and_says_which_tool_hangs(site, capsys):
    begun = time.monotonic()
    assert main(["check-config", str(site)]) == 2
    took = time.monotonic() - begun
    out = capsys.readouterr().out.splitlines()
    assert out == [
        f"{site.parent / 'attract' / '01-torus.toml'}: keyframe[0]: narration (en): espeak-ng "
        "did not answer within 0.5 s (speaking 'A ring in the middle of the screen. A...'); "
        "speech skipped for 2 more segments",
        "1 problem(s) found.",
    ]
    assert took < 60  # the config's own checks and one limit, not a limit a segment for ever
    assert len((site.parents[1] / "pids").read_text().split()) == 1  # asked once


def test_prepare_reports_the_hang_once(site, capsys, monkeypatch):
    from exhibit.commands import prepare

    monkeypatch.setattr(prepare, "scene_jobs", lambda *args: [])  # the speech part alone
    assert main(["prepare", "--config", str(site)]) == 1
    out = capsys.readouterr().out
    assert "narration: 0 of 3 segments ready" in out
    (line,) = [line for line in out.splitlines() if "espeak-ng" in line]
    assert line.strip().endswith(
        "keyframe[0] (en): espeak-ng did not answer within 0.5 s (speaking 'A ring in the "
        "middle of the screen. A...'); speech skipped for 2 more segments"
    )
    assert main(["prepare", "--config", str(site), "--json"]) == 1
    narration = __import__("json").loads(capsys.readouterr().out)["narration"]
    assert narration["skipped"] == 2 and len(narration["failed"]) == 1


def test_the_kiosk_skips_the_rest_after_a_hang(site):
    """The kiosk's narrator (no total: it runs for weeks) waits once, then fails fast."""
    from exhibit import scenes
    from exhibit.timelines.file import load_timeline
    from exhibit.kiosk.narrator import Narrator

    timeline = load_timeline(site.parent / "attract" / "01-torus.toml", scenes.get)
    narrator = Narrator([timeline], ["en"], lambda text, code: text, Player(), background=False)
    begun = time.monotonic()
    for t in (0, 20, 40):
        narrator.speak_timeline(timeline, t, "en", now=float(t))
    assert time.monotonic() - begun < 5.0
    assert narrator.failures() == [
        f"{timeline.path} #0 (en): espeak-ng did not answer within 0.5 s (speaking 'A ring in "
        "the middle of the screen. A...'); speech skipped for 2 more segments"
    ]
    assert len(narrator.status()["failed"]) == 3  # the health file still names each


class Player:
    playing = False

    def play(self, sound) -> None: ...
    def stop(self) -> None: ...
    def status(self) -> dict:
        return {}

    def close(self) -> None: ...


KIOSK = """
import sys, time
from exhibit import scenes
from exhibit.timelines.file import load_timeline
from exhibit.kiosk.narrator import Narrator

class Player:
    playing = False
    def play(self, sound): pass
    def stop(self): pass
    def status(self): return {}
    def close(self): pass

timeline = load_timeline(sys.argv[1], scenes.get)
# attract = True: the worker thread makes every segment's sound from the start
Narrator([timeline], ["en"], lambda text, code: text, Player(), attract=True)
time.sleep(1000)
"""


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
@pytest.mark.parametrize("who", ["kiosk", "check-config"])
def test_no_espeak_outlives_the_kiosk_or_the_command(site, sig, who):
    """Killed while espeak-ng speaks (hung), the kiosk's narration worker or check-config
    leaves no espeak-ng behind."""
    if who == "kiosk":
        command = [sys.executable, "-c", KIOSK, str(site.parent / "attract" / "01-torus.toml")]
    else:
        command = [sys.executable, "-m", "exhibit", "check-config", str(site)]
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": str(root)}
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, cwd=root)
    left = outlived(process, site.parents[1] / "pids", sig)
    assert left is None, f"espeak-ng (pid {left}) outlived {who} ({sig.name})"


def test_a_review_has_a_total_and_the_kiosk_none(site):
    """A narrated review (a command) gets a total for its speech; the kiosk, which runs for
    weeks, only the limit a call."""
    from exhibit.kiosk.config import load_kiosk_config
    from exhibit.kiosk.narrator import Narrator, for_kiosk

    review = for_kiosk(load_kiosk_config(site), [], lambda text, code: text, player=Player())
    assert review.budget.total_s == tools.SPEECH_TOTAL_S
    assert review.budget.call_s == tools.ESPEAK_CALL_S == 0.5
    kiosk = Narrator([], ["en"], lambda text, code: text, Player(), background=True)
    assert kiosk.budget.total_s is None and kiosk.budget.call_s == 0.5
