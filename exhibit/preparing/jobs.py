"""A job: one scene with one set of parameters, its meshes at every mesh level and the attract
timelines that show it, framed clear of the text; and the work that makes its result
(run_job), the same wherever it runs (here, or a worker process: exhibit.preparing.preparing)."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from exhibit import scenes
from exhibit.timelines.model import Params, Timeline
from exhibit.framing.timeline_framing import frame_timeline
from exhibit.render.framer import Framer
from exhibit.scenes.cache import build_cached
from exhibit.scenes.base import Scene
from exhibit.surfaces.mesh import Mesh4D

log = logging.getLogger("exhibit.kiosk")


class ContentList(Protocol):
    """What scene_jobs reads of the kiosk's config (exhibit.kiosk.config.KioskConfig, above
    this package; the worker process does not load it): content.scenes and content.resolution."""

    @property
    def scenes(self) -> Sequence[str]: ...

    @property
    def resolution(self) -> Mapping[str, Any]: ...


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


def scene_jobs(
    config: ContentList, timelines: Sequence[Timeline], levels: Iterable[int]
) -> list[Job]:
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


def level_resolution(scene: Scene, configured: int | None, level: int) -> int:
    """A scene's mesh resolution at a mesh level: content.resolution (else the scene's own)
    times the level's factor."""
    from exhibit.render.quality import mesh_resolution

    return mesh_resolution(int(configured or scene.default_resolution), level)


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


def build_levels(scene: Scene, job: Job) -> dict[int, Mesh4D]:
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


def slices(scene: Scene, timeline: Timeline) -> bool:
    """Whether the timeline slices a scene that has a 3D world at each moment (the inset)."""
    return (
        scene.world_at is not None
        and timeline.slice_axis == scene.slice_axis
        and any(k.slice_at is not None for k in timeline.keyframes)
    )


def frame(timeline: Timeline, scene: Scene, mesh: Mesh4D, framers: Framers) -> Timeline:
    """The timeline framed clear of the text (exhibit.framing.timeline_framing); unchanged without a
    framer or when framing fails (never fatal: an unframed timeline still plays)."""
    framer = framers.inset if slices(scene, timeline) else framers.main
    if framer is None:
        return timeline
    try:
        return frame_timeline(framer, timeline, scene, mesh)
    except Exception as exc:  # noqa: BLE001
        log.warning("timeline %s not framed: %s", timeline.name, exc)
        return timeline
