"""The scenes the kiosk can show as they come: the first one prepared at once for the first
frame (prepare_first), the rest taken in as the preparer delivers them
(exhibit.preparing.preparing), each arrival or failure told to the attract/visitor state."""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import time
from collections.abc import Callable
from typing import Any

from exhibit.timelines.model import Timeline
from exhibit.preparing.jobs import Framers, Job, Prepared, run_job
from exhibit.preparing.preparing import InlinePreparer, Preparer
from exhibit.preparing.scene_meshes import Key, SceneMeshes
from exhibit.kiosk.state import VISITOR, KioskState
from exhibit.operations.notify import Notifier
from exhibit import progress

log = logging.getLogger("exhibit.kiosk")


def nearest_level(levels: dict[int, Any], wanted: int) -> Any:
    """The mesh at level ``wanted``, else the nearest prepared (a finer one first)."""
    if wanted in levels:
        return levels[wanted]
    return levels[min(levels, key=lambda level: (abs(level - wanted), level > wanted))]


def prepare_first(
    meshes: SceneMeshes,
    jobs: list[Job],
    framers: Framers,
    level: int,
    clock: Callable[[], float],
    notifier: Notifier | None = None,
) -> list[Timeline]:
    """The first frame's scene, here and now, before there is a state to tell: jobs in order
    until one can be shown, at mesh ``level`` only (the scene's other levels go back at the
    head of ``jobs``). Returns the playlist to start with: the framed timelines of that
    scene."""
    with progress.on_terminal():
        while jobs:
            job = jobs.pop(0)
            now_levels = tuple(lv for lv in job.levels if lv[0] == level) or job.levels[:1]
            rest = tuple(lv for lv in job.levels if lv not in now_levels)
            progress.report(f"preparing scene {job.scene}")
            if notifier is not None:
                notifier.extend_timeout(60)  # a cold mesh build may take a while
            prepared = run_job(dataclasses.replace(job, levels=now_levels), framers)
            if meshes.take_in(prepared).shown:
                if rest:
                    jobs.insert(0, dataclasses.replace(job, levels=rest, timelines=()))
                return prepared.timelines
    return []


class Content:
    """The scenes on the GPU (``meshes``) and those still coming. ``state`` (None: no scene
    could be prepared, the notice screen) gets the timelines and hears of scenes that arrive
    or fail; ``timelines``: every timeline, in the attract folder's order (where an arriving
    one goes)."""

    def __init__(
        self, meshes: SceneMeshes, state: KioskState | None, timelines: list[Timeline]
    ) -> None:
        self.meshes = meshes
        self.state = state
        self.timelines = timelines
        self.preparer: Preparer | None = None
        #: When the last scene was taken in (None while some are being prepared).
        self.prepared_at: float | None = None

    def levels(self, key: Key) -> dict[int, Any] | None:
        return self.meshes.levels(key)

    # ------------------------------------------------------------------ preparing

    def prepare_rest(
        self,
        jobs: list[Job],
        framers: Framers,
        preparer: Callable[[Framers], Preparer] | None,
        now: float,
    ) -> None:
        """The other jobs: to ``preparer(framers)``, or (None) here and now."""
        self.preparer = preparer(framers) if preparer is not None else None
        if self.preparer is None:
            for job in jobs:
                self.take_in(run_job(job, framers), now)
            self.prepared_at = now
            return
        for job in jobs:
            self.preparer.submit(job)

    def collect(self, now: float, started: float) -> None:
        """Whatever the preparer has finished, taken in (a frame's work: uploads only). A
        worker process that cannot run leaves the rest to be prepared here, one per frame."""
        begin = time.perf_counter()
        preparer = self.preparer
        assert preparer is not None  # prepare_rest without one set prepared_at: no collect
        try:
            results = preparer.results()
        except Exception as exc:  # noqa: BLE001 - no worker process: here, one per frame
            log.error(
                "the preparing process cannot run (%s: %s): the scenes left are prepared "
                "here, one per frame",
                type(exc).__name__,
                exc,
            )
            pending = preparer.pending()
            with contextlib.suppress(Exception):
                preparer.close()
            self.preparer = InlinePreparer(preparer.framers)
            for job in pending:
                self.preparer.submit(job)
            return
        self._status(preparer.status())
        for prepared in results:
            self.take_in(prepared, now)
            if prepared.error is None:
                log.info(
                    "scene %s prepared (mesh levels %s, %d timelines; %.0f ms to take in)",
                    prepared.job.scene,
                    ",".join(map(str, sorted(prepared.meshes))),
                    len(prepared.timelines),
                    (time.perf_counter() - begin) * 1000,
                )
        if not preparer.busy and self.prepared_at is None:
            self.prepared_at = now
            log.info("every scene is prepared (%.1f s after start)", now - started)

    #: How the preparer's own line in ``problems`` begins (ProcessPreparer.status:
    #: exhibit.preparing.process_preparer).
    STATUS = "preparing process "

    def _status(self, line: str | None) -> None:
        """The preparer's line in the health file's problems (workers replaced, scenes to try
        again), kept current in place."""
        problems = self.meshes.problems
        kept = [p for p in problems if not p.startswith(self.STATUS)]
        if line is not None:
            kept.append(line)
        if kept != problems:
            problems[:] = kept

    def wanted(self, key: Key) -> None:
        """A visitor is waiting for this scene: it is prepared next."""
        if self.preparer is not None:
            self.preparer.first(key)

    def close(self) -> None:
        if self.preparer is not None:
            self.preparer.close()

    # ------------------------------------------------------------------ taking in

    def take_in(self, prepared: Prepared, now: float) -> list[Timeline]:
        """A job's result: its meshes uploaded, its timelines into the playlist (in the
        attract folder's order), or the scene noted as failed and taken out. Returns the
        timelines taken in."""
        job = prepared.job
        taken = self.meshes.take_in(prepared)
        state = self.state
        if state is None:
            return prepared.timelines if taken.shown else []
        if taken.dropped:
            state.drop(job.scene, now)
        if not taken.shown:
            return []
        if taken.restored:
            state.restore(job.scene)  # back in the content list
        for timeline in prepared.timelines:
            state.playlist.insert(self._position(state, timeline), timeline, now)
        frame = state.frame
        if (
            taken.first
            and state.mode == VISITOR
            and frame.scene == job.scene
            and frame.params == job.params
        ):
            state.reframe()  # a visitor waited for it: its start view, framed now
        return prepared.timelines

    def _position(self, state: KioskState, timeline: Timeline) -> int:
        """Where ``timeline`` goes among those playing: after every one before it in the
        attract folder's order."""
        order = {(t.path, t.name): i for i, t in enumerate(self.timelines)}
        mine = order.get((timeline.path, timeline.name), len(order))
        return sum(1 for t in state.playlist.timelines if order.get((t.path, t.name), 0) < mine)

    def release(self) -> None:
        """Free every uploaded mesh (each once)."""
        self.meshes.release()
