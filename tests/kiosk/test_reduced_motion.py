"""Reduced motion ([accessibility] reduced_motion) in the running kiosk loop: attract mode moves
in slow steps, each pose held and cut, crossfaded, to the next; the text panels do not drift.
The same
kiosk without it glides, so these tests fail without the feature."""

from __future__ import annotations

import math

import pytest

from tests.golden.kiosk_frames import FakeClock
from tests.kiosk.support import IDLE_S, FakeWindow, HeadlessKiosk, kiosk

#: The shipped 01-hypersphere timeline's keyframes after t = 0 (it lasts 56 s, then loops).
KEYFRAMES = [7.0, 15.0, 18.0, 22.0, 30.0, 37.0, 44.0]
LOOP_S = 56.0


def _camera(view):
    """What the camera shows, whatever moment a slice is at."""
    return view.replace(slice_axis=None, slice_at=0.0)


class RecordingWindow(FakeWindow):
    """A FakeWindow that keeps each frame's view, panel drift and fade, and the captures."""

    def __init__(self):
        super().__init__()
        self.views, self.drifts = [], []

    def draw(self, request):
        super().draw(request)
        self.views.append(request.view)
        self.drifts.append(request.options.hud_drift)


def play(tmp_path, monkeypatch, reduced_motion: bool, seconds: float = 60.0):
    """The kiosk (the shipped hypersphere timeline) stepped every 0.1 s of a fake clock: per
    frame its time, whether the state marked it a cut, and whether the window was asked to
    capture the outgoing picture for a crossfade."""
    clock = FakeClock(0.0)
    window = RecordingWindow()
    k, _ = kiosk(tmp_path, monkeypatch, clock=clock, window=window, reduced_motion=reduced_motion)
    window.views, window.drifts = [], []
    frames = []
    for i in range(1, round(seconds / 0.1) + 1):
        clock.t = round(i * 0.1, 6)
        captured = len(window.captured)
        k.step()
        assert k.state.frame.mode == "attract"
        frames.append((clock.t, k.state.frame.cut, len(window.captured) > captured))
    assert len(window.views) == len(frames)
    return k, window, frames


def test_reduced_motion_holds_each_pose_and_crossfades_to_the_next(tmp_path, monkeypatch):
    k, window, frames = play(tmp_path, monkeypatch, reduced_motion=True)
    assert k.config.reduced_motion
    moved = [
        t
        for (t, _, _), a, b in zip(frames[1:], window.views, window.views[1:])
        if _camera(a) != _camera(b)
    ]
    cuts = [t for t, cut, _ in frames if cut]
    # the view changes only in slow steps (the keyframes among them) and at the loop, each time
    # a cut...
    timeline = k.state.playlist.timelines[0]
    steps = [round(t, 6) for t in timeline.step_times()]
    assert moved == cuts
    assert set(KEYFRAMES) <= set(cuts) <= {*steps, LOOP_S, *(round(LOOP_S + t, 6) for t in steps)}
    assert len([t for t in cuts if t < LOOP_S]) > len(KEYFRAMES)  # steps between keyframes
    # ...that the window crossfades: the outgoing picture captured, the new one fading in
    for (t, cut, captured), fade in zip(frames, window.fades):
        assert captured == cut, t
        if cut:
            assert fade == pytest.approx(1.0), t
    # each pose held is the stepped timeline's, reached at once
    playlist = k.state.playlist
    for t in cuts:
        index = next(i for i, (ft, _, _) in enumerate(frames) if ft == t)
        want = playlist.at(t, stepped=True)[1]
        assert window.views[index].angles == pytest.approx(want.angles)
        assert window.views[index].sensor_r == pytest.approx(want.sensor_r)
    # "Now the 4D viewpoint moves closer" (7..18 s) stays true: closer a step at a time
    closer = [v.sensor_r for (t, _, _), v in zip(frames, window.views) if 7.0 <= t < 18.0]
    assert all(b >= a for a, b in zip(closer, closer[1:])) and closer[-1] > closer[0]
    # the text panels hold still
    assert set(window.drifts) == {(0.0, 0.0)}


def test_without_reduced_motion_the_same_timeline_glides(tmp_path, monkeypatch):
    k, window, frames = play(tmp_path, monkeypatch, reduced_motion=False)
    assert not k.config.reduced_motion
    moved = [
        t
        for (t, cut, _), a, b in zip(frames[1:], window.views, window.views[1:])
        if _camera(a) != _camera(b) and not cut
    ]
    assert len(moved) > 400  # the camera moves between keyframes, frame after frame
    assert [t for t, cut, _ in frames if cut] == [LOOP_S]
    assert len(set(window.drifts)) > 100  # and the panels drift (burn-in care)


def test_a_visitor_still_turns_smoothly_and_the_return_is_a_cut(headless, tmp_path):
    """The real kiosk on the headless renderer: a held key turns θ1 a little every frame (as
    without reduced motion); the takeover's reframing and the idle return are crossfaded cuts;
    nothing drifts."""
    loop = HeadlessKiosk(headless, tmp_path, "[accessibility]\nreduced_motion = true\n")
    from exhibit.render.target import Key

    loop.run(1.0)
    held = loop.frame.view
    loop.run(1.0)
    assert loop.frame.view == held and loop.frame.mode == "attract"  # the pose is held
    loop.target.post(Key("q", True))
    turns = []
    for _ in range(10):
        before = loop.frame.view.angles[0]
        loop.run(0.1)
        turns.append(loop.frame.view.angles[0] - before)
    loop.target.post(Key("q", False))
    assert loop.frame.mode == "visitor"
    steady = turns[2:]  # a held key's rate, frame after frame: small, even steps
    assert all(0 < d < math.radians(20) for d in steady), turns
    assert max(steady) - min(steady) < 1e-6, turns
    left = loop.frame.view
    frames = []
    for _ in range(round((IDLE_S + 1.0) / 0.1)):
        loop.run(0.1)
        frames.append((loop.frame, loop.kiosk._fade_start, loop.clock.t))
    i = next(i for i, (f, _, _) in enumerate(frames) if f.mode == "attract")
    (frame, fade_start, t), previous = frames[i], frames[i - 1][0]
    # the first attract frame is a cut, crossfaded, straight into the timeline's held pose
    assert previous.mode == "visitor" and frame.cut and fade_start == t
    assert frame.view.angles != left.angles
    assert all(f.view == frame.view and not f.cut for f, _, _ in frames[i + 1 :])
    assert loop.target.drawn[2].hud_drift == (0.0, 0.0)
    loop.kiosk.devices.close()
