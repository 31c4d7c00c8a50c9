"""The scenes the kiosk can show, on the GPU: the first one prepared at once for the first
frame, the rest taken in as the preparer delivers them (exhibit.kiosk.preparing), and the ones
that fail left out and named for the health file."""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import time
from collections.abc import Callable

from exhibit.kiosk.jobs import Framers, Job, Prepared, run_job
from exhibit.kiosk.preparing import InlinePreparer, Preparer
from exhibit.kiosk.state import VISITOR, KioskState
from exhibit.surfaces import progress
from exhibit.surfaces.mesh import Mesh4D

log = logging.getLogger("exhibit.kiosk")


def nearest_level(levels: dict, wanted: int):
    """The mesh at level ``wanted``, else the nearest prepared (a finer one first)."""
    if wanted in levels:
        return levels[wanted]
    return levels[min(levels, key=lambda level: (abs(level - wanted), level > wanted))]


class Content:
    """Uploaded meshes by (scene, params) and mesh level; ``state`` (the KioskState, once
    there is one) gets the timelines and hears of scenes that arrive or fail. ``problems`` and
    ``scenes_failed`` are the kiosk's lists for the health file, appended to here."""

    def __init__(
        self, upload: Callable, jobs: list[Job], problems: list[str], scenes_failed: list[dict]
    ):
        self.upload = upload
        self.gpu: dict[tuple, dict] = {}
        self.failed: set[tuple] = set()
        self.problems, self.scenes_failed = problems, scenes_failed
        #: Every timeline, in the attract folder's order (where an arriving one goes).
        self.timelines = [t for job in jobs for t in job.timelines]
        self.state: KioskState | None = None
        self.preparer: Preparer | None = None
        #: When the last scene was taken in (None while some are being prepared).
        self.prepared_at: float | None = None

    # ------------------------------------------------------------------ what is there

    def levels(self, key: tuple) -> dict | None:
        return self.gpu.get(key)

    def mesh(self, name: str, params) -> Mesh4D | None:
        """The scene's finest mesh (framing needs its bounds only), None without one."""
        levels = self.gpu.get((name, tuple(params)))
        mesh = getattr(levels[min(levels)], "mesh", None) if levels else None
        return mesh if isinstance(mesh, Mesh4D) else None

    def shown(self, names) -> tuple[str, ...]:
        """The content list less the scenes that failed (those still coming stay in)."""
        return tuple(
            name
            for name in names
            if not any(key[0] == name for key in self.failed)
            or any(key[0] == name for key in self.gpu)
        )

    # ------------------------------------------------------------------ preparing

    def prepare_first(
        self, jobs: list[Job], framers: Framers, level: int, clock, notifier=None
    ) -> list:
        """The first frame's scene, here and now: jobs in order until one can be shown, at
        mesh ``level`` only (the scene's other levels go back at the head of ``jobs``).
        Returns the playlist to start with: the framed timelines of that scene."""
        with progress.on_terminal():
            while jobs:
                job = jobs.pop(0)
                now_levels = tuple(lv for lv in job.levels if lv[0] == level) or job.levels[:1]
                rest = tuple(lv for lv in job.levels if lv not in now_levels)
                progress.report(f"preparing scene {job.scene}")
                if notifier is not None:
                    notifier.extend_timeout(60)  # a cold mesh build may take a while
                prepared = run_job(dataclasses.replace(job, levels=now_levels), framers)
                timelines = self.take_in(prepared, clock())
                if job.key in self.gpu:
                    if rest:
                        jobs.insert(0, dataclasses.replace(job, levels=rest, timelines=()))
                    return timelines
        return []

    def prepare_rest(self, jobs: list[Job], framers: Framers, preparer, now: float) -> None:
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

    #: How the preparer's own line in ``problems`` begins (exhibit.kiosk.preparing.status).
    STATUS = "preparing process "

    def _status(self, line: str | None) -> None:
        """The preparer's line in the health file's problems (workers replaced, scenes to try
        again), kept current in place."""
        kept = [p for p in self.problems if not p.startswith(self.STATUS)]
        if line is not None:
            kept.append(line)
        if kept != self.problems:
            self.problems[:] = kept

    def wanted(self, key: tuple) -> None:
        """A visitor is waiting for this scene: it is prepared next."""
        if self.preparer is not None:
            self.preparer.first(key)

    def close(self) -> None:
        if self.preparer is not None:
            self.preparer.close()

    # ------------------------------------------------------------------ taking in

    def take_in(self, prepared: Prepared, now: float) -> list:
        """A job's result: its meshes uploaded, its timelines into the playlist (in the
        attract folder's order), or the scene noted as failed and taken out. Returns the
        timelines taken in."""
        job = prepared.job
        uploaded: dict[int, object] = {}
        if prepared.error is None:
            try:
                by_mesh: dict[int, object] = {}
                for level, mesh in prepared.meshes.items():
                    if id(mesh) not in by_mesh:
                        by_mesh[id(mesh)] = self.upload(mesh)
                    uploaded[level] = by_mesh[id(mesh)]
            except Exception as exc:  # noqa: BLE001 - one scene must not stop the exhibit
                for gpu in {id(g): g for g in uploaded.values()}.values():
                    if hasattr(gpu, "release"):
                        gpu.release()
                uploaded = {}
                prepared = dataclasses.replace(prepared, error=f"{type(exc).__name__}: {exc}")
        if prepared.error is not None:
            self._failed(job, prepared.error, now)
            return []
        if job.key in self.failed:
            self._restored(job)
        waited = job.key not in self.gpu
        self.gpu.setdefault(job.key, {}).update(uploaded)
        state = self.state
        if state is not None:
            for timeline in prepared.timelines:
                state.playlist.insert(self._position(timeline), timeline, now)
            frame = state.frame
            if (
                waited
                and state.mode == VISITOR
                and frame.scene == job.scene
                and frame.params == job.params
            ):
                state.reframe()  # a visitor waited for it: its start view, framed now
        return prepared.timelines

    def _position(self, timeline) -> int:
        """Where ``timeline`` goes among those playing: after every one before it in the
        attract folder's order."""
        order = {(t.path, t.name): i for i, t in enumerate(self.timelines)}
        mine = order.get((timeline.path, timeline.name), len(order))
        assert self.state is not None  # take_in places timelines only once there is a state
        return sum(
            1 for t in self.state.playlist.timelines if order.get((t.path, t.name), 0) < mine
        )

    def _failed(self, job: Job, reason: str, now: float) -> None:
        if job.key in self.gpu:  # more mesh levels of a scene on screen: it has one already
            log.warning(
                "scene %s: mesh levels %s not prepared (%s); using the level it has",
                job.scene,
                ",".join(str(level) for level, _ in job.levels),
                reason,
            )
            return
        self.failed.add(job.key)
        log.error("scene %s skipped: %s", job.scene, reason)
        # one entry a scene: a scene tried again and failing again replaces its own
        self._forget(job)
        self.scenes_failed.append({"scene": job.scene, "reason": reason})
        self.problems.append(f"scene {job.scene} skipped: {reason}")
        for t in job.timelines:
            log.warning("attract timeline %s skipped: its scene %s failed", t.name, t.scene)
            self.problems.append(f"attract timeline {t.name} skipped (scene {t.scene})")
        if self.state is not None:
            self.state.drop(job.scene, now)

    def _forget(self, job: Job) -> None:
        """The job's scene off the health file's lists of failures (in place: the kiosk's)."""
        timelines = {f"attract timeline {t.name} skipped (scene {t.scene})" for t in job.timelines}
        self.scenes_failed[:] = [f for f in self.scenes_failed if f.get("scene") != job.scene]
        self.problems[:] = [
            p
            for p in self.problems
            if not p.startswith(f"scene {job.scene} skipped: ") and p not in timelines
        ]

    def _restored(self, job: Job) -> None:
        """A scene that failed (its worker died or stalled) and was tried again came: off the
        lists of failures, and back in the content list."""
        self.failed.discard(job.key)
        self._forget(job)
        log.info("scene %s prepared after all: it is shown again", job.scene)
        if self.state is not None:
            self.state.restore(job.scene)

    def release(self) -> None:
        """Free every uploaded mesh (each once)."""
        uploaded = {id(g): g for levels in self.gpu.values() for g in levels.values()}
        for gpu in uploaded.values():
            if hasattr(gpu, "release"):
                gpu.release()
        self.gpu = {}
