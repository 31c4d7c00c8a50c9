"""`exhibit prepare`: fill the mesh cache with every mesh the kiosk will load, and the speech
cache with every narration it may speak (exhibit.kiosk.narrator), so its next start is a warm
one. `exhibit install` and the update run it as the service's user before the service
(re)starts; after a change to a scene or the code, the first boot would otherwise build meshes
while the visitors wait for the scenes beyond the first."""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

from exhibit import scenes
from exhibit.timelines.file import load_playlist
from exhibit.kiosk.config import KioskConfig, load_kiosk_config
from exhibit.kiosk.governor import kiosk_levels
from exhibit.kiosk.narrator import prepare_all, report_lines
from exhibit.preparing.jobs import run_job, scene_jobs
from exhibit.scenes.cache import cache_dir, entry_path, entry_problem
from exhibit import progress

HELP = "build the mesh cache the kiosk loads at start (run before the service starts)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--config",
        help="site config over the shipped defaults (default: "
        "$EXHIBIT_CONFIG, else the shipped one)",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def mesh_levels_for(config: KioskConfig) -> list[int]:
    """Every mesh level the kiosk may use on any machine: its ladder on a GPU and on software
    GL (the renderer is only known once the kiosk's window is open)."""
    quality = getattr(config, "quality", None)
    return sorted(
        {
            level.mesh
            for renderer in ("", "llvmpipe")
            for level in kiosk_levels(quality, renderer)[0]
        }
    )


def _not_cached(job, resolutions: list[int]) -> str | None:
    """Why a scene built without an error left no mesh in the cache (the cache only warns when
    it cannot store one: a warm start is what prepare promises), or None."""
    scene = scenes.get(job.scene)
    for resolution in resolutions:
        problem = entry_problem(entry_path(scene, dict(job.params), resolution))
        if problem is not None:
            return f"not cached: {problem}"
    return None


def run(args: argparse.Namespace) -> int:
    config = load_kiosk_config(args.config)
    timelines = (
        load_playlist(config.attract_dir, scenes.get) if config.attract_dir is not None else []
    )
    jobs = scene_jobs(config, timelines, mesh_levels_for(config))
    report: list[dict[str, Any]] = []  # one JSON object a scene
    with progress.on_terminal():
        for i, job in enumerate(jobs, 1):
            progress.report(f"preparing scene {i}/{len(jobs)}: {job.scene}")
            start = time.perf_counter()
            prepared = run_job(job)
            resolutions = sorted({r for _, r in job.levels})
            report.append(
                {
                    "scene": job.scene,
                    "params": dict(job.params),
                    "resolutions": resolutions,
                    "seconds": round(time.perf_counter() - start, 2),
                    "error": prepared.error or _not_cached(job, resolutions),
                }
            )
    failed = [r for r in report if r["error"]]
    speech_start = time.perf_counter()
    with progress.on_terminal():
        spoken = prepare_all(config, timelines, progress.report)
    speech: dict[str, Any] = {
        "segments": len(spoken),
        "seconds": round(time.perf_counter() - speech_start, 2),
        "spoken_s": round(sum(p.seconds or 0.0 for p in spoken), 1),
        "failed": report_lines(  # those skipped after a hang: counted on its line
            (
                f"{p.timeline}: keyframe[{p.segment.keyframe}] ({p.segment.language})",
                p.error,
                p.skipped,
            )
            for p in spoken
            if p.error
        ),
        "skipped": sum(p.skipped for p in spoken),
    }
    unmade = sum(1 for p in spoken if p.error)
    if args.json:
        print(
            json.dumps({"cache": str(cache_dir()), "scenes": report, "narration": speech}, indent=2)
        )
    else:
        print(f"mesh cache: {cache_dir()}")
        repeated = {
            r["scene"] for r in report if [q["scene"] for q in report].count(r["scene"]) > 1
        }
        for r in report:
            what = f"failed: {r['error']}" if r["error"] else f"{r['seconds']:.2f} s"
            # a scene shown with several parameter sets (the collision's figures) says which
            given = ", ".join(f"{k}={v:g}" for k, v in r["params"].items())
            name = f"{r['scene']} ({given})" if r["scene"] in repeated and given else r["scene"]
            print(f"  {name:<20} resolutions {', '.join(map(str, r['resolutions']))}: {what}")
        print(f"{len(report) - len(failed)} of {len(report)} scenes ready")
        print(
            f"narration: {speech['segments'] - unmade} of {speech['segments']} "
            f"segments ready ({speech['spoken_s']:.0f} s of speech, made in "
            f"{speech['seconds']:.1f} s)"
        )
        for line in speech["failed"]:
            print(f"  {line}")
    return 1 if failed or unmade else 0
