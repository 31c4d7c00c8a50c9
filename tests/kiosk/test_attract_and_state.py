"""Attract timelines and the kiosk's modes, driven by a simulated clock and events (no window)."""

import math
from pathlib import Path

import numpy as np
import pytest

from exhibit.devices.base import Event, Kind
from exhibit.devices.config import parse_config
from exhibit.devices.mapping import Mapper
from exhibit.errors import ConfigError
from exhibit import scenes
from exhibit.timelines.file import load_playlist, load_timeline
from exhibit.timelines.playlist import Playlist
from exhibit.kiosk.state import ATTRACT, VISITOR, KioskState
from tests.kiosk.support import DEVICES, TIMELINE

ATTRACT_DIR = Path(__file__).resolve().parents[2] / "configs" / "attract"


@pytest.fixture
def timeline(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text(TIMELINE)
    return load_timeline(path, scenes.get)


def test_keyframes_are_hit_and_easing_is_smooth(timeline):
    view, caption = timeline.at(0)
    assert view.angles[0] == 0 and view.sensor_r == 0 and caption == "far"
    view, caption = timeline.at(10)
    assert view.angles[0] == pytest.approx(math.pi / 2) and view.sensor_r == 0.5
    assert caption == "near"
    # smooth easing: at a quarter of the way, less than a quarter of the change
    quarter, _ = timeline.at(2.5)
    assert 0 < quarter.angles[0] < math.pi / 8
    # the sensor moves in r, so "inf" -> 2 passes r = 0.25 at the midpoint
    assert timeline.at(5)[0].sensor_r == pytest.approx(0.25)
    # linear easing on the second stretch
    assert timeline.at(15)[0].angles[1] == pytest.approx(math.radians(-15))
    assert timeline.duration == 20


def test_shipped_playlist_covers_the_papers_scenes():
    timelines = load_playlist(ATTRACT_DIR, scenes.get)
    shown = {t.scene for t in timelines}
    assert {"hopf", "offset-parabola", "offset-cusp", "collision"} <= shown
    hopf = next(t for t in timelines if t.scene == "hopf")
    distances = {round(1 / k.sensor_r, 3) if k.sensor_r else math.inf for k in hopf.keyframes}
    assert {math.inf, 3.0, 2.0} <= distances  # Figures 6, 7 and 8
    collision_params = {t.params["rs"] for t in timelines if t.scene == "collision"}
    assert collision_params == {1.0, 0.7, 1.2}  # Figures 15, 16 and 17


def test_playlist_loops(timeline):
    playlist = Playlist([timeline, timeline])
    playlist.restart(100.0)
    assert playlist.at(100.0)[2] == "far"
    assert playlist.at(100.0 + 40 + 1)[1].angles[0] == pytest.approx(timeline.at(1)[0].angles[0])


@pytest.fixture
def state(timeline):
    import tomllib

    config = parse_config(tomllib.loads(DEVICES), "<test>")
    return KioskState(
        Playlist([timeline]),
        Mapper(config.mapping),
        ("hopf", "collision"),
        idle_timeout_s=30.0,
        blend_s=2.0,
        now=0.0,
    )


def knob(t, steps=1.0):
    return Event(t, "knobs", Kind.REL, 0, steps)


def test_attract_until_input_then_the_visitor_takes_over_without_a_jump(state):
    for t in (0.0, 1.0, 4.0):
        frame = state.update([], t)
        assert frame.mode == ATTRACT
    before = state.update([], 5.0).view
    frame = state.update([knob(5.0)], 5.0)
    assert frame.mode == VISITOR and frame.scene == "hopf"
    # the first visitor frame is the attract pose plus exactly one knob step
    assert frame.view.angles[0] == pytest.approx(before.angles[0] + math.radians(5))
    assert frame.view.angles[1:] == before.angles[1:]
    assert frame.view.sensor_r == before.sensor_r
    frame = state.update([], 10.0)  # no input: the visitor's pose stays
    assert frame.mode == VISITOR and frame.view == state.frame.view


def test_idle_timeout_returns_to_attract_with_a_glide(state):
    state.update([knob(1.0)], 1.0)
    visitor_view = state.update([knob(2.0, 3)], 2.0).view
    assert state.update([], 31.0).mode == VISITOR  # 29 s idle
    frame = state.update([], 32.5)  # 30.5 s idle
    assert frame.mode == ATTRACT
    assert frame.view.angles == pytest.approx(visitor_view.angles)  # starts where the visitor left
    later = state.update([], 35.0)  # after blend_s, the timeline itself
    assert later.view.angles[0] == pytest.approx(state.playlist.at(35.0)[1].angles[0])


def test_a_button_switches_scene_and_home_does_not(state):
    press = Event(1.0, "knobs", Kind.BUTTON, 5, 1.0)
    frame = state.update([press], 1.0)
    assert frame.mode == VISITOR and frame.scene == "collision"
    frame = state.update([Event(2.0, "knobs", Kind.BUTTON, 5, 1.0)], 2.0)
    assert frame.scene == "hopf"
    home = Event(3.0, "knobs", Kind.BUTTON, 0, 1.0)
    frame = state.update([home], 3.0)
    assert frame.scene == "hopf" and frame.view.angles == (0.0,) * 6


def test_a_takeover_glides_the_picture_into_the_visitors_free_area(timeline):
    """The visitor's caption replaces the timeline's: the pose stays (no jump), and the zoom
    and lens shift glide over REFRAME_S to the framing of that pose for the scene's panels,
    then stay while the visitor turns the knobs."""
    import tomllib
    from exhibit.kiosk.state import REFRAME_S

    config = parse_config(tomllib.loads(DEVICES), "<test>")
    asked = []

    def framer(name, params, view):
        asked.append(view.angles)
        return view.replace(half_height=4.0 * view.half_height, center=(0.5, -0.25))

    state = KioskState(
        Playlist([timeline]),
        Mapper(config.mapping),
        ("hopf",),
        idle_timeout_s=30.0,
        blend_s=2.0,
        now=0.0,
        framer=framer,
    )
    before = state.update([], 5.0).view
    first = state.update([knob(5.0)], 5.0)
    assert first.mode == VISITOR and not first.cut
    assert asked[-1] == pytest.approx(first.view.angles)  # framed at the pose taken over
    assert first.view.half_height == pytest.approx(before.half_height)
    middle = state.update([], 5.0 + REFRAME_S / 2).view
    assert before.half_height < middle.half_height < 4.0 * before.half_height
    assert 0.0 < middle.center[0] < 0.5
    done = state.update([knob(5.0 + REFRAME_S, 2)], 5.0 + REFRAME_S).view
    assert done.half_height == pytest.approx(4.0 * before.half_height)
    assert done.center == (0.5, -0.25)
    later = state.update([knob(9.0, 3)], 9.0).view  # turning keeps the new framing
    assert later.half_height == done.half_height and later.center == done.center
    assert later.angles[0] != done.angles[0]


def test_noise_free_idle_means_attract_forever(state):
    for t in range(0, 300, 7):
        assert state.update([], float(t)).mode == ATTRACT


def test_home_returns_to_the_scenes_own_start_view_framed(timeline):
    """Home is the scene on screen's start view (through the kiosk's framer), not all angles 0;
    the jump there is a cut, so the kiosk crossfades."""
    import tomllib
    from exhibit import scenes

    config = parse_config(tomllib.loads(DEVICES), "<test>")

    def framer(name, params, view):
        return view.replace(half_height=7.0, center=(0.5, -0.25))

    state = KioskState(
        Playlist([timeline]),
        Mapper(config.mapping),
        ("hopf", "collision"),
        idle_timeout_s=30.0,
        blend_s=2.0,
        now=0.0,
        framer=framer,
    )
    frame = state.update([Event(1.0, "knobs", Kind.BUTTON, 5, 1.0)], 1.0)
    assert frame.scene == "collision" and frame.cut
    collision = scenes.get("collision").view
    assert frame.view == framer("collision", (), collision)  # the next scene starts framed
    turned = state.update([knob(2.0, 4)], 2.0)
    assert not turned.cut and turned.view.angles != collision.angles
    home = state.update([Event(3.0, "knobs", Kind.BUTTON, 0, 1.0)], 3.0)
    assert home.scene == "collision" and home.cut
    assert home.view.angles == collision.angles and home.view.angles != (0.0,) * 6
    assert home.view.half_height == 7.0 and home.view.center == (0.5, -0.25)


def test_cuts_mark_every_discontinuity_and_nothing_else(tmp_path, timeline):
    """Timeline to timeline, the playlist looping, a scene switch: cut (crossfaded). Playing on,
    the visitor taking over, and a glide back into the same scene: not cut."""
    import tomllib

    other = tmp_path / "other.toml"
    other.write_text(TIMELINE.replace('scene = "hopf"', 'scene = "offset-cusp"'))
    config = parse_config(tomllib.loads(DEVICES), "<test>")
    state = KioskState(
        Playlist([timeline, load_timeline(other, scenes.get)]),
        Mapper(config.mapping),
        ("hopf", "collision"),
        idle_timeout_s=30.0,
        blend_s=2.0,
        now=0.0,
    )
    cuts = [t for t in range(0, 81) if state.update([], float(t)).cut]
    assert cuts == [21, 40, 61, 80]  # into the second timeline, the loop, again, again
    taken = state.update([knob(81.5)], 81.5)
    assert taken.mode == VISITOR and not taken.cut
    assert not state.update([], 100.0).cut
    back = state.update([], 112.0)  # idle: the playlist starts again, on hopf
    assert back.mode == ATTRACT and back.cut == (back.scene != taken.scene)


@pytest.mark.parametrize(
    "fit, zoomed, framed",
    [
        (None, False, True),
        pytest.param(None, True, True, marks=pytest.mark.slow),  # slow: CI runs them
        pytest.param(True, True, True, marks=pytest.mark.slow),
        (False, False, False),
    ],
)
def test_timelines_are_framed_unless_they_say_fit_false(tmp_path, fit, zoomed, framed):
    """Framing by the picture (render.framer) replaces hand-set zooms too, keeping every sampled
    pose in the free area; only fit = false leaves a timeline as written."""
    from exhibit import scenes
    from exhibit.geometry.framing import mesh_sample, pixel_bounds
    from exhibit.framing.timeline_framing import frame_timeline
    from exhibit.render.framer import Framer

    text = TIMELINE.replace('scene = "hopf"', 'scene = "offset-cusp"').replace(
        "sensor_distance = 2", "sensor_distance = 6"
    )
    if fit is not None:
        text = text.replace(
            'scene = "offset-cusp"', f'scene = "offset-cusp"\nfit = {str(fit).lower()}'
        )
    if zoomed:
        text = text.replace('caption = "near"', 'caption = "near"\nhalf_height = 3.0')
    path = tmp_path / "t.toml"
    path.write_text(text)
    timeline = load_timeline(path, scenes.get)
    scene = scenes.get("offset-cusp")
    mesh = scene.build({}, 12)
    size = (1280, 720)
    framer = Framer(size)
    result = frame_timeline(framer, timeline, scene, mesh)
    assert (result is not timeline) == framed
    if not framed:
        return
    # Zoom and lens shift at each keyframe, interpolated with the view's own easing.
    assert all(c != (0.0, 0.0) for c in result.centers)
    for i, k in enumerate(result.keyframes):
        assert result.at(k.t)[0].center == pytest.approx(result.centers[i])
        assert result.at(k.t)[0].half_height == pytest.approx(k.half_height)
    middle = result.at(15.0)[0].center  # linear easing from t = 10 to 20
    assert middle == pytest.approx(
        tuple(0.5 * (a + b) for a, b in zip(result.centers[1], result.centers[2]))
    )
    areas = framer.areas(scene.title, [(k.caption,) for k in timeline.keyframes])
    points = mesh_sample(mesh)[0]  # surfaces and markers: curves may reach out
    for t in (0.0, 3.3, 10.0, 14.0, 20.0):
        x0, y0, x1, y1 = pixel_bounds(points, result.at(t)[0], size)
        assert any(
            a.x0 - 1 <= x0 and x1 <= a.x1 + 1 and a.y0 - 1 <= y0 and y1 <= a.y1 + 1 for a in areas
        ), t


@pytest.mark.parametrize(
    "size",
    [(1920, 1080), pytest.param((1280, 720), marks=pytest.mark.slow)],  # slow: CI runs it
)
def test_shipped_timelines_stay_in_the_free_area(size):
    """Every shipped timeline that is framed keeps the picture clear of its panels at every
    0.5 s of its run; the ones left alone are the curator-zoomed hypersphere only."""
    import numpy as np
    from exhibit import scenes
    from exhibit.geometry.framing import mesh_sample, pixel_bounds
    from exhibit.framing.timeline_framing import frame_timeline
    from exhibit.render.framer import Framer

    framer = Framer(size, drift=12.0)
    unframed, following, filling = [], [], []
    for timeline in load_playlist(ATTRACT_DIR, scenes.get):
        scene = scenes.get(timeline.scene)
        mesh = scene.build(timeline.params, 12)
        result = frame_timeline(framer, timeline, scene, mesh)
        if result is timeline:
            unframed.append(timeline.scene)
            continue
        if len({k.half_height for k in result.keyframes}) > 1:
            following.append(timeline.name)  # framed keyframe by keyframe
        fills = result.fills
        filling += [(timeline.scene, k.t) for k, f in zip(result.keyframes, fills) if f]
        areas = framer.areas(scene.title, [(k.caption,) for k in timeline.keyframes])
        points = mesh_sample(mesh)[0]  # surfaces and markers: curves may reach out
        for t in np.arange(0.0, timeline.duration + 0.01, 0.25):
            i = result.index_at(t)
            if fills[i] or (i + 1 < len(fills) and fills[i + 1] and t != result.keyframes[i].t):
                continue  # into, at or out of a moment that fills the world on purpose
            x0, y0, x1, y1 = pixel_bounds(points, result.at(t)[0], size)
            assert any(
                a.x0 - 1 <= x0 and x1 <= a.x1 + 1 and a.y0 - 1 <= y0 and y1 <= a.y1 + 1
                for a in areas
            ), (timeline.name, t)
    assert unframed == []
    assert following, "no timeline was framed keyframe by keyframe"
    # Figure 8's moment in the hypersphere timeline (the sensor at distance 2) is kept as written.
    assert filling == [("hopf", 30.0), ("hopf", 37.0)]


# ---------------------------------------------------------------------- the time slice

SLICED = """
scene = "collision"
params = { rc = 1.0, rs = 1.2, vc = 0.0, vs = 1.0 }
[[keyframe]]
t = 0
caption = "whole"
[[keyframe]]
t = 4
slice = -2.0
ease = "linear"
[[keyframe]]
t = 8
slice = 0.0
ease = "hold"
[[keyframe]]
t = 10
slice = "off"
"""


def test_timelines_move_the_slice_along_the_scenes_time(tmp_path):
    path = tmp_path / "sliced.toml"
    path.write_text(SLICED)
    timeline = load_timeline(path, scenes.get)
    assert timeline.slice_axis == 3  # the collision's t, the scene's own slice axis
    assert timeline.at(2.0)[0].slice_axis is None  # no slice before the first
    view = timeline.at(6.0)[0]
    assert view.slice_axis == 3 and view.slice_at == pytest.approx(-1.0)  # linear, halfway
    assert timeline.at(9.0)[0].slice_at == 0.0  # held
    assert timeline.at(10.0)[0].slice_axis is None  # "off"


PARAMS = "params = { rc = 1.0, rs = 1.2, vc = 0.0, vs = 1.0 }\n"


@pytest.mark.parametrize(
    "old, new, message",
    [
        (
            'scene = "collision"',
            'scene = "collision"\nslice_axis = "w"',
            "slice_axis: 'w' is not an axis of collision (axes: x, y, z, t)",
        ),
        (
            'scene = "collision"\n' + PARAMS,
            'scene = "hopf"\n',
            "slice_axis: keyframes slice, but hopf has no time-like axis",
        ),
        ("slice = -2.0", "slice = nan", "keyframe[1].slice"),
        ('slice = "off"', 'slice = "of"', "keyframe[3].slice"),
    ],
)
def test_a_bad_slice_is_named_by_file_and_key(tmp_path, old, new, message):
    path = tmp_path / "sliced.toml"
    assert old in SLICED
    path.write_text(SLICED.replace(old, new))
    with pytest.raises(ConfigError) as info:
        load_timeline(path, scenes.get)
    assert message in str(info.value) and str(path) in str(info.value)


def test_a_scene_without_a_time_axis_can_name_one(tmp_path):
    path = tmp_path / "hopf.toml"
    path.write_text(
        'scene = "hopf"\nslice_axis = "w"\n[[keyframe]]\nt = 0\nslice = 0.3\n[[keyframe]]\nt = 2\n'
    )
    view = load_timeline(path, scenes.get).at(1.0)[0]
    assert view.slice_axis == 3 and view.slice_at == 0.3


# ---------------------------------------------------------------------- reduced motion


def _reduced(timelines, framer=None, content=("hopf", "collision")):
    import tomllib

    config = parse_config(tomllib.loads(DEVICES), "<test>")
    extra = {} if framer is None else {"framer": framer}
    return KioskState(
        Playlist(timelines),
        Mapper(config.mapping),
        content,
        idle_timeout_s=30.0,
        blend_s=2.0,
        now=0.0,
        reduced_motion=True,
        **extra,
    )


def test_stepped_timelines_hold_the_pose_and_keep_the_slice_moving(tmp_path):
    """Reduced motion: the keyframe's pose (angles, sensor, eye, zoom) holds for its stretch,
    the slice (the collision's moment: content, not camera) still moves; the last keyframe
    only ends the last stretch."""
    path = tmp_path / "sliced.toml"
    path.write_text(
        SLICED.replace(
            "slice = -2.0\n",
            "slice = -2.0\nangles = [0, 0, 0, 0, 0, 0]"
            "\nsensor_distance = 4\neye = [10, 10]\nhalf_height = 2\n",
        ).replace(
            "slice = 0.0\n",
            "slice = 0.0\nangles = [60, 0, 0, 0, 0, 0]\n"
            "sensor_distance = 2\neye = [40, 20]\nhalf_height = 3\n",
        )
    )
    timeline = load_timeline(path, scenes.get)
    start = timeline.at(4.0, stepped=True)[0]
    for t in (4.5, 5.0, 6.0, 7.9):
        view = timeline.at(t, stepped=True)[0]
        assert view.replace(slice_at=0.0) == start.replace(slice_at=0.0)
        assert view.slice_at == pytest.approx(timeline.at(t)[0].slice_at)  # as without
        assert view.angles != timeline.at(t)[0].angles  # which glides
    assert timeline.at(6.0, stepped=True)[0].slice_at == pytest.approx(-1.0)
    assert timeline.at(8.0, stepped=True)[0] == timeline.at(8.0)[0]  # the next pose
    assert timeline.at(10.0, stepped=True) == timeline.at(9.0, stepped=True)  # not "off"'s


def test_reduced_motion_cuts_at_each_keyframe_and_the_loop(timeline):
    state = _reduced([timeline])
    frames = [state.update([], round(i * 0.1, 6)) for i in range(1, 401)]
    cuts = [round(i * 0.1, 6) for i, f in enumerate(frames, 1) if f.cut]
    steps = timeline.step_times()  # slow steps of about STEP_S, keyframe 1 among them
    assert steps == [5.0, 10.0, 15.0]
    assert cuts == [5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0]  # and the loop, again
    for a, b in zip(frames, frames[1:]):
        assert b.cut or b.view == a.view
    assert frames[0].view.angles == timeline.at(0)[0].angles
    assert frames[150].view.angles == pytest.approx(timeline.at(15.0)[0].angles)  # a step


def test_reduced_motion_returns_from_a_visitor_with_a_cut(timeline):
    state = _reduced([timeline])
    state.update([knob(1.0)], 1.0)
    state.update([knob(2.0, 3)], 2.0)
    assert state.update([], 31.0).mode == VISITOR
    frame = state.update([], 32.5)
    assert frame.mode == ATTRACT and frame.cut  # a crossfade, not a glide...
    assert frame.view == state.playlist.at(32.5, stepped=True)[1]  # ...straight into it
    assert not state.update([], 33.0).cut and state.frame.view == frame.view


def test_reduced_motion_takeover_reframes_at_once_and_knobs_turn_as_ever(timeline):
    def framer(name, params, view):
        return view.replace(half_height=4.0 * view.half_height, center=(0.5, -0.25))

    state = _reduced([timeline], framer, ("hopf",))
    before = state.update([], 5.0).view
    first = state.update([knob(5.0)], 5.0)
    assert first.mode == VISITOR and first.cut  # the reframing jumps: crossfaded
    assert first.view.half_height == pytest.approx(4.0 * before.half_height)
    assert first.view.center == (0.5, -0.25)
    assert first.view.angles[0] == pytest.approx(before.angles[0] + math.radians(5))
    turned = state.update([knob(5.1, 2)], 5.1)  # the visitor's knob: one step at a time
    assert not turned.cut
    assert turned.view.angles[0] == pytest.approx(first.view.angles[0] + math.radians(10))
    assert turned.view.half_height == first.view.half_height


def test_reduced_motion_without_timelines_turns_in_held_steps():
    from exhibit.kiosk.state import TURN_S, TURN_STEPS

    state = _reduced([])
    step = TURN_S / TURN_STEPS
    frames = [(t, state.update([], t)) for t in np.arange(0.5, 2.5 * step, 0.5)]
    cuts = [t for t, f in frames if f.cut]
    assert cuts == [step, 2 * step]
    for (_, a), (_, b) in zip(frames, frames[1:]):
        assert b.cut or b.view == a.view
    assert frames[-1][1].view.angles[0] == pytest.approx(
        frames[0][1].view.angles[0] + 2 * math.tau / TURN_STEPS
    )
