"""Jobs run in worker processes (exhibit.preparing.worker) at a lower priority than the frame loop,
one at a time so the kiosk can reorder what waits, with an urgent worker for the scene a visitor
waits for; workers that die or stall are replaced at a bounded rate and their jobs tried again
later, for a kiosk that runs for months."""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess

from exhibit.timelines.model import Params
from exhibit.preparing.jobs import Framers, Job, Prepared
from exhibit.preparing.worker import serve
from exhibit.preparing.worker_watch import ENDED, Watch, read_results

log = logging.getLogger("exhibit.kiosk")

#: How much the worker process yields to the frame loop (os.nice increment).
WORKER_NICE = 10
#: A worker process that dies (killed for memory, a crash in a native library) or stalls is
#: replaced, at most WORKER_RESTARTS times in any RESTART_WINDOW_S: a kiosk runs for months, so
#: the limit is a rate, never a count for the life of the process. Beyond it the jobs wait (none
#: is dropped) until the window allows the next start.
WORKER_RESTARTS = 3
RESTART_WINDOW_S = 3600.0
#: A job failed by its worker's death or stall is tried again after RETRY_S, doubling with each
#: failure up to RETRY_MAX_S (the scene is left out meanwhile, and back when it arrives).
RETRY_S = 60.0
RETRY_MAX_S = 3600.0


@dataclass
class _Urgent:
    """The worker for the scene a visitor waits for: its job, process, pipe and inbox."""

    job: Job
    process: BaseProcess
    connection: Connection
    inbox: queue.SimpleQueue
    watch: Watch


class WorkerLosses:
    """Workers lost (died or stalled) and the jobs they failed, for :class:`ProcessPreparer`:
    the rate of restarts, the jobs to try again and the health file's line about them."""

    clock: Callable[[], float]
    _queue: list[Job]

    def __init__(self) -> None:
        #: When workers died or stalled, within the last RESTART_WINDOW_S.
        self._deaths: deque[float] = deque()
        self._died = self._stalls = 0
        self._last_loss = ""
        self._held = False
        #: Jobs a worker's death or stall failed, by key: (when to try again, the job), and
        #: how many times each has failed so.
        self._retries: dict[tuple, tuple[float, Job]] = {}
        self._attempts: dict[tuple, int] = {}

    def _may_start(self, now: float) -> bool:
        """Whether a worker may start now: not when WORKER_RESTARTS workers died or stalled
        within the last RESTART_WINDOW_S (the jobs wait; logged once a hold)."""
        while self._deaths and now - self._deaths[0] >= RESTART_WINDOW_S:
            self._deaths.popleft()
        held = len(self._deaths) > WORKER_RESTARTS
        if held and not self._held:
            log.error(
                "the preparing process was replaced %d times within %.0f s: the next start "
                "waits %.0f s (%d scenes wait)",
                len(self._deaths),
                RESTART_WINDOW_S,
                self._deaths[0] + RESTART_WINDOW_S - now,
                len(self._queue),
            )
        self._held = held
        return not held

    def _lost(self, job: Job | None, error: str, now: float) -> list[Prepared]:
        """A worker died or stalled (counted against the rate of restarts) under ``job``,
        which fails now and is tried again later."""
        self._deaths.append(now)
        if job is None:
            return []
        tries = self._attempts[job.key] = self._attempts.get(job.key, 0) + 1
        delay = min(RETRY_S * 2 ** (tries - 1), RETRY_MAX_S)
        self._retries[job.key] = (now + delay, job)
        return [Prepared(job, error=f"{error}; tried again in {delay:.0f} s")]

    def status(self) -> str | None:
        """One line for the health file about workers replaced and scenes waiting to be tried
        again, or None while no worker has been lost."""
        if not (self._died or self._stalls):
            return None
        parts = [
            f"preparing process replaced {self._died + self._stalls} times "
            f"({self._died} died, {self._stalls} stalled); last: {self._last_loss}"
        ]
        if self._held:
            parts.append(f"restarts held: {WORKER_RESTARTS} within {RESTART_WINDOW_S:.0f} s")
        if self._retries:
            now = self.clock()
            parts.append(
                "to try again: "
                + ", ".join(
                    f"{job.scene} in {max(0.0, at - now):.0f} s"
                    for at, job in self._retries.values()
                )
            )
        return "; ".join(parts)


class ProcessPreparer(WorkerLosses):
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
    counts (the niced one takes only what the rest of the machine leaves).

    For a kiosk that runs for months: a worker that dies or stalls (STALL_S, JOB_DEADLINE_S) is
    replaced at most WORKER_RESTARTS times an hour, its job fails (the kiosk leaves the scene out
    and says so) and is tried again later (RETRY_S, doubling); status() is the line for the
    health file. ``clock``: monotonic seconds (tests pass a fake one)."""

    def __init__(
        self,
        framers: Framers = Framers(),
        urgent: bool = True,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.framers = framers
        self.urgent = urgent
        self.clock = clock
        self._watch: Watch | None = None
        super().__init__()
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
        self._leaving = False
        #: A worker whose pipe has closed, not yet reaped.
        self._exiting: multiprocessing.process.BaseProcess | None = None
        #: Urgent workers done or stopped, not yet reaped.
        self._stopped: list[BaseProcess] = []

    def _spawn(self, nice: int, name: str) -> tuple[BaseProcess, Connection, queue.SimpleQueue]:
        parent, child = self._context.Pipe()
        process = self._context.Process(
            target=serve, args=(child, self.framers, nice), name=name, daemon=True
        )
        process.start()
        child.close()
        inbox: queue.SimpleQueue = queue.SimpleQueue()
        threading.Thread(
            target=read_results, args=(parent, inbox), daemon=True, name=f"{name}-reader"
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
            or bool(self._retries)
        )

    def first(self, key: tuple[str, Params]) -> None:
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
        now = self.clock()
        self._urgent = _Urgent(job, process, connection, inbox, Watch(now, now))
        with contextlib.suppress(OSError):  # it died at once: its reader says so
            connection.send(job)
        log.info("scene %s: prepared now, for a visitor who waits", job.scene)

    def _stop_urgent(self, kill: bool = False) -> None:
        urgent, self._urgent = self._urgent, None
        if urgent is None:
            return
        # its pipe is left to its reader, which closes it at the end (read_results)
        if kill:  # a stopped process acts on SIGTERM only once continued
            urgent.process.kill()
        else:
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
            why = urgent.watch.stalled(urgent.process, self.clock())
            if why is not None:
                self._stalls += 1
                self._last_loss = (
                    f"urgent pid {urgent.process.pid} stalled preparing {urgent.job.scene}: {why}"
                )
                log.error("the preparing process (%s): it waits its turn", self._last_loss)
                self._stop_urgent(kill=True)
            return []
        self._urgent = None
        if item is not ENDED:
            with contextlib.suppress(OSError):
                urgent.connection.send(None)  # done: it leaves, and its reader closes the pipe
        self._stopped.append(urgent.process)
        if item is ENDED:
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

    def _send(self, now: float) -> None:
        urgent = self._urgent.job.key if self._urgent is not None else None
        ready = [i for i, job in enumerate(self._queue) if job.key != urgent]
        if self._in_flight is not None or not ready or self._leaving:
            return
        if self._process is None:
            if not self._may_start(now):
                return
            self._start()
        self._in_flight = self._queue.pop(ready[0])
        self._watch = Watch(now, now)
        assert self._connection is not None  # set with the process
        # A Job is small: the pipe takes it at once. A worker gone: the reader says so.
        with contextlib.suppress(OSError):
            self._connection.send(self._in_flight)

    def _due(self, now: float) -> None:
        """Jobs to try again whose time has come, back in the queue."""
        for key, (at, job) in list(self._retries.items()):
            if at <= now:
                del self._retries[key]
                if all(j.key != key for j in self.pending()):
                    log.info("scene %s: tried again", job.scene)
                    self._queue.append(job)

    def _stalled(self, now: float) -> list[Prepared]:
        """The niced worker, if it is stalled under a job: killed (SIGKILL reaches a stopped
        process), its pipe and inbox left, and its job failed to be tried again."""
        process, job, watch = self._process, self._in_flight, self._watch
        if process is None or job is None or watch is None:
            return []
        why = watch.stalled(process, now)
        if why is None:
            return []
        process.kill()
        # its pipe is left to its reader, which closes it at the end (read_results); the reader's
        # word of that end goes to an inbox nobody reads
        self._inbox = queue.SimpleQueue()
        self._process, self._connection, self._in_flight = None, None, None
        self._stopped.append(process)  # reaped by a later results()
        self._leaving = False
        self._stalls += 1
        self._last_loss = f"pid {process.pid} stalled preparing {job.scene}: {why}"
        log.error("the preparing process (%s): it is replaced", self._last_loss)
        return self._lost(job, f"the preparing process stalled ({why})", now)

    def results(self) -> list[Prepared]:
        out: list[Prepared] = []
        now = self.clock()
        if self._exiting is not None and not self._exiting.is_alive():
            self._exiting = None  # is_alive() has reaped it: never waited for in a frame
        self._stopped = [p for p in self._stopped if p.is_alive()]  # reaped likewise
        out += self._urgent_results()
        out += self._stalled(now)
        self._due(now)
        self._send(now)
        while True:
            try:
                item = self._inbox.get_nowait()
            except queue.Empty:
                break
            if item is ENDED:
                out += self._ended(now)
                self._send(now)  # a new worker, if the rate of restarts allows
            else:
                self._in_flight = None
                if item.error is None:
                    self._attempts.pop(item.job.key, None)
                if item.job.key in self._delivered:
                    self._delivered.discard(item.job.key)  # the urgent worker was first
                else:
                    if self._urgent is not None and self._urgent.job.key == item.job.key:
                        self._stop_urgent()  # the niced worker was first
                    out.append(item)
                self._send(now)
        if (
            self._in_flight is None
            and not self._queue
            and self._process is not None
            and not self._leaving
        ):
            self._leaving = True  # nothing left: the worker's memory back
            assert self._connection is not None  # set with the process
            with contextlib.suppress(OSError):
                self._connection.send(None)
        return out

    def _ended(self, now: float) -> list[Prepared]:
        """The worker's end of the pipe closed: it left as asked, or it died under a job,
        which then fails and is tried again later; a worker starts again for the rest
        (WORKER_RESTARTS an hour at most: then they wait)."""
        process, job = self._process, self._in_flight
        # ENDED comes from the reader of a started worker's pipe
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
        self._died += 1
        self._last_loss = (
            f"pid {process.pid} died (exit code {code}) preparing {job.scene if job else 'nothing'}"
        )
        return self._lost(job, f"the preparing process died (exit code {code})", now)

    def close(self) -> None:
        """Stop the worker: at once when it is busy (a half-built mesh is not worth waiting
        for; the cache never keeps half a file), else it exits when the pipe closes."""
        self._queue.clear()
        self._retries.clear()
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
