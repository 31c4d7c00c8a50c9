"""The renderer as a list of passes (exhibit.render.passes): each level's and option's pass list,
every pass reading only what an earlier one wrote, and the per-pass timer (exhibit.render
.pass_timer) on llvmpipe and on a faked timer-query path."""

from __future__ import annotations

from dataclasses import replace

import pytest

from exhibit import scenes
from exhibit.commands.bench.kiosk import breakdown_line, median_passes
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.pass_timer import PassTimer, PassTimes
from exhibit.render.frame_request import FrameRequest, Inset
from exhibit.render.quality import LADDER
from exhibit.render.scene_target import CLEARED

SIZE = (160, 100)
LEVELS = {q.name: q for q in LADDER}
NO_PINCH = RenderOptions(pinch_points=False)
SCENE = ["surfaces", "intersections", "outlines", "curves", "marks"]


@pytest.fixture(scope="module")
def hopf(headless):
    scene, preset = scenes.figure(6)
    gpu = headless.renderer.upload(scene.build(preset.params, 12))
    yield gpu, preset.view
    gpu.release()


def names(passes) -> list[str]:
    return [p.name for p in passes]


def frame_plan(gl, gpu, view, options: RenderOptions, level: str, sliced: bool = False):
    """A kiosk frame's plan at ``level`` (exhibit.render.frame.FramePipeline.plan): the post
    chain's passes around the scene's, as the pipeline runs them."""
    if sliced:
        view = view.replace(slice_axis=3, slice_at=0.0)
    request = FrameRequest(gpu, view, replace(options, quality=LEVELS[level]), HudInfo(title="t"))
    return gl.pipeline.plan(request, gl.target(SIZE, 0).framebuffer, SIZE)


@pytest.mark.parametrize(
    ("level", "options", "sliced", "expected"),
    [
        ("fxaa", RenderOptions(), False, SCENE),
        ("lean", RenderOptions(), False, "surfaces outlines curves marks"),
        ("direct", RenderOptions(), False, "background surfaces outlines curves marks"),
        ("direct", NO_PINCH, False, "background surfaces outlines curves"),
        ("direct", NO_PINCH, True, "background surfaces outlines curves marks"),
        ("fxaa", RenderOptions(curves=False), True, "surfaces intersections outlines marks"),
        ("fxaa", RenderOptions(silhouettes=False), False, "surfaces intersections curves"),
        ("fxaa", RenderOptions(surfaces=False), False, "outlines curves marks"),
    ],
)  # fmt: skip
def test_the_pass_list_per_level_and_option(gl, hopf, level, options, sliced, expected):
    plan = frame_plan(gl, *hopf, options, level, sliced)
    assert names(plan.scene) == (expected if isinstance(expected, list) else expected.split())
    post = names(plan.before) + ["scene"] + names(plan.after)
    if level == "direct":
        assert plan.direct and post == ["scene", "hud"]
    else:
        assert post == ["clear", "scene", "composite", "hud"]
        assert (plan.before[0].writes == CLEARED) == ("intersections" in names(plan.scene))


@pytest.mark.parametrize(
    ("level", "fade", "inset", "expected"),
    [
        ("msaa", 0.0, False, "clear scene resolve composite hud"),
        ("scale-50", 0.0, False, "clear scene composite hud"),
        ("fxaa", 0.7, True, "clear scene composite inset fade hud"),
        ("direct", 0.3, True, "scene inset fade hud"),
        ("direct", 0.0, False, "scene hud"),
    ],
)  # fmt: skip
def test_the_post_chain_per_level_crossfade_and_inset(gl, hopf, level, fade, inset, expected):
    gpu, view = hopf
    options = RenderOptions(quality=LEVELS[level])
    pipeline = gl.pipeline
    pipeline.capture(FrameRequest(gpu, view, options), SIZE)  # the crossfade's snapshot
    corner = Inset(gpu, view, (0.0, 0.0, 40.0, 30.0)) if inset else None
    request = FrameRequest(gpu, view, options, HudInfo(title="t"), fade, corner)
    plan = pipeline.plan(request, gl.target(SIZE, 0).framebuffer, SIZE)
    assert plan.unwritten_reads() == []
    assert names(plan.before) + ["scene"] + names(plan.after) == expected.split()
    bare = pipeline.plan(
        replace(request, hud=None, fade=0.0, inset=None), plan.frame.destination, SIZE
    )
    assert "hud" not in names(bare.after) and bare.frame.words is None


@pytest.mark.parametrize("level", ["msaa", "fxaa", "mesh-50", "lean", "direct", "scale-50"])
@pytest.mark.parametrize("sliced", [False, True])
@pytest.mark.parametrize(
    "options",
    [
        RenderOptions(),
        RenderOptions(surfaces=False),
        RenderOptions(silhouettes=False, curves=False),
    ],
)
def test_a_pass_reads_only_what_an_earlier_pass_wrote(gl, hopf, level, sliced, options):
    """The whole frame, post chain included: nothing is in a buffer before its first pass."""
    plan = frame_plan(gl, *hopf, options, level, sliced)
    assert plan.unwritten_reads() == []
    assert plan.after[-1].name == "hud"  # over the screen, which an earlier pass wrote
    if not plan.direct:  # the check bites: without the clear, the scene reads nothing
        assert replace(plan, before=()).unwritten_reads()
    assert replace(plan, scene=(), before=()).unwritten_reads()


def test_every_pass_declares_its_name_reads_writes_and_programs(gl):
    r = gl.renderer
    for render_pass in r.passes_for(RenderOptions(), inked=True, sliced=True):
        assert render_pass.name and isinstance(render_pass.reads, tuple)
        assert render_pass.writes and render_pass.programs
    assert {"background", "surface_depth", "floor", "intersect_gate", "silhouette_slice"} <= set(
        r.programs
    )
    p = gl.pipeline
    for post in (p.clear, p.clear_sheets, p.resolve, p.composite, p.inset, p.fade, p.hud):
        assert post.name and isinstance(post.reads, tuple) and post.writes


@pytest.mark.parametrize("level", ["fxaa", "lean", "direct"])
def test_the_timer_has_one_entry_per_pass_on_this_gl(gl, hopf, level):
    gpu, view = hopf
    r = gl.renderer
    options = RenderOptions()
    gl.draw_frame(gpu, view, SIZE, options, HudInfo(title="t"), LEVELS[level])
    before = r.pass_times
    gl.draw_frame(gpu, view, SIZE, options, HudInfo(title="t"), LEVELS[level])
    assert r.pass_times is before  # unmeasured frames leave it alone
    r.measure_next_frame()
    gl.draw_frame(gpu, view, SIZE, options, HudInfo(title="t"), LEVELS[level])
    times = r.timer.flush()
    assert times is not None and times.total_ms > 0
    assert list(times.passes) == names(frame_plan(gl, gpu, view, options, level).passes)
    assert all(ms >= 0 for ms in times.passes.values())
    if times.mode == "wall":
        assert sum(times.passes.values()) <= times.total_ms + 1e-6


class FakeQuery:
    """A GL timer query that takes 1 ms per pass, done when read."""

    def __init__(self, log: list[str]) -> None:
        self.log, self.elapsed = log, 0

    def __enter__(self) -> None:
        self.log.append("begin")

    def __exit__(self, *exc) -> None:
        self.log.append("end")
        self.elapsed = 1_000_000


class FakeContext:
    info = {"GL_RENDERER": "A Real GPU"}

    def __init__(self) -> None:
        self.log: list[str] = []
        self.made = 0

    def query(self, time: bool = False) -> FakeQuery:
        assert time
        self.made += 1
        return FakeQuery(self.log)

    def finish(self) -> None:
        self.log.append("finish")


def test_the_timer_reads_timer_queries_latency_frames_later_without_finishing():
    ctx = FakeContext()
    timer = PassTimer(ctx)  # type: ignore[arg-type]  # a fake context
    assert timer.mode == "gpu"

    def frame(measured: bool) -> None:
        if measured:
            timer.measure_next_frame()
        timer.begin_frame()
        for name in ("surfaces", "curves", "composite", "composite"):
            with timer.section(name), timer.section("nested, ignored"):
                pass
        timer.end_frame()

    frame(False)
    assert ctx.made == 0 and ctx.log == []  # unmeasured frames pay nothing
    frame(True)
    assert timer.latest is None and ctx.made == 4
    for _ in range(PassTimer.LATENCY - 1):
        frame(False)
    assert timer.latest is None  # not yet LATENCY frames old
    frame(False)
    latest = timer.latest
    assert latest == PassTimes({"surfaces": 1.0, "curves": 1.0, "composite": 2.0}, 4.0, "gpu")
    assert "finish" not in ctx.log
    frame(True)  # the queries are reused
    assert ctx.made == 4 and timer.flush() == latest


def test_the_timer_falls_back_to_wall_time_on_software_gl():
    ctx = FakeContext()
    ctx.info = {"GL_RENDERER": "llvmpipe (LLVM 15.0.6, 256 bits)"}
    ticks = iter(range(100))
    timer = PassTimer(ctx, clock=lambda: float(next(ticks)) / 1000.0)  # type: ignore[arg-type]
    assert timer.mode == "wall"
    timer.measure_next_frame()
    timer.begin_frame()
    with timer.section("surfaces"):
        pass
    with timer.section("hud"):
        pass
    timer.end_frame()
    assert ctx.made == 0 and ctx.log.count("finish") == 6
    assert timer.latest == PassTimes({"surfaces": 1.0, "hud": 1.0}, 5.0, "wall")
    assert timer.latest.other_ms == 3.0 and timer.latest.share("hud") == 0.2


def test_the_breakdown_lists_every_pass_with_its_share():
    frames = [
        PassTimes({"clear": 1.0, "surfaces": 4.0, "hud": 2.0}, 10.0),
        PassTimes({"clear": 1.0, "surfaces": 6.0, "hud": 2.0}, 12.0),
    ]
    passes, total = median_passes(frames)
    assert passes == {"clear": 1.0, "surfaces": 5.0, "hud": 2.0, "other": 3.0} and total == 11.0
    line = breakdown_line("fxaa", "hopf", passes, total)
    for name in ("clear", "surfaces", "hud", "other"):
        assert f"{name} " in line
    assert "surfaces 5.0 (45%)" in line and "frame 11.0 ms" in line


def test_the_direct_path_draws_the_same_with_the_timer_on(gl, hopf):
    """Measuring a frame changes only when it finishes, never what it draws."""
    gpu, view = hopf
    options = replace(RenderOptions(), hud=False)
    plain = gl.frame(gpu, view, SIZE, options, None, LEVELS["fxaa"])
    gl.renderer.measure_next_frame()
    timed = gl.frame(gpu, view, SIZE, options, None, LEVELS["fxaa"])
    assert (plain == timed).all()
