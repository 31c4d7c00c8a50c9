"""A review copies a timeline's recordings beside its copy of the timeline, under the names
the timeline gives them: a recording reached through a link inside the timeline's folder keeps
its name (before: copied under the link's target name, then "no such file"), and one that
leads out of the folder is not copied, as the kiosk refuses it."""

from __future__ import annotations

from pathlib import Path

from exhibit import scenes
from exhibit.narration import load_recording
from exhibit.review.player import copy_recordings
from exhibit.timelines.file import load_timeline
from tests.kiosk.support import TIMELINE as KIOSK_TIMELINE
from tests.narration.support import pcm_wav, sine

#: The kiosk tests' timeline, its first caption recorded in English and German.
TIMELINE = KIOSK_TIMELINE.replace(
    'caption = "far"\n',
    'caption = "far"\nnarration = { en = "audio/far-en.wav", de = "audio/far-de.wav" }\n',
    1,
)


def test_recordings_are_copied_under_the_names_the_timeline_gives(tmp_path):
    source, outside, attract = tmp_path / "site", tmp_path / "elsewhere", tmp_path / "review"
    for folder in (source / "audio" / "takes", outside, attract):
        folder.mkdir(parents=True)
    take = source / "audio" / "takes" / "far-en-take3.wav"
    take.write_bytes(pcm_wav(sine(440, 1.0, 22050), 22050))
    (source / "audio" / "far-en.wav").symlink_to("takes/far-en-take3.wav")
    (outside / "secret.wav").write_bytes(pcm_wav(sine(440, 1.0, 22050), 22050))
    (source / "audio" / "far-de.wav").symlink_to(outside / "secret.wav")
    path = source / "t.toml"
    path.write_text(TIMELINE)
    timeline = load_timeline(path, scenes.get)
    copy_recordings(timeline, source, attract)
    copied = attract / "audio" / "far-en.wav"
    assert load_recording(Path("audio/far-en.wav"), attract).duration == 1.0
    assert copied.read_bytes() == take.read_bytes()
    assert not (attract / "audio" / "far-de.wav").exists()
    assert not list(attract.rglob("secret.wav"))
