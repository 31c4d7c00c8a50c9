"""The scenes on the GPU: each (scene, params)'s uploaded meshes by mesh level, the scenes that
failed, and the health file's lists of failures. Kept apart from what arrives later
(exhibit.kiosk.content) so the attract/visitor state, which frames views around these meshes,
is built on it whole before anything arrives after the first scene."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from exhibit.preparing.jobs import Job, Prepared
from exhibit.surfaces.mesh import Mesh4D

log = logging.getLogger("exhibit.kiosk")

Key = tuple[str, tuple]


@dataclass(frozen=True)
class TakenIn:
    """What taking in a job's result did. ``shown``: its meshes are on the GPU; ``first``: the
    scene had none before (a visitor may wait for it); ``restored``: it had failed and is back;
    ``dropped``: it failed with no mesh to fall back on, and is to be left out."""

    shown: bool = False
    first: bool = False
    restored: bool = False
    dropped: bool = False


class SceneMeshes:
    """Uploaded meshes by (scene, params) and mesh level (``upload(mesh)`` makes one; the
    kiosk's renderer, or a test's stand-in), and the meshes they came from. ``problems`` and
    ``scenes_failed`` are the kiosk's lists for the health file, kept current here in place."""

    def __init__(
        self, upload: Callable[[Mesh4D], Any], problems: list[str], scenes_failed: list[dict]
    ) -> None:
        self.upload = upload
        self.gpu: dict[Key, dict[int, Any]] = {}
        self.failed: set[Key] = set()
        self.problems, self.scenes_failed = problems, scenes_failed
        #: The meshes uploaded, by key and level (framing measures the finest).
        self._sources: dict[Key, dict[int, Mesh4D]] = {}

    def levels(self, key: Key) -> dict[int, Any] | None:
        return self.gpu.get(key)

    def mesh(self, name: str, params: Iterable) -> Mesh4D | None:
        """The scene's finest mesh (framing needs its bounds only), None without one."""
        sources = self._sources.get((name, tuple(params)))
        mesh = sources[min(sources)] if sources else None
        return mesh if isinstance(mesh, Mesh4D) else None

    def shown(self, names: Iterable[str]) -> tuple[str, ...]:
        """The content list less the scenes that failed (those still coming stay in)."""
        return tuple(
            name
            for name in names
            if not any(key[0] == name for key in self.failed)
            or any(key[0] == name for key in self.gpu)
        )

    def take_in(self, prepared: Prepared) -> TakenIn:
        """A job's result: its meshes uploaded (each distinct mesh once), or the scene noted as
        failed (an upload that raises fails it too)."""
        job = prepared.job
        uploaded: dict[int, Any] = {}
        if prepared.error is None:
            try:
                by_mesh: dict[int, Any] = {}
                for level, mesh in prepared.meshes.items():
                    if id(mesh) not in by_mesh:
                        by_mesh[id(mesh)] = self.upload(mesh)
                    uploaded[level] = by_mesh[id(mesh)]
            except Exception as exc:  # noqa: BLE001 - one scene must not stop the exhibit
                _release(uploaded.values())
                uploaded = {}
                prepared = dataclasses.replace(prepared, error=f"{type(exc).__name__}: {exc}")
        if prepared.error is not None:
            return TakenIn(dropped=self._failed(job, prepared.error))
        restored = job.key in self.failed
        if restored:
            self._restored(job)
        first = job.key not in self.gpu
        self.gpu.setdefault(job.key, {}).update(uploaded)
        self._sources.setdefault(job.key, {}).update(prepared.meshes)
        return TakenIn(shown=True, first=first, restored=restored)

    def _failed(self, job: Job, reason: str) -> bool:
        """Whether the scene is now left out (False: it keeps the mesh levels it has)."""
        if job.key in self.gpu:  # more mesh levels of a scene on screen: it has one already
            log.warning(
                "scene %s: mesh levels %s not prepared (%s); using the level it has",
                job.scene,
                ",".join(str(level) for level, _ in job.levels),
                reason,
            )
            return False
        self.failed.add(job.key)
        log.error("scene %s skipped: %s", job.scene, reason)
        # one entry a scene: a scene tried again and failing again replaces its own
        self._forget(job)
        self.scenes_failed.append({"scene": job.scene, "reason": reason})
        self.problems.append(f"scene {job.scene} skipped: {reason}")
        for t in job.timelines:
            log.warning("attract timeline %s skipped: its scene %s failed", t.name, t.scene)
            self.problems.append(f"attract timeline {t.name} skipped (scene {t.scene})")
        return True

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
        lists of failures."""
        self.failed.discard(job.key)
        self._forget(job)
        log.info("scene %s prepared after all: it is shown again", job.scene)

    def release(self) -> None:
        """Free every uploaded mesh (each once)."""
        _release(g for levels in self.gpu.values() for g in levels.values())
        self.gpu = {}
        self._sources = {}


def _release(uploaded: Iterable[Any]) -> None:
    """Each distinct GPU mesh freed once (a test's stand-ins have nothing to free)."""
    for gpu in {id(g): g for g in uploaded}.values():
        if hasattr(gpu, "release"):
            gpu.release()
