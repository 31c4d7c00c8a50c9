"""The health file says what a kiosk frame costs, pass by pass: one frame measured now and then
(exhibit.kiosk.frame_passes), shown by `exhibit status` and the metrics."""

from __future__ import annotations

import json

from exhibit.kiosk.frame_passes import PassSampler
from exhibit.render.pass_timer import PassTimes


class Window:
    def __init__(self):
        self.asked = 0
        self.pass_times: PassTimes | None = None

    def measure_passes(self):
        self.asked += 1


def test_one_frame_in_every_period_is_measured_and_reported_with_its_level_and_age():
    window, level = Window(), ["direct"]
    sampler = PassSampler(window, lambda: level[0], every_s=10.0)  # type: ignore[arg-type]
    assert sampler.health(0.0) is None and window.asked == 1
    assert sampler.health(5.0) is None and window.asked == 1  # not due yet, nothing measured
    window.pass_times = PassTimes({"background": 3.0, "surfaces": 5.125}, 9.0, "wall")
    level[0] = "lean"  # the level changed after the frame was asked for
    report = sampler.health(6.0)
    assert report == {
        "level": "direct",
        "mode": "wall",
        "age_s": 6.0,
        "total_ms": 9.0,
        "passes_ms": {"background": 3.0, "surfaces": 5.12},
        "other_ms": 0.88,
    }
    assert sampler.health(10.0) == {**report, "age_s": 10.0} and window.asked == 2
    window.pass_times = PassTimes({"clear": 1.0}, 2.0, "gpu")
    assert sampler.health(11.0)["level"] == "lean"


def test_the_running_kiosk_writes_its_passes_to_the_health_file(headless, tmp_path):
    from tests.kiosk.support import HeadlessKiosk

    run = HeadlessKiosk(headless, tmp_path)
    health = tmp_path / "health.json"
    run.kiosk.parts.reporter.health_path = health
    run.run(0.5)
    run.kiosk.report(run.clock())  # asks for the next frame to be measured
    run.run(0.3)
    run.kiosk.report(run.clock())
    passes = json.loads(health.read_text())["frame_passes"]
    level = run.kiosk.parts.governor.quality.name
    assert passes["level"] == level and passes["mode"] == "wall"  # llvmpipe: wall time
    names = list(passes["passes_ms"])
    assert {"surfaces", "outlines", "hud"} <= set(names), names
    assert names.index("surfaces") < names.index("outlines") < names.index("hud")
    assert all(ms >= 0 for ms in passes["passes_ms"].values())
    assert passes["total_ms"] >= sum(passes["passes_ms"].values()) - 0.05


def test_status_and_metrics_show_the_passes_and_survive_odd_values():
    from exhibit.commands.status import passes_line
    from exhibit.operations.prometheus import render

    good = {
        "level": "direct",
        "age_s": 4.0,
        "total_ms": 17.5,
        "passes_ms": {"background": 3.1, "surfaces": 5.24},
        "other_ms": 0.3,
    }
    assert passes_line(good) == (
        "direct, 4.0 s ago: background 3.1, surfaces 5.2, other 0.3 ms; frame 17.5 ms"
    )
    odd = {"level": "\x1b[2Jx", "passes_ms": {"a\nb": "fast", **{f"p{i}": 1 for i in range(99)}}}
    line = passes_line(odd)
    assert "\x1b" not in line and "\n" not in line and "a b ?" in line and "p14 1.0" in line
    assert "p15 " not in line  # at most 16 passes
    assert passes_line({"passes_ms": 7}) == "?, ? s ago: other ? ms; frame ? ms"
    metrics = render({"time": 1.0, "frame_passes": good}, "ok")
    assert 'exhibit_frame_pass_seconds{pass="surfaces"} 0.00524' in metrics
    odd_metrics = render({"time": 1.0, "frame_passes": {"passes_ms": {"x": -1, "y": "no"}}}, "ok")
    assert "exhibit_frame_pass_seconds" not in odd_metrics
