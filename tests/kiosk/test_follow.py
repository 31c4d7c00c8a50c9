"""The framing follows a visitor's picture (exhibit.framing.follow): the offset parabola turned
with the knobs stays in the free area with a fair share of it, the zoom and lens shift glide
without jumps, the visitor's angles and sensor are exactly what they turned, the sensor driven
in keeps its zoom, and with reduced motion the framing moves only in rare cuts. The state
machine on a fake clock with the real framer and mesh (no GL, no wall clock)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest

from exhibit import scenes
from exhibit.devices.base import Event, Kind
from exhibit.devices.config import parse_config
from exhibit.devices.mapping import Mapper
from exhibit.geometry.framing import mesh_sample, sample_bounds, to_pixels
from exhibit.framing import follow
from exhibit.timelines.file import load_timeline
from exhibit.timelines.playlist import Playlist
from exhibit.framing.follow import Aims
from exhibit.framing.start_views import StartViews
from exhibit.framing.timeline_framing import frame_timeline
from exhibit.kiosk.state import REFRAME_S, VISITOR, KioskState
from exhibit.render.framer import Framer

ROOT = Path(__file__).resolve().parents[2]
SCENE = "offset-parabola"
SIZE = (1280, 720)
STEP = 0.1  # seconds of fake time per frame
KNOBS = "\n".join(
    f'[[mapping.bind]]\ndevice = "knobs"\ninput = "delta {i}"\nparam = "theta{i}"\nstep = 5'
    for i in range(1, 7)
)
DEVICES = f"""
[devices.knobs]
url = "keyboard://"
{KNOBS}
[[mapping.bind]]
device = "knobs"
input = "delta 7"
param = "sensor"
step = 0.025
"""


class Content:
    """The one mesh the framing measures (Content.mesh's part)."""

    def __init__(self, mesh):
        self._mesh = mesh

    def mesh(self, name, params):
        return self._mesh if name == SCENE else None


@pytest.fixture(scope="module")
def world():
    scene = scenes.get(SCENE)
    mesh = scene.build(scene.resolve(), 24)
    framer = Framer(SIZE)
    timeline = load_timeline(ROOT / "configs" / "attract" / "02-offset-parabola.toml", scenes.get)
    timeline = frame_timeline(framer, timeline, scene, mesh)  # as the kiosk shows it
    return framer, Content(mesh), mesh_sample(mesh), timeline


def make_state(world, followed=True, reduced_motion=False):
    framer, content, _, timeline = world
    config = parse_config(tomllib.loads(DEVICES), "<test>")
    return KioskState(
        Playlist([timeline]),
        Mapper(config.mapping),
        (SCENE,),
        idle_timeout_s=600.0,
        blend_s=2.0,
        now=0.0,
        framer=StartViews(framer, content),
        reduced_motion=reduced_motion,
        follow=Aims(framer, content) if followed else None,
    )


def turn(state, knob: int, detents: int, start: float, rest_s: float = 0.0, steps: float = 1.0):
    """``detents`` knob detents, one a frame from ``start``, then ``rest_s`` without input:
    the frames, each (time, frame)."""
    frames = []
    t = start
    for _ in range(detents):
        t = round(t + STEP, 6)
        frames.append((t, state.update([Event(t, "knobs", Kind.REL, knob - 1, steps)], t)))
    for _ in range(round(rest_s / STEP)):
        t = round(t + STEP, 6)
        frames.append((t, state.update([], t)))
    return frames


def placement(world, view):
    """(how far the picture lies outside the best free rectangle, as a fraction of the screen
    height; the share of that rectangle it takes, the larger of width and height)."""
    framer, _, sample, _ = world
    x0, y0, x1, y1 = to_pixels(sample_bounds(sample, view), view, SIZE)
    best = None
    for a in Aims(framer, None).areas(SCENE):
        out = max(a.x0 - x0, a.y0 - y0, x1 - a.x1, y1 - a.y1, 0.0) / SIZE[1]
        share = max((x1 - x0) / a.width, (y1 - y0) / a.height)
        if best is None or (out, -share) < (best[0], -best[1]):
            best = (out, share)
    return best


def take_over(state):
    """Attract mode for 3 s, then one detent of θ1: the visitor's, the takeover's glide done."""
    for t in (1.0, 2.0, 3.0):
        state.update([], t)
    taken = turn(state, 1, 1, 3.0 - STEP)[-1][1]
    assert taken.mode == VISITOR
    return taken


def expected(angles, knob: int, detents: int):
    """The angles after ``detents`` detents of ``knob``, as the mapping turns them alone."""
    angles = list(angles)
    for _ in range(detents):
        a = math.remainder(angles[knob - 1] + math.radians(5), 2 * math.pi)
        angles[knob - 1] = math.pi if a == -math.pi else a
    return tuple(angles)


@pytest.mark.parametrize("knob, detents", [(1, 24), (1, 36), (2, 36), (2, 48), (3, 48)])
def test_turning_keeps_the_picture_in_the_free_area(world, knob, detents):
    """A visitor holds a knob for seconds (5 degrees a frame, 50 degrees a second of fake
    time), then lets go: once the glide has caught up the picture is inside the free area
    with a fair share of it; without following, θ1 and θ2 take it off the screen."""
    state = make_state(world)
    take_over(state)
    turn(state, 1, 0, 3.0, rest_s=REFRAME_S)  # the takeover's own glide
    start = state.frame.view
    frames = turn(state, knob, detents, 3.0 + REFRAME_S, rest_s=4.0)
    view = frames[-1][1].view
    # the visitor's pose is exactly what they turned: angles, sensor, eye
    assert view.angles == expected(start.angles, knob, detents)
    assert view.replace(angles=start.angles, half_height=1.0, center=(0.0, 0.0)) == start.replace(
        half_height=1.0, center=(0.0, 0.0)
    )
    out, share = placement(world, view)
    assert out <= 0.02 and share >= 0.25, (out, share)
    # while turning, the picture never strays far
    assert max(placement(world, f.view)[0] for _, f in frames) < 0.2
    # no jumps: the zoom and the lens shift change at most at their rates
    views = [start] + [f.view for _, f in frames]
    for a, b in zip(views, views[1:]):
        assert abs(math.log(b.half_height / a.half_height)) <= follow.ZOOM_RATE * STEP * 1.0001
        shift = math.dist(a.center, b.center)
        assert shift <= follow.SHIFT_RATE * a.half_height * STEP * 1.0001
    # the same turn without following: off the free area for θ1 and θ2 (the bug this fixes)
    fixed = make_state(world, followed=False)
    take_over(fixed)
    turn(fixed, 1, 0, 3.0, rest_s=REFRAME_S)
    unfollowed = turn(fixed, knob, detents, 3.0 + REFRAME_S, rest_s=4.0)[-1][1].view
    assert unfollowed.angles == view.angles
    if knob in (1, 2):
        assert placement(world, unfollowed)[0] > 0.15


def test_the_sensor_driven_in_keeps_its_zoom(world):
    """Driving the sensor in makes the picture grow: the zoom never goes out to undo it
    (the lens shift may follow); backing out again, the picture is framed as before."""
    state = make_state(world)
    take_over(state)
    start = turn(state, 1, 0, 3.0, rest_s=REFRAME_S + 3.0)[-1][1].view
    near = turn(state, 7, 20, 7.0, rest_s=3.0)  # 20 detents: from infinity to distance 2
    for _, f in near:
        assert f.view.half_height <= start.half_height * 1.0001
    assert near[-1][1].view.sensor_r == pytest.approx(20 * 0.025)
    assert placement(world, near[-1][1].view)[1] > 1.2  # larger than the free area: approached
    back = turn(state, 7, 20, 12.0, rest_s=4.0, steps=-1.0)[-1][1].view
    assert back.sensor_r == 0.0
    out, share = placement(world, back)
    assert out <= 0.02 and share >= 0.25


def test_reduced_motion_moves_the_framing_in_rare_cuts(world):
    """With reduced motion the framing never glides: it holds while the visitor turns, and
    once they rest for PAUSE_S it jumps to the fit in one step, a cut (crossfaded)."""
    state = make_state(world, reduced_motion=True)
    take_over(state)
    start = turn(state, 1, 0, 3.0, rest_s=1.0)[-1][1].view
    frames = turn(state, 1, 30, 4.0)
    assert all(
        (f.view.half_height, f.view.center) == (start.half_height, start.center) for _, f in frames
    )
    assert frames[-1][1].view.angles == expected(start.angles, 1, 30)
    assert placement(world, frames[-1][1].view)[0] > 0.15  # off the free area meanwhile
    rest = turn(state, 1, 0, 7.0, rest_s=3.0)
    moved = [
        t
        for (_, f), (t, g) in zip([frames[-1]] + rest, rest)
        if (f.view.half_height, f.view.center) != (g.view.half_height, g.view.center)
    ]
    cuts = [t for t, f in rest if f.cut]
    assert moved == cuts and len(cuts) == 1
    assert cuts[0] >= 7.0 + follow.PAUSE_S - 1e-9
    out, share = placement(world, rest[-1][1].view)
    assert out <= 0.02 and share >= 0.25
    assert rest[-1][1].view.angles == frames[-1][1].view.angles
