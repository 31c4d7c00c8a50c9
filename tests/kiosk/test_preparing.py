"""The first picture needs the first scene only (exhibit.preparing.preparing): the rest arrive while
it plays, in the playlist's order, a visitor's choice first; the worker process does real work,
and what it cannot do comes back as a named failure."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from exhibit import scenes
from exhibit.kiosk import app
from exhibit.preparing import jobs as jobs_module
from exhibit.preparing import process_preparer, worker_watch
from exhibit.timelines.file import load_playlist
from exhibit.timelines.playlist import Playlist
from exhibit.kiosk.config import load_kiosk_config
from exhibit.kiosk.governor import mesh_levels
from exhibit.kiosk.language import PREPARING
from exhibit.preparing.jobs import Job, run_job, scene_jobs
from exhibit.preparing.preparing import InlinePreparer
from exhibit.preparing.process_preparer import ProcessPreparer
from exhibit.render.framer import Framer
from exhibit.surfaces.mesh import Mesh4D
from tests.kiosk.support import ROOT, FakeWindow, Notifier, make_config
from tests.xvfb import xvfb


class Window(FakeWindow):
    """FakeWindow that keeps the notice screens' words and each frame's HUD."""

    def __init__(self):
        super().__init__()
        self.notice_lines, self.huds = [], []

    def notice(self, lines, drift=(0.0, 0.0)):
        super().notice(lines, drift)
        self.notice_lines.append(lines)

    def draw(self, request):
        super().draw(request)
        self.huds.append(request.hud)


def _config(tmp_path):
    """The small test config with two timelines (hopf, then the Clifford torus) and three
    content scenes, on keyboards only."""
    path = make_config(tmp_path, "")
    shutil.copy(ROOT / "configs" / "attract" / "07-gallery.toml", path.parent / "attract")
    devices = path.parent / "devices" / "default.toml"
    devices.write_text(re.sub(r'url = "sim://[^"]*"', 'url = "keyboard://"', devices.read_text()))
    text = path.read_text().replace(
        'scenes = ["hopf", "clifford-torus"]', 'scenes = ["hopf", "clifford-torus", "veronese"]'
    )
    path.write_text(text)
    return load_kiosk_config(path)


@pytest.fixture
def built(monkeypatch):
    """Meshes are strings naming scene and resolution; ``built.calls`` records each build,
    ``built.broken`` the scenes whose build raises."""
    calls, broken = [], set()

    def build(scene, params, resolution):
        calls.append((scene.name, resolution))
        if scene.name in broken:
            raise RuntimeError(f"cannot build {scene.name}")
        return f"mesh {scene.name} {resolution}", None

    monkeypatch.setattr(jobs_module, "build_cached", build)
    monkeypatch.setattr(jobs_module, "frame", lambda timeline, *rest: timeline)
    built.calls, built.broken = calls, broken
    return built


def _kiosk(tmp_path, window=None):
    ticks = iter(np.arange(1e6) * 0.1)
    return app.Kiosk(
        _config(tmp_path),
        window or Window(),
        clock=lambda: float(next(ticks)),
        notifier=Notifier(),
        health_path=tmp_path / "health.json",
        preparer=InlinePreparer,
    )


def test_the_first_frame_needs_the_first_scene_at_one_mesh_level(tmp_path, built):
    """...and nothing else is prepared until it is drawn."""
    k = _kiosk(tmp_path)
    level = k.parts.governor.quality.mesh
    assert list(k.content.meshes.gpu) == [("hopf", k.state.frame.params)]
    assert list(k.content.meshes.gpu[("hopf", k.state.frame.params)]) == [level]
    assert len(built.calls) == 1 and built.calls[0][0] == "hopf"
    assert [t.scene for t in k.state.playlist.timelines] == ["hopf"]
    assert k.window.drawn == [] and k.window.captured == [], "no warm-up before the first frame"
    k.run(max_frames=1)
    assert len(k.content.meshes.gpu) == 1 and len(built.calls) == 1


def test_the_rest_arrive_one_per_frame_in_the_playlists_order(tmp_path, built):
    k = _kiosk(tmp_path)
    k.run(max_frames=8)
    # the first scene's other levels, then the next timeline's scene, then the content list
    order = list(dict.fromkeys(name for name, _ in built.calls))
    assert order == ["hopf", "clifford-torus", "veronese"]
    assert [t.scene for t in k.state.playlist.timelines] == ["hopf", "clifford-torus"]
    assert all(
        set(levels) == set(mesh_levels(k.parts.governor))
        for levels in k.content.meshes.gpu.values()
    )
    assert k.content.prepared_at is not None and k.parts.problems == []


def test_a_timeline_that_arrives_does_not_move_the_one_playing(tmp_path, built):
    k = _kiosk(tmp_path)
    k.step()
    before = k.state.frame
    k.content.collect(k.clock(), k.parts.started)  # the rest of hopf
    k.content.collect(k.clock(), k.parts.started)  # the Clifford torus and its timeline
    assert len(k.state.playlist.timelines) == 2
    k.step()
    after = k.state.frame
    assert after.timeline == before.timeline and not after.cut


def test_warm_up_runs_one_piece_per_frame_after_the_first(tmp_path, built):
    k = _kiosk(tmp_path)
    pieces = len(k.warm.chores)
    assert pieces > len(k.parts.governor.levels)  # text panels, then the quality levels
    k.run(max_frames=1)
    assert len(k.warm.chores) == pieces
    k.run(max_frames=3)
    assert len(k.warm.chores) == pieces - 3


def test_a_visitor_who_asks_for_a_scene_not_ready_keeps_the_picture_with_a_notice(tmp_path, built):
    """Issue 31: never the dark notice screen once a picture was shown. The picture on screen
    stays, its caption giving way to what is being prepared (issue 41); that scene goes first;
    when it comes, the held picture (notice and all) crossfades into it."""
    window = Window()
    k = _kiosk(tmp_path, window)
    k.step()
    held, before = window.drawn[-1], window.huds[-1]
    keyboard = k.devices.keyboard
    keyboard.key("n", True)  # the next scene: the Clifford torus, not prepared yet
    keyboard.key("n", False)
    k.content.preparer._queue.reverse()  # it waits behind others...
    for _ in range(3):
        k.step()
        assert k.state.frame.scene == "clifford-torus" and k.waiting
        assert window.notices == 0, "not the notice screen"
        assert window.drawn[-1] == held, "the picture on screen stays"
        hud = window.huds[-1]
        title = scenes.get("clifford-torus").title
        assert hud.title == before.title, "its title stays true"
        assert hud.caption == PREPARING.replace("{title}", title)
    assert k.content.preparer._queue[0].scene == "clifford-torus", "...and goes first"
    k.content.collect(k.clock(), k.parts.started)
    k.step()
    assert not k.waiting and window.drawn[-1].startswith("mesh clifford-torus")
    assert window.captured[-1] == held and window.fades[-1] > 0.9, "a crossfade from it"
    assert window.huds[-1].note == "" and window.notices == 0


def test_with_nothing_shown_yet_the_notice_screen_says_what_is_prepared(tmp_path, built):
    window = Window()
    k = _kiosk(tmp_path, window)
    k.devices.keyboard.key("n", True)  # before the first frame
    k.devices.keyboard.key("n", False)
    k.step()
    title = scenes.get("clifford-torus").title
    assert window.notice_lines == [[PREPARING.replace("{title}", title)]] and k.waiting
    assert k.content.preparer._queue[0].scene == "clifford-torus"


class _Process:
    pid, exitcode = 4242, -9

    def __init__(self):
        self.alive, self.killed = True, False

    def is_alive(self):
        return self.alive

    def terminate(self):
        self.alive = False

    def kill(self):
        self.alive, self.killed = False, True

    def join(self, timeout=None):
        pass


class _Connection:
    def __init__(self):
        self.sent, self.closed = [], False

    def send(self, item):
        self.sent.append(item)

    def close(self):
        self.closed = True


def test_the_scene_a_visitor_waits_for_gets_a_worker_at_full_priority(monkeypatch):
    """The niced worker cannot be made un-niced again (that needs privilege): the wanted scene
    goes to an urgent worker at nice 0, started once; the first result for it counts."""
    import queue

    workers = []

    def spawn(self, nice, name):
        worker = (nice, _Process(), _Connection(), queue.SimpleQueue())
        workers.append(worker)
        return worker[1:]

    monkeypatch.setattr(ProcessPreparer, "_spawn", spawn)
    a, b, c = (Job(name, (), ((0, 8),)) for name in ("a", "b", "c"))
    p = ProcessPreparer()
    for job in (a, b, c):
        p.submit(job)
    assert p.results() == [] and len(workers) == 1
    niced, urgent = workers[0], None
    assert niced[0] == process_preparer.WORKER_NICE and niced[2].sent == [a]
    for _ in range(3):  # every frame while the visitor waits
        p.first(c.key)
    assert len(workers) == 2
    urgent = workers[1]
    assert urgent[0] == 0 and urgent[2].sent == [c]
    urgent[3].put(jobs_module.Prepared(c))
    assert [r.job for r in p.results()] == [c]
    assert urgent[2].sent == [c, None] and p.pending() == [a, b], "c is done: it leaves"
    niced[3].put(jobs_module.Prepared(a))
    assert [r.job for r in p.results()] == [a] and niced[2].sent == [a, b]
    # the niced worker is already preparing the one wanted: both go on, the first counts
    p.first(b.key)
    assert len(workers) == 3 and workers[2][2].sent == [b]
    workers[2][3].put(jobs_module.Prepared(b))
    assert [r.job for r in p.results()] == [b]
    niced[3].put(jobs_module.Prepared(b))
    assert p.results() == [], "the niced worker's late result is dropped"
    # without urgent workers: the queue's order only
    p = ProcessPreparer(urgent=False)
    for job in (a, b, c):
        p.submit(job)
    p.results()
    p.first(c.key)
    assert len(workers) == 4 and p._queue[0] is c


def test_a_scene_that_fails_later_is_left_out_and_the_visitor_moves_on(tmp_path, built):
    built.broken.add("clifford-torus")
    window = Window()
    k = _kiosk(tmp_path, window)
    k.step()
    k.devices.keyboard.key("n", True)
    k.devices.keyboard.key("n", False)
    k.step()
    assert k.state.frame.scene == "clifford-torus"
    k.run(max_frames=6)
    assert "clifford-torus" not in k.state.content
    assert k.state.frame.scene != "clifford-torus"
    assert [t.scene for t in k.state.playlist.timelines] == ["hopf"]
    assert any("scene clifford-torus skipped" in p for p in k.parts.problems)
    assert any("timeline" in p and "skipped" in p for p in k.parts.problems)


def test_a_first_scene_that_fails_hands_the_first_frame_to_the_next(tmp_path, built):
    built.broken.add("hopf")
    k = _kiosk(tmp_path)
    assert [t.scene for t in k.state.playlist.timelines] == ["clifford-torus"]
    assert "hopf" not in k.state.content and k.state.frame.scene == "clifford-torus"


@given(
    durations=st.lists(st.floats(1, 50), min_size=1, max_size=5),
    at=st.floats(0, 500),
    new=st.floats(1, 50),
    index=st.integers(0, 5),
)
@example(durations=[19.0, 1.0], at=19.0, new=45.66, index=0)  # a boundary, rounded badly
def test_playlist_insert_keeps_the_timeline_playing_where_it_is(durations, at, new, index):
    from types import SimpleNamespace

    def timeline(name, duration):
        return SimpleNamespace(name=name, duration=duration, at=lambda t, stepped=False: (t, name))

    playlist = Playlist([timeline(f"t{i}", d) for i, d in enumerate(durations)], started=0.0)
    before, offset, _ = playlist.at(at)
    playlist.insert(min(index, len(durations)), timeline("new", new), at)
    after, offset_after, _ = playlist.at(at)
    assert after is before and offset_after == pytest.approx(offset, abs=2e-6)


def test_the_worker_process_prepares_and_frames_and_names_what_fails(tmp_path, monkeypatch):
    """A real worker process (spawn): a real mesh and a framed timeline come back through the
    pipe; a scene that does not exist comes back as an error; a worker that dies is named."""
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    config = _config(tmp_path)
    timelines = load_playlist(config.attract_dir, scenes.get)
    jobs = scene_jobs(config, timelines, [2])
    framer = Framer((640, 360))
    worker = ProcessPreparer(jobs_module.Framers(framer, framer))
    try:
        worker.submit(jobs[0])
        worker.submit(Job("no-such-scene", (), ((2, 8),)))
        results = []
        for _ in range(600):
            results += worker.results()
            if len(results) == 2:
                break
            time.sleep(0.1)
        assert [r.job.scene for r in results] == ["hopf", "no-such-scene"]
        mesh = results[0].meshes[2]
        assert isinstance(mesh, Mesh4D) and mesh.triangle_count > 0
        assert results[0].timelines[0].keyframes != jobs[0].timelines[0].keyframes, "framed"
        assert "no scene named 'no-such-scene'" in results[1].error
        process = worker._process
        assert worker.busy and worker._leaving, "nothing left: the worker is told to leave"
        process.join(timeout=30)
        for _ in range(600):  # 60 s: a hang's backstop, however busy the machine
            if worker.results() == [] and not worker.busy:
                break
            time.sleep(0.1)
        assert not worker.busy and process.exitcode == 0, "it left, and the kiosk knows"
        # a worker that dies under a job: that job fails with the exit code
        worker.submit(jobs[1])
        assert worker._process is None, "started by results(), not by submit()"
        assert worker.results() == [] and worker._in_flight is jobs[1]
        worker._process.kill()
        worker._process.join()
        died = []
        for _ in range(600):
            died += worker.results()
            if died:
                break
            time.sleep(0.1)
        assert died[0].job is jobs[1] and "died (exit code -9)" in died[0].error
    finally:
        worker.close()


def test_run_job_in_process_matches_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    config = _config(tmp_path)
    job = scene_jobs(config, [], [2])[0]
    first = run_job(job)
    again = run_job(job)
    assert first.error is None and again.error is None
    assert np.array_equal(
        first.meshes[2].surfaces[0].positions, again.meshes[2].surfaces[0].positions
    )
    assert len(list(Path(tmp_path / "cache").glob("hopf-*.npz"))) == 1


def test_exhibit_prepare_fills_the_cache_the_kiosk_then_reads(tmp_path, monkeypatch, capsys):
    """`exhibit prepare` builds every mesh level of every scene the config shows; a kiosk
    started afterwards builds nothing. A scene that fails is named, exit 1."""
    from exhibit.cli import main
    from exhibit.scenes import cache

    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    path = make_config(tmp_path, "")
    assert main(["prepare", "--config", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [s["scene"] for s in report["scenes"]] == ["hopf", "clifford-torus"]
    assert report["scenes"][0]["resolutions"] == [8, 12, 16]  # hopf = 16 at x0.5, x0.75, x1
    assert all(s["error"] is None for s in report["scenes"])
    hits = []
    real = cache.build_cached

    def counting(scene, params, resolution):
        mesh, hit = real(scene, params, resolution)
        hits.append(hit)
        return mesh, hit

    monkeypatch.setattr(jobs_module, "build_cached", counting)
    config = load_kiosk_config(path)
    app.Kiosk(config, Window(), notifier=Notifier(), health_path=tmp_path / "health.json")
    assert hits and all(hits), "every mesh the kiosk loads was in the cache"

    def broken(scene, params, resolution):
        if scene.name == "clifford-torus":
            raise RuntimeError("out of memory")
        return real(scene, params, resolution)

    monkeypatch.setattr(jobs_module, "build_cached", broken)
    assert main(["prepare", "--config", str(path)]) == 1
    out = capsys.readouterr().out
    assert "clifford-torus" in out and "failed: RuntimeError: out of memory" in out
    assert "1 of 2 scenes ready" in out


def test_more_levels_of_the_scene_on_screen_leave_a_visitors_view_alone(
    tmp_path, built, monkeypatch
):
    """The first scene's other mesh levels arrive while a visitor turns it: their zoom stays;
    if those levels cannot be built, the scene keeps the one it has (not "skipped")."""
    built.broken.add("hopf")
    real = jobs_module.build_cached
    k_calls = []

    def first_only(scene, params, resolution):
        k_calls.append(resolution)
        if len(k_calls) == 1:  # the first frame's level builds; the others fail
            return f"mesh {scene.name} {resolution}", None
        return real(scene, params, resolution)

    monkeypatch.setattr(jobs_module, "build_cached", first_only)
    k = _kiosk(tmp_path)
    k.step()
    k.devices.keyboard.key("q", True)  # a visitor turns θ1...
    for _ in range(3):
        k.step()
    k.devices.keyboard.key("q", False)
    view = k.state.frame.view
    assert k.state.mode == "visitor"
    k.content.collect(k.clock(), k.parts.started)  # hopf's other levels: they fail
    assert k.state.frame.view == view
    assert k.parts.problems == [] and k.parts.scenes_failed == [] and "hopf" in k.state.content


def test_no_worker_process_means_the_rest_is_prepared_here(tmp_path, built, monkeypatch, caplog):
    """A worker process that cannot start (no processes left, a sandbox that forbids it): the
    kiosk says so once and prepares the rest itself, one scene per frame, with no failed frame."""

    def refuse(self):
        raise OSError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(ProcessPreparer, "_start", refuse)
    ticks = iter(np.arange(1e6) * 0.1)
    k = app.Kiosk(
        _config(tmp_path),
        Window(),
        clock=lambda: float(next(ticks)),
        notifier=Notifier(),
        health_path=tmp_path / "health.json",
        preparer=ProcessPreparer,
    )
    k.run(max_frames=8)
    assert caplog.text.count("the preparing process cannot run") == 1
    assert isinstance(k.content.preparer, InlinePreparer) and k.content.prepared_at is not None
    assert [t.scene for t in k.state.playlist.timelines] == ["hopf", "clifford-torus"]
    assert k.errors.total == 0


@pytest.mark.slow
def test_bench_startup_reports_rounds_ratios_and_the_prepared_time(tmp_path):
    """`exhibit bench startup --repeat 1 --json` on a real window (Xvfb) with a small site
    config: a first frame cold and warm, every scene prepared in both, and the ratios computed
    from the medians it reports (no time is asserted: that is the benchmark's job)."""
    path = make_config(tmp_path, "")
    with xvfb("1280x720x24") as display:
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "exhibit",
                "bench",
                "startup",
                "--repeat",
                "1",
                "--json",
                "--config",
                str(path),
            ],
            env={**os.environ, "DISPLAY": display, "OPENBLAS_NUM_THREADS": "1"},
            capture_output=True,
            text=True,
            timeout=600,
            cwd=tmp_path,
        )
    assert result.returncode == 0, result.stderr[-2000:]
    report = json.loads(result.stdout)
    assert len(report["cold_runs_s"]) == len(report["warm_runs_s"]) == 1
    assert report["prepared_s"]["cold"] >= report["cold_s"] > 0
    assert report["prepared_s"]["warm"] >= report["warm_s"] > 0
    imports = report["baseline"]["imports_s"]
    assert report["ratios"]["warm_to_imports"] == round(report["warm_s"] / imports, 2)
    assert report["ratios"]["cold_to_warm"] == round(report["cold_s"] / report["warm_s"], 2)
    assert isinstance(report["goals_met"], bool)


def test_the_kiosk_runs_with_the_parts_it_is_handed(tmp_path, built):
    """The parts are built outside (exhibit.kiosk.assembly) and handed in: a kiosk given a
    reporter of the test's own reports through it, and draws the content it was handed."""
    from exhibit.kiosk.assembly import assemble

    ticks = iter(np.arange(1e6) * 0.1)
    clock = lambda: float(next(ticks))  # noqa: E731 - a clock of 0.1 s steps
    window = Window()
    config = _config(tmp_path)
    parts = assemble(config, window, clock)

    class Reports:
        def __init__(self):
            self.calls = []

        def report(self, now, **what):
            self.calls.append((now, what["frames"], what["state"].mode))

    parts = dataclasses.replace(parts, reporter=Reports())
    k = app.Kiosk(config, window, clock, parts=parts)
    k.run(max_frames=20)
    assert parts.reporter.calls and all(mode == "attract" for _, _, mode in parts.reporter.calls)
    assert k.content is parts.content and len(window.drawn) > 0


@pytest.mark.parametrize("case", ["a regular file", "a link to a device", "read-only"])
def test_exhibit_prepare_fails_when_it_cached_nothing(tmp_path, monkeypatch, capsys, case):
    """Issue 33: prepare said "2 of 2 scenes ready" and exit 0 with nothing in the cache (the
    cache only warns when it cannot store); install and update took that as a warm cache."""
    from exhibit.cli import main

    cache = tmp_path / "cache"
    if case == "a regular file":
        cache.write_text("not a folder")
    elif case == "a link to a device":
        cache.symlink_to("/dev/null")
    else:
        cache.mkdir()
        if os.geteuid() == 0:  # root writes through the mode bits: a store that fails instead
            from exhibit.scenes import cache as mesh_cache

            def refuse(folder, path, data):
                raise PermissionError(13, "Read-only file system")

            monkeypatch.setattr(mesh_cache, "store", refuse)
        else:
            cache.chmod(0o555)
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(cache))
    path = make_config(tmp_path, "")
    assert main(["prepare", "--config", str(path)]) == 1
    out = capsys.readouterr().out
    assert "0 of 2 scenes ready" in out and "not cached: " in out
    if case != "read-only":
        assert "not a folder" in out


def _fake_workers(monkeypatch) -> list:
    """ProcessPreparer's workers as fakes: (nice, process, connection, inbox) each."""
    import queue

    workers: list = []

    def spawn(self, nice, name):
        worker = (nice, _Process(), _Connection(), queue.SimpleQueue())
        workers.append(worker)
        return worker[1:]

    monkeypatch.setattr(ProcessPreparer, "_spawn", spawn)
    return workers


def test_workers_are_replaced_by_rate_not_count_and_what_they_dropped_is_tried_again(
    monkeypatch,
):
    """Issue 33: after its third death the worker was never started again and every scene
    still waiting was dropped until the kiosk restarted. Now at most WORKER_RESTARTS restarts
    an hour: beyond that the jobs wait, none is dropped, and each job a death failed is tried
    again later, the wait doubling."""
    workers = _fake_workers(monkeypatch)
    now = [0.0]
    p = ProcessPreparer(urgent=False, clock=lambda: now[0])
    jobs = [Job(name, (), ((0, 8),)) for name in "abcdef"]
    for job in jobs:
        p.submit(job)
    assert p.results() == [] and workers[0][2].sent == [jobs[0]]
    failed = []
    for _ in range(process_preparer.WORKER_RESTARTS + 1):  # deaths 10 s apart
        now[0] += 10
        workers[-1][3].put(worker_watch.ENDED)
        failed += p.results()
    assert [r.job.scene for r in failed] == ["a", "b", "c", "d"]
    assert all("died" in r.error and "tried again in 60 s" in r.error for r in failed)
    assert len(workers) == 1 + process_preparer.WORKER_RESTARTS, "three restarts, then held"
    assert p.busy and [j.scene for j in p.pending()] == ["e", "f"], "nothing dropped"
    assert "restarts held" in p.status() and "to try again: a in 30 s" in p.status()
    now[0] = 10 + process_preparer.RESTART_WINDOW_S  # an hour after the first death
    assert p.results() == [] and len(workers) == 5
    assert [j.scene for j in p.pending()] == ["e", "f", "a", "b", "c", "d"]
    workers[-1][3].put(jobs_module.Prepared(jobs[4]))
    workers[-1][3].put(jobs_module.Prepared(jobs[5]))
    assert [r.job.scene for r in p.results()] == ["e", "f"]
    workers[-1][3].put(worker_watch.ENDED)  # a fails a second time: twice as long to wait
    again = p.results()
    assert again[0].job is jobs[0] and "tried again in 120 s" in again[0].error


def test_a_stopped_or_stalled_worker_is_found_by_a_deadline_and_replaced(monkeypatch):
    """A worker whose CPU time stands still (SIGSTOP, a hung disk) for STALL_S with a job under
    way is killed and replaced, its job tried again later; one that works on one job past
    JOB_DEADLINE_S likewise; status() names it for the health file."""
    workers = _fake_workers(monkeypatch)
    seen = {"state": "R", "cpu": 1.0}
    monkeypatch.setattr(worker_watch, "worker_progress", lambda pid: (seen["state"], seen["cpu"]))
    now = [0.0]
    p = ProcessPreparer(urgent=False, clock=lambda: now[0])
    a, b, c = (Job(name, (), ((0, 8),)) for name in "abc")
    for job in (a, b, c):
        p.submit(job)
    p.results()
    for _ in range(100):  # a slow job that progresses is never stalled
        now[0] += 10
        seen["cpu"] += 0.01
        assert p.results() == []
    seen["state"] = "T"  # SIGSTOP: its CPU time stands still
    now[0] += worker_watch.STALL_S - 1
    assert p.results() == [] and not workers[0][1].killed
    now[0] += 2
    out = p.results()
    assert out[0].job is a and "stalled (no progress for 121 s (stopped))" in out[0].error
    assert workers[0][1].killed and len(workers) == 2 and workers[1][2].sent == [b]
    assert "1 stalled); last: pid 4242 stalled preparing a: no progress" in p.status()
    # without /proc to read: the job's deadline alone
    monkeypatch.setattr(worker_watch, "worker_progress", lambda pid: None)
    now[0] += worker_watch.JOB_DEADLINE_S
    out = p.results()
    assert out[0].job is b and "still on one job after 1800 s" in out[0].error
    assert workers[1][1].killed and workers[2][2].sent == [c]


def test_a_real_stopped_worker_is_found_and_replaced(tmp_path, monkeypatch):
    """SIGSTOP on a real worker process: its CPU time stands still (/proc), so the deadline
    finds it on the preparer's clock (a fake one: nothing here waits on the wall clock for
    something slower under load); a new worker takes the job when it is tried again."""
    import signal

    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    now = [0.0]
    p = ProcessPreparer(urgent=False, clock=lambda: now[0])
    job = Job("no-such-scene", (), ((2, 8),))
    try:
        p.submit(job)
        assert p.results() == []
        stopped = p._process
        os.kill(stopped.pid, signal.SIGSTOP)
        for _ in range(600):  # until the stop has taken effect
            if worker_watch.worker_progress(stopped.pid)[0] in "Tt":
                break
            time.sleep(0.01)
        assert p.results() == []  # its CPU time, seen once
        now[0] += worker_watch.STALL_S + 1
        out = p.results()
        assert out[0].job is job and "stalled (no progress for 121 s (stopped))" in out[0].error
        stopped.join(timeout=30)
        assert stopped.exitcode == -signal.SIGKILL
        assert f"pid {stopped.pid} stalled preparing no-such-scene" in p.status()
        now[0] += process_preparer.RETRY_S
        results = []
        for _ in range(600):
            results += p.results()
            if results:
                break
            time.sleep(0.1)
        assert p._process is not stopped and "no scene named 'no-such-scene'" in results[0].error
    finally:
        p.close()


def test_a_stalled_worker_is_named_in_the_health_file_and_its_scene_comes_back(
    tmp_path, built, monkeypatch
):
    """In the kiosk: the scene a stalled worker dropped is left out and named, the worker is
    named in the health file's problems, and the scene comes back when it is tried again."""
    import functools

    workers = _fake_workers(monkeypatch)
    monkeypatch.setattr(worker_watch, "worker_progress", lambda pid: ("T", 1.0))
    now = [0.0]
    ticks = iter(np.arange(1e6) * 0.1)
    k = app.Kiosk(
        _config(tmp_path),
        Window(),
        clock=lambda: float(next(ticks)),
        notifier=Notifier(),
        health_path=tmp_path / "health.json",
        preparer=functools.partial(ProcessPreparer, urgent=False, clock=lambda: now[0]),
    )

    def deliver():
        job = workers[-1][2].sent[-1]
        meshes = {level: f"mesh {job.scene} {res}" for level, res in job.levels}
        workers[-1][3].put(jobs_module.Prepared(job, meshes, list(job.timelines)))

    def frame():
        k.tick(k.clock())

    frame()  # the first frame
    frame()  # the worker starts
    deliver()  # hopf's other mesh levels
    frame()
    assert workers[-1][2].sent[-1].scene == "clifford-torus"
    now[0] += worker_watch.STALL_S + 1
    frame()
    assert "clifford-torus" not in k.state.content
    k.report(k.clock())
    problems = json.loads((tmp_path / "health.json").read_text())["problems"]
    assert any(
        p.startswith("scene clifford-torus skipped: the preparing process stalled")
        for p in problems
    )
    assert any(
        p.startswith(
            "preparing process replaced 1 times (0 died, 1 stalled); last: pid 4242 "
            "stalled preparing clifford-torus: no progress for 121 s (stopped)"
        )
        and "to try again: clifford-torus in 60 s" in p
        for p in problems
    ), problems
    assert workers[-1][2].sent[-1].scene == "veronese", "a new worker goes on"
    deliver()
    frame()
    assert workers[-1][2].sent[-1] is None, "nothing to do now: the worker leaves"
    workers[-1][3].put(worker_watch.ENDED)
    now[0] += process_preparer.RETRY_S
    frame()
    assert workers[-1][2].sent[-1].scene == "clifford-torus", "tried again"
    deliver()
    frame()
    assert k.state.content == ("hopf", "clifford-torus", "veronese")
    assert [t.scene for t in k.state.playlist.timelines] == ["hopf", "clifford-torus"]
    assert (
        not any("clifford-torus skipped" in p for p in k.parts.problems)
        and not k.parts.scenes_failed
    )
    workers[-1][3].put(worker_watch.ENDED)  # it leaves: everything is prepared
    workers[-1][1].alive = False
    frame()
    frame()  # reaped
    assert k.content.prepared_at is not None
