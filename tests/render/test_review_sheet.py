"""The contact sheet draws only the frames it keeps (issue 33): each caption's frame after the
few frames a crossfade into it needs, not the whole timeline between, and the frames it keeps
are those the whole timeline played at the same rate shows. Long jobs are refused before they
start (frames x pixels), and report their progress on stderr."""

from __future__ import annotations

import numpy as np
import pytest

from exhibit.commands._media import MAX_JOB_FRAMES
from exhibit.progress import Progress
from exhibit.review.player import KioskPlayer, lead_s, play_schedule
from exhibit.review.setup import base_config

#: A day-long timeline with one caption: the issue's case, which never finished.
DAY = """
name = "A day"
scene = "hopf"
[[keyframe]]
t = 0
caption = "Three doughnuts on the surface of a 4D ball, seen from infinitely far away in 4D."
[[keyframe]]
t = 86400
angles = [40, 0, 0, 0, 0, 0]
"""

#: Fourteen seconds, three captions, poses that change (each change a cut with reduced motion).
SHORT = """
name = "Short"
scene = "hopf"
[[keyframe]]
t = 0
caption = "one"
[[keyframe]]
t = 5
angles = [40, 0, 0, 0, 0, 0]
caption = "two"
[[keyframe]]
t = 9
angles = [80, 20, 0, 0, 0, 0]
sensor_distance = 3
caption = "three"
[[keyframe]]
t = 14
angles = [120, 20, 0, 30, 0, 0]
"""


def test_a_sheet_of_a_day_draws_a_few_frames():
    schedule = play_schedule(86400, 1, [1.5])
    assert [t for t, kept in schedule if kept] == [1.5]
    assert len(schedule) <= lead_s(1) + 2
    everything = play_schedule(86400, 1)
    assert len(everything) == 86401 and all(kept for _, kept in everything)


def test_the_lead_in_frames_lie_on_the_grid_before_each_kept_time():
    schedule = play_schedule(14, 4, [1.5, 6.5, 10.5, 10.5])
    times = [t for t, _ in schedule]
    assert times == sorted(set(times))
    assert [t for t, kept in schedule if kept] == [1.5, 6.5, 10.5]
    for t, kept in schedule:
        assert kept or (t * 4).is_integer()
    assert min(t for t in times if t > 2) == 6.5 - lead_s(4) == 5.0  # a crossfade and 2 frames


@pytest.mark.parametrize("reduced_motion", [False, True])
def test_the_kept_frames_are_those_of_the_whole_timeline(
    headless, tmp_path, monkeypatch, reduced_motion
):
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    timeline = tmp_path / "short.toml"
    timeline.write_text(SHORT)
    site = tmp_path / "site.toml"
    site.write_text(
        "[content]\nresolution = { hopf = 12 }\n"
        f"[accessibility]\nreduced_motion = {str(reduced_motion).lower()}\n"
    )
    config = base_config(site)
    fps, size = 4, (160, 90)
    with KioskPlayer(size, timeline=timeline, config=config, headless=headless) as player:
        wanted = [s.settled for s in player.captions()]
        sparse = list(player.play(fps, times=wanted))
    with KioskPlayer(size, timeline=timeline, config=config, headless=headless) as player:
        everything = {f.t: f for f in player.play(fps)}
    assert [f.t for f in sparse] == wanted == [1.5, 6.5, 10.5]
    for frame in sparse:
        whole = everything[frame.t]
        assert frame.caption == whole.caption
        assert np.array_equal(frame.image, whole.image), frame.t


def test_the_sheet_of_a_day_long_timeline_finishes(cli, tmp_path, monkeypatch):
    """Was: no sheet after 240 s (every one of 86,400 frames drawn)."""
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    timeline = tmp_path / "day.toml"
    timeline.write_text(DAY)
    site = tmp_path / "site.toml"
    site.write_text("[content]\nresolution = { hopf = 12 }\n")
    out = tmp_path / "sheet.png"
    result = cli(
        "render", "--timeline", str(timeline), "--config", str(site), "--size", "64x36",
        "--fps", "1", "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert out.exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["--timeline", "DAY", "--size", "1280x720", "--fps", "1", "--out", "frames/"],
        ["--timeline", "DAY", "--size", "64x36", "--fps", "25", "--out", "frames/"],
        ["--takeover", "collision", "--after", "600", "--fps", "120", "--out", "t.png"],
        ["--takeover", "hopf", "--after", "600", "--size", "8192x8192", "--out", "t.png"],
    ],
)
def test_jobs_over_the_limit_are_refused_before_they_start(tmp_path, capsys, monkeypatch, argv):
    from exhibit.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "day.toml").write_text(DAY)
    argv = [str(tmp_path / "day.toml") if a == "DAY" else a for a in argv]
    assert main(["render", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "over the limit" in err
    assert not (tmp_path / "frames").exists() or not any((tmp_path / "frames").iterdir())


def test_progress_lines_without_a_terminal(capsys):
    clock = iter(range(0, 1000, 4))
    with Progress(MAX_JOB_FRAMES) as progress:
        progress._clock = lambda: float(next(clock))
        progress._next = 10.0
        for _ in range(10):
            progress(10)
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"rendering: {n}/{MAX_JOB_FRAMES} frames" for n in (40, 70, 100)]
