"""Meshes and framed timelines made ready off the frame path, so the first picture comes within
a second of start and the rest arrive while it plays.

The kiosk needs one scene for its first frame; everything else (the other scenes, the other
mesh levels, framing the other timelines) is a Job. Jobs run in a Preparer: ProcessPreparer in a
worker process at a lower priority (building the cusp's pipe takes seconds of pure Python: a
thread would hold the interpreter lock against the frame loop), InlinePreparer in this process
(tests, reviews, `exhibit prepare`). Either way a job's result comes back as plain data (Mesh4D,
Timeline); uploading it to the GPU is the kiosk's, on its own thread.

Why one module of this size: jobs, the work they do and both places they run: a worker process
imports exactly this."""

from __future__ import annotations

import dataclasses
import logging
import multiprocessing
import os
import queue
import threading
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Protocol

from exhibit import scenes
from exhibit.kiosk.attract import Timeline
from exhibit.kiosk.timeline_framing import frame_timeline
from exhibit.kiosk.governor import level_resolution
from exhibit.render.framer import Framer
from exhibit.scenes.cache import build_cached
from exhibit.surfaces.mesh import Mesh4D

log = logging.getLogger("exhibit.kiosk")

#: How much the worker process yields to the frame loop (os.nice increment).
WORKER_NICE = 10
#: A worker process that dies (killed for memory, a crash in a native library) is started again
#: this many times; then the jobs left fail with the reason.
WORKER_RESTARTS = 2

Params = tuple[tuple[str, float], ...]


def params_of(timeline: Timeline) -> Params:
    return tuple(sorted(timeline.params.items()))


@dataclass(frozen=True)
class Job:
    """One scene with one set of parameters: its meshes at ``levels`` (mesh level ->
    resolution), and the attract ``timelines`` that show it, to frame with its finest mesh."""

    scene: str
    params: Params
    levels: tuple[tuple[int, int], ...]
    timelines: tuple[Timeline, ...] = ()

    @property
    def key(self) -> tuple[str, Params]:
        return (self.scene, self.params)


@dataclass
class Prepared:
    """A job's result: meshes by level, the timelines framed (in the job's order), and
    ``error`` (one line, for people) when the scene cannot be shown at all."""

    job: Job
    meshes: dict[int, Mesh4D] = field(default_factory=dict)
    timelines: list[Timeline] = field(default_factory=list)
    error: str | None = None


@dataclass(frozen=True)
class Framers:
    """How timelines are framed: ``main`` for the screen, ``inset`` clear of the time-slice
    inset's corner too (timelines that slice a scene with a 3D world at each moment)."""

    main: Framer | None = None
    inset: Framer | None = None


def scene_jobs(config, timelines: Sequence[Timeline], levels: Iterable[int]) -> list[Job]:
    """Every (scene, parameters) the kiosk shows, in the order it needs them: the playlist's
    (the first timeline first), then the content list's; each at every mesh level in
    ``levels``, with its timelines. Scenes that do not load raise (the caller skips them)."""
    levels = sorted(set(levels))
    keys: dict[tuple[str, Params | None], list[Timeline]] = {}
    for timeline in timelines:
        keys.setdefault((timeline.scene, params_of(timeline)), []).append(timeline)
    for name in config.scenes:
        keys.setdefault((name, None), [])
    jobs: dict[tuple[str, Params], Job] = {}
    for (name, params), shown in keys.items():
        try:
            scene = scenes.get(name)
            params = params if params is not None else tuple(sorted(scene.resolve().items()))
            resolutions = tuple(
                (level, level_resolution(scene, config.resolution.get(name), level))
                for level in levels
            )
        except Exception as exc:  # noqa: BLE001 - reported by the caller as this scene's
            jobs[(name, ())] = Job(name, (), (), tuple(shown))
            log.debug("scene %s: %s", name, exc)
            continue
        old = jobs.get((name, params))
        jobs[(name, params)] = Job(
            name, params, resolutions, (old.timelines if old else ()) + tuple(shown)
        )
    return list(jobs.values())


def run_job(job: Job, framers: Framers = Framers()) -> Prepared:
    """Build or load the job's meshes (from the mesh cache) and frame its timelines. Never
    raises: a scene that cannot be built comes back with ``error``."""
    try:
        scene = scenes.get(job.scene)
        meshes = build_levels(scene, job)
        if not meshes:
            raise ValueError("no mesh level to build")
    except Exception as exc:  # noqa: BLE001 - one scene must not stop the exhibit
        log.error(
            "scene %s cannot be prepared: %s: %s", job.scene, type(exc).__name__, exc, exc_info=exc
        )
        return Prepared(job, error=f"{type(exc).__name__}: {exc}")
    finest = meshes[min(meshes)]
    framed = [frame(t, scene, finest, framers) for t in job.timelines]
    return Prepared(job, meshes, framed)


def build_levels(scene, job: Job) -> dict[int, Mesh4D]:
    """The scene's mesh at every level of the job. A coarser level that fails uses the finer
    one (it is only an economy); the finest failing fails the scene."""
    meshes: dict[int, Mesh4D] = {}
    by_resolution: dict[int, Mesh4D] = {}
    for level, resolution in sorted(job.levels):
        try:
            if resolution not in by_resolution:
                by_resolution[resolution] = build_cached(scene, dict(job.params), resolution)[0]
            meshes[level] = by_resolution[resolution]
        except Exception as exc:  # noqa: BLE001
            if not meshes:
                raise
            log.warning(
                "scene %s: no mesh at resolution %d (%s); using a finer one",
                job.scene,
                resolution,
                exc,
            )
            meshes[level] = meshes[max(meshes)]
    return meshes


def slices(scene, timeline: Timeline) -> bool:
    """Whether the timeline slices a scene that has a 3D world at each moment (the inset)."""
    return (
        scene.world_at is not None
        and timeline.slice_axis == scene.slice_axis
        and any(k.slice_at is not None for k in timeline.keyframes)
    )


def frame(timeline: Timeline, scene, mesh: Mesh4D, framers: Framers) -> Timeline:
    """The timeline framed clear of the text (exhibit.kiosk.timeline_framing); unchanged without a
    framer or when framing fails (never fatal: an unframed timeline still plays)."""
    framer = framers.inset if slices(scene, timeline) else framers.main
    if framer is None:
        return timeline
    try:
        return frame_timeline(framer, timeline, scene, mesh)
    except Exception as exc:  # noqa: BLE001
        log.warning("timeline %s not framed: %s", timeline.name, exc)
        return timeline


# ---------------------------------------------------------------------- where jobs run


class Preparer(Protocol):
    """Where jobs run: InlinePreparer (here) or ProcessPreparer (a worker process)."""

    framers: Framers

    def submit(self, job: Job) -> None: ...
    @property
    def busy(self) -> bool: ...
    def first(self, key: tuple) -> None: ...
    def pending(self) -> list[Job]: ...
    def results(self) -> list[Prepared]: ...
    def close(self) -> None: ...


class InlinePreparer:
    """Runs each job in this process when its result is asked for: one job per results() call,
    so a test steps through the kiosk's start frame by frame."""

    def __init__(self, framers: Framers = Framers()):
        self.framers = framers
        self._queue: list[Job] = []

    def submit(self, job: Job) -> None:
        self._queue.append(job)

    @property
    def busy(self) -> bool:
        return bool(self._queue)

    def first(self, key) -> None:
        """The job for ``key`` (scene, params), if waiting, runs next."""
        self._queue.sort(key=lambda job: job.key != key)

    def pending(self) -> list[Job]:
        return list(self._queue)

    def results(self) -> list[Prepared]:
        return [run_job(self._queue.pop(0), self.framers)] if self._queue else []

    def close(self) -> None:
        self._queue.clear()


def _portable(prepared: Prepared) -> Prepared:
    """``prepared`` as the kiosk gets it from the cache: without a fresh build's exact
    surfaces (sympy functions, which do not pickle; the kiosk's frames never use them)."""
    plain: dict[int, Mesh4D] = {}
    for level, mesh in prepared.meshes.items():
        same = next((plain[other] for other in plain if prepared.meshes[other] is mesh), None)
        plain[level] = same or dataclasses.replace(
            mesh, surfaces=[dataclasses.replace(s, exact=None) for s in mesh.surfaces]
        )
    return dataclasses.replace(prepared, meshes=plain)


def _worker(connection, framers: Framers, nice: int = WORKER_NICE) -> None:
    """The worker process: jobs in, Prepared out, until a None job or the end of the pipe.
    ``nice``: how much it yields to the frame loop (0: the urgent worker, for the scene a
    visitor waits for)."""
    try:
        if nice:
            os.nice(nice)
    except OSError:  # a system call filter without setpriority: the same priority, then
        pass
    from exhibit.kiosk import journal

    journal.install()
    scenes.load()
    while True:
        try:
            job = connection.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        try:
            connection.send(_portable(run_job(job, framers)))
        except OSError:  # the kiosk is gone or stopping
            return


#: What the reader thread puts in the inbox when the worker's end of the pipe has closed.
_ENDED = object()


def _read(connection, inbox: queue.SimpleQueue) -> None:
    """The kiosk's reader thread: a result is read whole here, off the frame loop (a worker
    at a lower priority may take its time writing megabytes), and handed over whole."""
    while True:
        try:
            inbox.put(connection.recv())
        except (EOFError, OSError):
            inbox.put(_ENDED)
            return


@dataclass
class _Urgent:
    """The worker for the scene a visitor waits for: its job, process, pipe and inbox."""

    job: Job
    process: BaseProcess
    connection: Connection
    inbox: queue.SimpleQueue


class ProcessPreparer:
    """Runs jobs in a worker process (multiprocessing "spawn": the kiosk has GL and X or
    Wayland connections open, which a forked child must not share). One job at a time, so
    the kiosk can reorder what waits (a visitor who asks for a scene first). results() never
    blocks: a reader thread receives. The worker leaves when nothing is left to do, or by
    itself when the kiosk dies (the end of its pipe).

    The worker runs at nice WORKER_NICE, and a process cannot lower its niceness again without
    privilege (CAP_SYS_NICE). So the scene a visitor waits for (first()) goes to an urgent
    worker of its own at the kiosk's priority (``urgent``; the default): on a machine busy
    with other work, a niced worker gets a tenth of a core, and the visitor would wait minutes.
    Should the niced worker already be preparing that scene, both go on and the first result
    counts (the niced one takes only what the rest of the machine leaves)."""

    def __init__(self, framers: Framers = Framers(), urgent: bool = True):
        self.framers = framers
        self.urgent = urgent
        self._urgent: _Urgent | None = None
        #: Keys an urgent worker delivered first: the niced worker's result for them is dropped.
        self._delivered: set[tuple] = set()
        self._context = multiprocessing.get_context("spawn")
        #: the worker and the kiosk's end of its pipe: both set, or both None
        self._process: BaseProcess | None = None
        self._connection: Connection | None = None
        self._inbox: queue.SimpleQueue = queue.SimpleQueue()
        self._in_flight: Job | None = None
        self._queue: list[Job] = []
        self._restarts = 0
        self._leaving = False
        #: A worker whose pipe has closed, not yet reaped.
        self._exiting: multiprocessing.process.BaseProcess | None = None
        #: Urgent workers done or stopped, not yet reaped.
        self._stopped: list[BaseProcess] = []

    def _spawn(self, nice: int, name: str) -> tuple[BaseProcess, Connection, queue.SimpleQueue]:
        parent, child = self._context.Pipe()
        process = self._context.Process(
            target=_worker, args=(child, self.framers, nice), name=name, daemon=True
        )
        process.start()
        child.close()
        inbox: queue.SimpleQueue = queue.SimpleQueue()
        threading.Thread(
            target=_read, args=(parent, inbox), daemon=True, name=f"{name}-reader"
        ).start()
        return process, parent, inbox

    def _start(self) -> None:
        self._process, self._connection, self._inbox = self._spawn(WORKER_NICE, "exhibit-prepare")

    def submit(self, job: Job) -> None:
        """Queued; the worker starts at the first results() (after the kiosk's first frame:
        its start-up would compete with the first picture for the CPU)."""
        self._queue.append(job)

    @property
    def busy(self) -> bool:
        """Jobs waiting or under way, or a worker not yet gone."""
        return (
            self._in_flight is not None
            or bool(self._queue)
            or self._process is not None
            or self._exiting is not None
            or self._urgent is not None
        )

    def first(self, key) -> None:
        """The job for ``key`` (scene, params), if waiting, runs next: in an urgent worker of
        its own (``urgent``), else next in the niced one. Called every frame while a visitor
        waits: an urgent worker starts once per scene."""
        self._queue.sort(key=lambda job: job.key != key)
        if not self.urgent or (self._urgent is not None and self._urgent.job.key == key):
            return
        job = next((j for j in self.pending() if j.key == key), None)
        if job is None or key in self._delivered:
            return
        self._stop_urgent()  # a visitor who moved on: the scene they left waits its turn
        process, connection, inbox = self._spawn(0, "exhibit-prepare-now")
        self._urgent = _Urgent(job, process, connection, inbox)
        try:
            connection.send(job)
        except OSError:
            pass  # it died at once: its reader says so
        log.info("scene %s: prepared now, for a visitor who waits", job.scene)

    def _stop_urgent(self) -> None:
        urgent, self._urgent = self._urgent, None
        if urgent is None:
            return
        urgent.connection.close()
        urgent.process.terminate()  # reaped by its reader's end or at close()
        self._stopped.append(urgent.process)

    def _urgent_results(self) -> list[Prepared]:
        """The urgent worker's result, once: the job leaves the queue (or the niced worker's
        result for it will be dropped); a worker that died leaves the job to the niced one."""
        urgent = self._urgent
        if urgent is None:
            return []
        try:
            item = urgent.inbox.get_nowait()
        except queue.Empty:
            return []
        self._urgent = None
        urgent.connection.close()
        self._stopped.append(urgent.process)
        if item is _ENDED:
            log.warning("the urgent preparing process died: %s waits its turn", urgent.job.scene)
            return []
        key = urgent.job.key
        self._queue = [job for job in self._queue if job.key != key]
        if self._in_flight is not None and self._in_flight.key == key:
            self._delivered.add(key)
        return [item]

    def pending(self) -> list[Job]:
        """The jobs not done: the one under way first."""
        return ([self._in_flight] if self._in_flight is not None else []) + self._queue

    def _send(self) -> None:
        urgent = self._urgent.job.key if self._urgent is not None else None
        ready = [i for i, job in enumerate(self._queue) if job.key != urgent]
        if self._in_flight is not None or not ready or self._leaving:
            return
        if self._process is None:
            self._start()
        self._in_flight = self._queue.pop(ready[0])
        assert self._connection is not None  # set with the process
        try:
            self._connection.send(self._in_flight)  # a Job is small: the pipe takes it at once
        except OSError:
            pass  # the worker is gone: the reader says so

    def results(self) -> list[Prepared]:
        out: list[Prepared] = []
        if self._exiting is not None and not self._exiting.is_alive():
            self._exiting = None  # is_alive() has reaped it: never waited for in a frame
        self._stopped = [p for p in self._stopped if p.is_alive()]  # reaped likewise
        out += self._urgent_results()
        self._send()
        while True:
            try:
                item = self._inbox.get_nowait()
            except queue.Empty:
                break
            if item is _ENDED:
                out += self._ended()
            else:
                self._in_flight = None
                if item.job.key in self._delivered:
                    self._delivered.discard(item.job.key)  # the urgent worker was first
                else:
                    if self._urgent is not None and self._urgent.job.key == item.job.key:
                        self._stop_urgent()  # the niced worker was first
                    out.append(item)
                self._send()
        if (
            self._in_flight is None
            and not self._queue
            and self._process is not None
            and not self._leaving
        ):
            self._leaving = True  # nothing left: the worker's memory back
            assert self._connection is not None  # set with the process
            try:
                self._connection.send(None)
            except OSError:
                pass
        return out

    def _ended(self) -> list[Prepared]:
        """The worker's end of the pipe closed: it left as asked, or it died under a job,
        which then fails; the worker starts again for the rest (up to WORKER_RESTARTS times;
        then they fail too)."""
        process, job = self._process, self._in_flight
        # _ENDED comes from the reader of a started worker's pipe
        assert process is not None and self._connection is not None
        self._connection.close()
        self._process, self._connection, self._in_flight = None, None, None
        self._exiting = process  # it has closed its end: exiting, reaped by a later results()
        if self._leaving and job is None:
            self._leaving = False
            return []
        self._leaving = False
        code = process.exitcode  # None while it is still on its way out
        log.error(
            "the preparing process died (exit code %s) while preparing %s",
            code,
            job.scene if job else "nothing",
        )
        self._restarts += 1
        failed = [job] if job is not None else []
        if self._restarts > WORKER_RESTARTS:
            failed += self._queue
            self._queue = []
        return [Prepared(j, error=f"the preparing process died (exit code {code})") for j in failed]

    def close(self) -> None:
        """Stop the worker: at once when it is busy (a half-built mesh is not worth waiting
        for; the cache never keeps half a file), else it exits when the pipe closes."""
        self._queue.clear()
        self._stop_urgent()
        if self._connection is not None:
            self._connection.close()
        for process in (self._process, self._exiting, *self._stopped):
            if process is None:
                continue
            if process is self._process and self._in_flight is not None:
                process.terminate()
            process.join(timeout=2)
            if process.is_alive():
                process.kill()
                process.join(timeout=2)
        self._process = self._connection = self._in_flight = self._exiting = None
        self._stopped = []
        self._leaving = False
