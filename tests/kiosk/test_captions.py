"""Captions that stay true: a keyframe's ``while`` states what its caption claims about the view,
and `exhibit check-config` plays the timeline and reports where the claim is false, or where a
caption is shown too briefly to be read."""

import shutil
from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.errors import ConfigError
from exhibit import scenes
from exhibit.timelines.file import load_playlist, load_timeline
from exhibit.timelines.captions import caption_problems, reading_time

CONFIGS = Path(__file__).resolve().parents[2] / "configs"

#: The shipped 01-hypersphere.toml as it was (issue 14), with the conditions its captions state:
#: from t = 28 to 36 "At distance 2" stays up while the sensor goes back out to infinity.
OLD_HYPERSPHERE = """
scene = "hopf"
preset = "figure-6"
[[keyframe]]
t = 0
sensor_distance = "inf"
caption = "Three doughnuts on the surface of a 4D ball, seen from far away."
while = { sensor_distance = "inf" }
[[keyframe]]
t = 6
angles = [0, 0, 0, 20, 0, 0]
caption = "Now the 4D viewpoint moves closer."
while = { sensor_motion = "closer" }
[[keyframe]]
t = 14
sensor_distance = 3
caption = "At distance 3 (Figure 7) the green doughnut has grown."
while = { sensor_distance = [2.9, 3.1] }
[[keyframe]]
t = 22
sensor_distance = 2
caption = "At distance 2 (Figure 8) green fills the world."
while = { sensor_distance = [1.9, 2.1] }
ease = "hold"
[[keyframe]]
t = 28
sensor_distance = 2
[[keyframe]]
t = 36
sensor_distance = "inf"
angles = [30, -20, -15, 0, 0, 0]
caption = "Turning in 4D."
"""


def write(tmp_path, text, name="t.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_old_hypersphere_timeline_is_caught_where_the_caption_lies(tmp_path):
    problems = caption_problems(load_timeline(write(tmp_path, OLD_HYPERSPHERE), scenes.get))
    path = tmp_path / "t.toml"
    assert problems == [
        # the last caption is shown for an instant only
        f"{path}: keyframe[5].caption: shown for 0.0 s (the timeline ends here), too short to "
        "read: 3 words need 3.0 s (0.4 s a word, at least 3 s)",
        # "At distance 3" while the sensor moves on to 2
        f"{path}: keyframe[2].while.sensor_distance: the caption is shown at t = 15.3..22.0 s "
        "with the sensor at 2..2.9, outside [2.9, 3.1]",
        # "At distance 2" while the sensor moves back out: the bug the issue reports
        f"{path}: keyframe[3].while.sensor_distance: the caption is shown at t = 29.1..36.0 s "
        "with the sensor at 2.11..inf, outside [1.9, 2.1]",
    ]


def test_motion_conditions(tmp_path):
    text = """
scene = "hopf"
[[keyframe]]
t = 0
sensor_distance = "inf"
caption = "It moves closer."
while = { sensor_motion = "%s" }
[[keyframe]]
t = 5
sensor_distance = 3
caption = "It stays."
while = { sensor_motion = "%s" }
[[keyframe]]
t = 10
"""
    assert (
        caption_problems(load_timeline(write(tmp_path, text % ("closer", "still")), scenes.get))
        == []
    )
    path = write(tmp_path, text % ("farther", "closer"))
    assert caption_problems(load_timeline(path, scenes.get)) == [
        f"{path}: keyframe[0].while.sensor_motion: the caption says 'farther', but the sensor "
        "moves closer at t = 0.0..5.0 s",
        f"{path}: keyframe[1].while.sensor_motion: the caption says the sensor moves closer, but "
        "it stays at 3 all the while (t = 5..10 s)",
    ]
    path = write(
        tmp_path, text.replace("t = 10", "t = 10\nsensor_distance = 2") % ("closer", "still")
    )
    assert caption_problems(load_timeline(path, scenes.get)) == [
        f"{path}: keyframe[1].while.sensor_motion: the caption says 'still', but the sensor "
        "moves at t = 5.0..10.0 s"
    ]


def test_a_condition_belongs_to_its_caption(tmp_path):
    """A keyframe that keeps the caption keeps its condition; a new caption without ``while``
    states none; ``while`` alone restates the condition of the caption shown."""
    text = """
scene = "hopf"
[[keyframe]]
t = 0
sensor_distance = 3
caption = "At distance 3."
while = { sensor_distance = [2.9, 3.1] }
[[keyframe]]
t = 5
[[keyframe]]
t = 10
sensor_distance = 2
caption = "Anything."
[[keyframe]]
t = 15
while = { sensor_distance = [1, 1.5] }
[[keyframe]]
t = 20
"""
    path = write(tmp_path, text)
    timeline = load_timeline(path, scenes.get)
    assert [k.caption_from for k in timeline.keyframes] == [0, 0, 2, 3, 3]
    problems = caption_problems(timeline)
    # keyframe[0]'s condition holds over 0..5 and, carried, over 5..10, where the sensor moves
    assert problems[0].startswith(
        f"{path}: keyframe[0].while.sensor_distance: the caption is shown at t = 5."
    )
    assert problems[1] == (
        f"{path}: keyframe[3].while.sensor_distance: the caption is shown at "
        "t = 15.0..20.0 s with the sensor at 2, outside [1, 1.5]"
    )
    assert len(problems) == 2


@pytest.mark.parametrize(
    "condition, key, reason",
    [
        (
            "{}",
            "keyframe[0].while",
            "states no condition: give sensor_distance, sensor_motion, angles_within, visible, "
            "absent, grows, shrinks, outgrows, fills, at or covers",
        ),
        ("{ angles_within = -1 }", "keyframe[0].while.angles_within", "must lie in [0, 180]"),
        ('{ angles_within = "start" }', "keyframe[0].while.angles_within", "must be a number"),
        (
            "{ sensor_distance = [3, 2] }",
            "keyframe[0].while.sensor_distance",
            'must be "inf" or [low, high] distances with low <= high',
        ),
        ("{ sensor_distance = 2 }", "keyframe[0].while.sensor_distance", 'must be "inf" or [low'),
        (
            "{ sensor_distance = [0, 2] }",
            "keyframe[0].while.sensor_distance",
            "item 1 must lie in [0.05, 1e+06]",
        ),
        (
            '{ sensor_motion = "nearer" }',
            "keyframe[0].while.sensor_motion",
            "must be 'closer', 'farther' or 'still'",
        ),
        (
            "{ sensor_distans = 2 }",
            "keyframe[0].while.sensor_distans",
            "unknown key (allowed: absent, angles_within, at, covers, fills, grows, outgrows, "
            "sensor_distance, sensor_motion, shrinks, visible)",
        ),
        ("3", "keyframe[0].while", "must be a table"),
    ],
)
def test_bad_conditions_name_file_key_and_reason(tmp_path, condition, key, reason):
    path = write(
        tmp_path, f'scene = "hopf"\n[[keyframe]]\nt = 0\nwhile = {condition}\n[[keyframe]]\nt = 5\n'
    )
    with pytest.raises(ConfigError) as info:
        load_timeline(path, scenes.get)
    assert any(p.startswith(f"{path}: {key}: ") and reason in p for p in info.value.problems), (
        info.value.problems
    )


def test_unknown_keyframe_keys_list_while_as_written(tmp_path):
    path = write(tmp_path, 'scene = "hopf"\n[[keyframe]]\nt = 0\nwhen = 1\n[[keyframe]]\nt = 5\n')
    with pytest.raises(ConfigError) as info:
        load_timeline(path, scenes.get)
    assert "while" in info.value.problems[0] and "while_" not in info.value.problems[0]


#: A caption about one pose ("in the plane ...") left on screen while the view turns away: the
#: shipped 02-offset-parabola.toml as it was, with the condition its first caption states.
PLANE = (
    "Lifted into 4D, the points at distance 1 from a parabola form this smooth tube; its red "
    "outline is their offset curve."
)
PLANE_CAPTION = """
scene = "offset-parabola"
preset = "figure-9"
[[keyframe]]
t = 0
angles = [0, 0, 0, 0, 0, 0]
eye = [0, -10]
caption = "{PLANE}"
while = { angles_within = 5 }
[[keyframe]]
t = 10
angles = [60, -40, -30, 0, 0, 0]
caption = "Now the tube turns in 4D."
[[keyframe]]
t = 20
""".replace("{PLANE}", PLANE)


def test_a_caption_about_one_pose_is_refused_once_the_view_turns_away(tmp_path):
    path = write(tmp_path, PLANE_CAPTION)
    assert caption_problems(load_timeline(path, scenes.get)) == [
        f"{path}: keyframe[0].while.angles_within: the caption is shown at t = 1.8..10.0 s with "
        "the view turned up to 60.0° (θ1) from keyframe[0]'s pose, more than 5°"
    ]
    # the caption changes before the view turns (it drifts 4° meanwhile): accepted
    held = PLANE_CAPTION.replace(
        """[[keyframe]]
t = 10
angles""",
        """[[keyframe]]
t = 10
eye = [4, -10]
caption = "Now the tube turns in 4D."
[[keyframe]]
t = 16
angles""",
    )
    timeline = load_timeline(write(tmp_path, held, "held.toml"), scenes.get)
    assert [k.t for k in timeline.keyframes] == [0, 10, 16, 20]
    assert caption_problems(timeline) == []


def test_angles_within_counts_from_the_stating_keyframe_and_includes_the_eye(tmp_path):
    """``while`` restated alone measures from its own keyframe's pose; the eye's azimuth and
    incidence count like the six angles."""
    text = """
scene = "hopf"
[[keyframe]]
t = 0
angles = [0, 0, 0, 0, 0, 0]
eye = [0, -60]
caption = "Seen straight on, the three doughnuts look like rings."
while = { angles_within = 3 }
[[keyframe]]
t = 5
eye = [10, -60]
[[keyframe]]
t = 10
while = { angles_within = 3 }
[[keyframe]]
t = 15
"""
    path = write(tmp_path, text)
    problems = caption_problems(load_timeline(path, scenes.get))
    # 0..10: the eye swings 10° from keyframe[0]'s; 10..15 holds still at keyframe[2]'s pose
    assert problems == [
        f"{path}: keyframe[0].while.angles_within: the caption is shown at t = 1.9..10.0 s with "
        "the view turned up to 10.0° (eye azimuth) from keyframe[0]'s pose, more than 3°"
    ]


def test_reading_time():
    assert reading_time("") == 0.0
    assert reading_time("Closer still.") == 3.0
    assert reading_time(" ".join(["word"] * 20)) == pytest.approx(8.0)


def test_shipped_timelines_keep_their_captions_true():
    timelines = load_playlist(CONFIGS / "attract", scenes.get)
    assert [p for t in timelines for p in caption_problems(t)] == []
    hopf = next(t for t in timelines if t.scene == "hopf")
    # the captions that state a distance or a motion say so
    stated = {k.caption: k.condition for k in hopf.keyframes if k.condition}
    assert len(stated) >= 5
    assert all(c.claims for c in stated.values())
    for caption, condition in stated.items():
        if "distance 2" in caption:
            assert condition.claim("sensor_distance").written == (1.9, 2.1)
    # the caption about Figure 9's view (its outline is the offset curve) holds only near it
    parabola = next(t for t in timelines if t.scene == "offset-parabola")
    plane = [k for k in parabola.keyframes if "offset curve" in k.caption.lower()]
    assert plane and all(
        k.condition and k.condition.claim("angles_within").degrees <= 5 for k in plane
    )
    assert all(a == 0 for a in plane[0].angles)


def test_check_config_reports_a_caption_that_lies(tmp_path, capsys):
    tree = tmp_path / "configs"
    shutil.copytree(CONFIGS, tree)
    for old in (tree / "attract").glob("*.toml"):
        old.unlink()
    write(tree / "attract", OLD_HYPERSPHERE, "01-hypersphere.toml")
    kiosk = tree / "kiosk.toml"  # English only: the old captions have no German (tested apart)
    kiosk.write_text(kiosk.read_text().replace('shown = ["en", "de"]', 'shown = ["en"]'))
    assert main(["check-config", str(tree / "kiosk.toml")]) == 2
    out = capsys.readouterr().out.splitlines()
    assert out[-1] == "3 problem(s) found."
    assert any(
        "01-hypersphere.toml: keyframe[3].while.sensor_distance: the caption is shown at "
        "t = 29.1..36.0 s" in line
        for line in out
    )
    assert main(["check-config"]) == 0  # the shipped timelines


def test_a_caption_held_for_a_day_is_checked_quickly(tmp_path):
    """Sampling is capped (MAX_SAMPLES a caption), so a day-long keyframe does not make
    check-config take minutes; the claim is still held to the view."""
    path = write(
        tmp_path,
        'scene = "hopf"\n[[keyframe]]\nt = 0\ncaption = "Far away."\n'
        'while = { sensor_distance = "inf" }\n[[keyframe]]\nt = 86400\n'
        "sensor_distance = 2\n",
    )
    problems = caption_problems(load_timeline(path, scenes.get))
    assert len(problems) == 1 and problems[0].startswith(
        f"{path}: keyframe[0].while.sensor_distance: the caption is shown at t = "
    )
    assert problems[0].endswith("..86400.0 s with the sensor at 2..2.67e+08, outside inf")


def test_check_config_refuses_a_plane_caption_shown_after_the_view_turned(tmp_path, capsys):
    tree = tmp_path / "configs"
    shutil.copytree(CONFIGS, tree)
    write(tree / "attract", PLANE_CAPTION, "02-offset-parabola.toml")
    assert main(["check-config", str(tree / "kiosk.toml")]) == 2
    out = capsys.readouterr().out.splitlines()
    assert out[-1] == "1 problem(s) found."
    assert any(
        line.startswith(
            f"{tree / 'attract' / '02-offset-parabola.toml'}: keyframe[0]."
            "while.angles_within: the caption is shown at t = 1.8..10.0 s"
        )
        for line in out
    ), out


def test_thousands_of_captions_are_checked_within_a_fixed_budget(tmp_path, monkeypatch):
    """A timeline of a thousand captions, each with its ``while``, costs check-config a fixed
    number of samples (MAX_SAMPLES for the whole timeline), each looked up without a scan of
    every keyframe: the old check played 100,000 poses, each scanning 1,000 keyframes."""
    from exhibit.timelines import model

    body = "".join(
        f'[[keyframe]]\nt = {5 * i}\ncaption = "Caption {i} stays still."\n'
        f'while = {{ sensor_motion = "still" }}\n'
        for i in range(1000)
    )
    body += "[[keyframe]]\nt = 5000\n"
    timeline = load_timeline(write(tmp_path, 'scene = "hopf"\n' + body), scenes.get)
    scanned = []
    real = model.Timeline.at

    def at(self, t, stepped=False):
        scanned.append(len(self.keyframes))
        if sum(scanned) > 200_000:
            raise AssertionError("the caption check scans the timeline over and over")
        return real(self, t, stepped)

    monkeypatch.setattr(model.Timeline, "at", at)
    assert caption_problems(timeline) == []
    assert len(scanned) <= 20_000 + 2 * 1000
