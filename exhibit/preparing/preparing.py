"""Meshes and framed timelines made ready off the frame path, so the first picture comes within
a second of start and the rest arrive while it plays.

The kiosk needs one scene for its first frame; everything else (the other scenes, the other
mesh levels, framing the other timelines) is a Job. Jobs run in a Preparer: ProcessPreparer in a
worker process at a lower priority (building the cusp's pipe takes seconds of pure Python: a
thread would hold the interpreter lock against the frame loop), InlinePreparer in this process
(tests, reviews, `exhibit prepare`). Either way a job's result comes back as plain data (Mesh4D,
Timeline); uploading it to the GPU is the kiosk's, on its own thread.

The jobs and their work are exhibit.preparing.jobs; ProcessPreparer is
exhibit.preparing.process_preparer (what runs in its worker: exhibit.preparing.worker; its watch
on it: exhibit.preparing.worker_watch)."""

from __future__ import annotations

from typing import Protocol

from exhibit.timelines.model import Params
from exhibit.preparing.jobs import Framers, Job, Prepared, run_job


class Preparer(Protocol):
    """Where jobs run: InlinePreparer (here) or ProcessPreparer (a worker process)."""

    framers: Framers

    def submit(self, job: Job) -> None: ...
    @property
    def busy(self) -> bool: ...
    def first(self, key: tuple[str, Params]) -> None: ...
    def pending(self) -> list[Job]: ...
    def results(self) -> list[Prepared]: ...
    def status(self) -> str | None: ...
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

    def first(self, key: tuple[str, Params]) -> None:
        """The job for ``key`` (scene, params), if waiting, runs next."""
        self._queue.sort(key=lambda job: job.key != key)

    def pending(self) -> list[Job]:
        return list(self._queue)

    def results(self) -> list[Prepared]:
        return [run_job(self._queue.pop(0), self.framers)] if self._queue else []

    def status(self) -> str | None:
        """Nothing to report: no worker to lose."""
        return None

    def close(self) -> None:
        self._queue.clear()
