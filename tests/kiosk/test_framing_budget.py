"""Framing an attract timeline costs a fixed budget whatever its length: a day-long stretch or
thousands of keyframes must not keep the kiosk from its first frame."""

import pytest

from exhibit import scenes
from exhibit.framing import timeline_framing as framing
from exhibit.timelines.file import load_timeline
from exhibit.render.framer import Framer

HEAD = 'name = "hostile"\nscene = "collision"\npreset = "figure-15"\n'
#: Poses framing may sample (framing.MAX_POSES), with room for the few checks around them.
BUDGET = 450


@pytest.fixture(scope="module")
def mesh():
    scene = scenes.get("collision")
    return scene, scene.build(scene.resolve(scene.preset("figure-15").params), 12)


@pytest.fixture
def counted(monkeypatch):
    """framing's sample_bounds, counted; past the budget it stops the test at once (the old
    code sampled a day-long timeline 172,800 times)."""
    calls = []
    real = framing.sample_bounds

    def sample_bounds(points, view):
        calls.append(view)
        if len(calls) > BUDGET:
            raise AssertionError(f"framing sampled more than {BUDGET} poses")
        return real(points, view)

    monkeypatch.setattr(framing, "sample_bounds", sample_bounds)
    return calls


def day_long(tmp_path):
    path = tmp_path / "day.toml"
    path.write_text(
        HEAD + '\n[[keyframe]]\nt = 0\nslice = -2\ncaption = "start"\n'
        "\n[[keyframe]]\nt = 86400\nslice = 2\nangles = [40, 0, 0, 0, 0, 0]\n"
    )
    return load_timeline(path, scenes.get)


def many_keyframes(tmp_path, n=2000, captions=True):
    body = "".join(
        f"\n[[keyframe]]\nt = {5 * i}\n"
        + (f'caption = "caption number {i} here"\nslice = {(-1) ** i}\n' if captions else "")
        for i in range(n)
    )
    path = tmp_path / "many.toml"
    path.write_text(HEAD + body)
    return load_timeline(path, scenes.get)


@pytest.mark.parametrize(
    "make", [day_long, many_keyframes, lambda p: many_keyframes(p, 3000, captions=False)]
)
def test_a_hostile_timeline_is_framed_within_the_budget(tmp_path, mesh, counted, make):
    scene, built = mesh
    timeline = make(tmp_path)
    result = framing.frame_timeline(Framer((1280, 720)), timeline, scene, built)
    assert len(counted) <= BUDGET
    assert isinstance(result, framing.FramedTimeline)
    assert len(result.keyframes) == len(timeline.keyframes)


def test_sample_times_spread_over_the_timeline_keyframes_first(tmp_path):
    timeline = many_keyframes(tmp_path, 1000, captions=False)
    times = framing.sample_times(timeline)
    assert len(times) <= framing.MAX_POSES
    assert times[0] == 0 and times[-1] == timeline.duration
    keys = {k.t for k in timeline.keyframes}
    assert len(keys & set(times)) >= framing.MAX_KEYFRAME_POSES - 1
    gaps = [b - a for a, b in zip(times, times[1:])]
    assert max(gaps) <= 2.5 * timeline.duration / framing.MAX_POSES


def test_short_timelines_sample_every_half_second_and_every_keyframe(tmp_path):
    from tests.kiosk.support import TIMELINE

    path = tmp_path / "t.toml"
    path.write_text(TIMELINE)
    timeline = load_timeline(path, scenes.get)
    times = framing.sample_times(timeline)
    assert times == sorted(
        {
            *(0.5 * i for i in range(int(2 * timeline.duration))),
            *(k.t for k in timeline.keyframes),
            timeline.duration,
        }
    )


def test_poses_are_the_timelines_own(tmp_path, mesh):
    """The O(log n) lookup framing samples with gives Timeline.at's view exactly, framed or
    not, at keyframes, between them and past the ends."""
    scene, built = mesh
    timeline = many_keyframes(tmp_path, 40)
    framed = framing.frame_timeline(Framer((1280, 720)), timeline, scene, built)
    for t in (-1.0, 0.0, 2.5, 5.0, 7.3, 99.9, 100.0, 195.0, 196.0, 1e9):
        for tl in (timeline, framed):
            assert framing._Poses(tl)(t) == tl.at(t)[0], t
