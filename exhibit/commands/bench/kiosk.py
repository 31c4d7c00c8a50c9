"""`exhibit bench kiosk [--size WxH] [--json]`: whole kiosk frames, headless, at every quality
level of the governor's ladder, with the shipped config's scenes (content.scenes, at
content.resolution and each level's mesh factor) and effects (live silhouettes, curves, the HUD
with the scene's title and caption), against the pass-through floor of the same triangles.

For each scene the levels and the floor are timed frame by frame in turn (so a noisy machine slows
all alike), the view turning every frame as a visitor's would; a frame is timed from its first
GL call to glFinish (what the kiosk's governor measures on software GL). A level's frame_ms is the
median over its frames of the slowest scene (the one the governor must hold the target for), and
floor_ms is that scene's floor: the same triangles, same size, flat pass-through shader, depth
test, one clear. ``chosen`` is the level a governor starting at the top settles on at this size
(exhibit.kiosk.governor.pick) among the levels the kiosk uses on this renderer (``used_here``:
kiosk_levels leaves out MSAA and the render scales on software GL) for the config's target
(vsync: 60 Hz here, as headless there is no display; else fps_limit). Numpy is held to one BLAS
thread while timing (exhibit.commands.bench).
With --ssim, each level's picture of the scene's own view is compared with MSAA 4x at full
scale and full mesh (exhibit.render.ssim): over the whole frame, and over the edges alone (where
the MSAA picture differs from one without antialiasing, grown by 3 pixels). With --breakdown,
where each level's frame goes: every round also draws one frame per level with the renderer's
per-pass timer on (exhibit.render.pass_timer: on software GL a glFinish at each pass boundary,
elsewhere GL timer queries), not counted in frame_ms, and reports each pass's median (ms and
share of the measured frame) for the level's slowest scene.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from typing import TYPE_CHECKING, Any

import moderngl

from exhibit.errors import ExhibitError

if TYPE_CHECKING:
    from exhibit.render.pass_timer import PassTimes

HELP = "whole kiosk frames at each quality level vs the pass-through floor (shipped config)"


def median_passes(frames: list[PassTimes]) -> tuple[dict[str, float], float]:
    """Each pass's median over measured frames (0 in a frame it did not run), in the order
    the passes ran, then "other" (the frame outside its passes), and the median total."""
    names: list[str] = []
    for times in frames:
        names += [name for name in times.passes if name not in names]
    passes = {
        name: round(statistics.median(t.passes.get(name, 0.0) for t in frames), 2) for name in names
    }
    passes["other"] = round(statistics.median(t.other_ms for t in frames), 2)
    return passes, round(statistics.median(t.total_ms for t in frames), 2)


def breakdown_line(level: str, scene: str, passes: dict[str, float], total: float) -> str:
    """One level's passes: ms and share of the measured frame."""
    parts = ", ".join(
        f"{name} {ms:.1f} ({100.0 * ms / total:.0f}%)" if total > 0 else f"{name} {ms:.1f}"
        for name, ms in passes.items()
    )
    return f"{level:>9} ({scene}): {parts}; frame {total:.1f} ms"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--size", default="1920x1080", metavar="WxH", help="frame size (default: %(default)s)"
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument(
        "--frames",
        default="12",
        metavar="N",
        help="timed frames per level and scene (default: %(default)s)",
    )
    parser.add_argument("--config", help="kiosk config (default: the layered site config)")
    parser.add_argument(
        "--scenes",
        metavar="NAME,...",
        help="only these scenes (default: the config's content.scenes)",
    )
    parser.add_argument(
        "--levels", metavar="NAME,...", help="only these levels (default: the whole ladder)"
    )
    parser.add_argument(
        "--ssim",
        action="store_true",
        help="also compare each level's picture with MSAA 4x at full scale "
        "(SSIM of the whole frame and of the edges alone)",
    )
    parser.add_argument(
        "--breakdown",
        action="store_true",
        help="also time each level's frame pass by pass (background or clear, surfaces, "
        "intersections, outlines, curves, marks, composite, HUD)",
    )


def run(args: argparse.Namespace) -> int:
    from exhibit import scenes
    from exhibit.commands.render import parse_size
    from exhibit.kiosk.config import load_kiosk_config
    from exhibit.kiosk.governor import kiosk_levels, pick, target_ms
    from exhibit.preparing.jobs import level_resolution
    from exhibit.render import Headless, HudInfo, RenderOptions, describe
    from exhibit.commands.bench.render import cpu_model
    from exhibit.render.quality import LADDER, MESH_FACTORS
    from exhibit.scenes.cache import build_cached

    size = parse_size(args.size)
    try:
        frames = int(args.frames)
    except ValueError:
        raise ExhibitError("--frames must be a whole number") from None
    if not 3 <= frames <= 1000:
        raise ExhibitError("--frames must lie in [3, 1000]")
    config = load_kiosk_config(args.config, check_linked=False)
    names = list(config.scenes)
    if args.scenes:
        names = [n.strip() for n in args.scenes.split(",") if n.strip()]
        for name in names:
            scenes.get(name)  # an unknown name is a one-line error
    levels = list(LADDER)
    if args.levels:
        wanted = [n.strip() for n in args.levels.split(",") if n.strip()]
        unknown = [n for n in wanted if n not in {q.name for q in LADDER}]
        if unknown:
            raise ExhibitError(
                f"--levels: no level {unknown[0]!r} (levels: {', '.join(q.name for q in LADDER)})"
            )
        levels = [q for q in LADDER if q.name in wanted]

    headless = Headless()
    ctx, renderer = headless.ctx, headless.renderer
    renderer_name = describe(ctx)
    renderer_timer_mode = renderer.timer.mode
    floor_target = headless.target(size, 0)
    per_scene = []
    try:
        for name in names:
            scene = scenes.get(name)
            params = scene.resolve()
            gpus = {}
            # SSIM's reference is MSAA at the full mesh, whichever levels are timed.
            meshes = {q.mesh for q in levels} | ({0} if args.ssim else set())
            for level in sorted(meshes):
                resolution = level_resolution(scene, config.resolution.get(name), level)
                mesh, _ = build_cached(scene, params, resolution)
                gpus[level] = renderer.upload(mesh)
            hud = HudInfo(scene.title, scene.caption, scene.axes)
            options = RenderOptions(hud=config.hud)
            times: dict[str, list[float]] = {q.name: [] for q in levels}
            floors: dict[int, list[float]] = {level: [] for level in gpus}
            measured: dict[str, list[PassTimes]] = {q.name: [] for q in levels}

            def floor(gpu, view):
                fbo = floor_target.framebuffer
                fbo.use()
                ctx.viewport = (0, 0, *size)
                ctx.fbo.depth_mask = True
                fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
                ctx.enable(moderngl.DEPTH_TEST)
                renderer.draw_surfaces(gpu, view, size, key="floor")
                ctx.disable(moderngl.DEPTH_TEST)

            def timed(draw, into, warm):
                start = time.perf_counter()
                draw()
                ctx.finish()
                if not warm:
                    into.append((time.perf_counter() - start) * 1e3)

            for i in range(frames + 2):  # two warm-up rounds
                turn = 0.02 * i
                angles = scene.view.angles
                view = scene.view.replace(
                    angles=(angles[0] + turn, angles[1] + 0.5 * turn, *angles[2:])
                )
                for q in levels:
                    timed(
                        lambda: headless.draw_frame(gpus[q.mesh], view, size, options, hud, q),
                        times[q.name],
                        i < 2,
                    )
                for level, gpu in gpus.items():
                    timed(lambda: floor(gpu, view), floors[level], i < 2)
                if args.breakdown:  # one more frame per level, pass by pass, not in frame_ms
                    for q in levels:
                        renderer.measure_next_frame()
                        headless.draw_frame(gpus[q.mesh], view, size, options, hud, q)
                        times_now = renderer.timer.flush()
                        if i >= 2 and times_now is not None:
                            measured[q.name].append(times_now)
            # the scene's part of the JSON report: a row per level, "none"
            rows: dict[str, dict[str, Any]] = {}
            for q in levels:
                frame_ms = statistics.median(times[q.name])
                floor_ms = statistics.median(floors[q.mesh])
                rows[q.name] = {
                    "frame_ms": round(frame_ms, 2),
                    "floor_ms": round(floor_ms, 2),
                    "triangles": gpus[q.mesh].triangle_count,
                }
                if measured[q.name]:
                    passes, total = median_passes(measured[q.name])
                    rows[q.name]["passes"] = passes
                    rows[q.name]["passes_total_ms"] = total
            if args.ssim:
                from exhibit.render.quality import Quality
                from exhibit.render.ssim import edge_mask, ssim

                view = scene.view
                reference = headless.frame(
                    gpus[0], view, size, options, hud, Quality("msaa", "msaa")
                )
                plain = headless.frame(gpus[0], view, size, options, hud, Quality("none", "none"))
                edges = edge_mask(reference, plain)
                for q in levels:
                    if q.mesh not in gpus:
                        continue
                    picture = headless.frame(gpus[q.mesh], view, size, options, hud, q)
                    rows[q.name]["ssim"] = round(ssim(picture, reference), 4)
                    rows[q.name]["ssim_edges"] = round(ssim(picture, reference, mask=edges), 4)
                rows["none"] = {
                    "ssim": round(ssim(plain, reference), 4),
                    "ssim_edges": round(ssim(plain, reference, mask=edges), 4),
                }
            per_scene.append((name, rows))
            for gpu in gpus.values():
                gpu.release()
        error = ctx.error
    finally:
        headless.release()
    if error != "GL_NO_ERROR":
        raise ExhibitError(f"OpenGL reported {error} during the benchmark")

    report_levels: list[dict[str, Any]] = []
    for q in levels:
        name, row = max(
            ((n, rows[q.name]) for n, rows in per_scene), key=lambda item: item[1]["frame_ms"]
        )
        report_levels.append(
            {
                "name": q.name,
                "frame_ms": row["frame_ms"],
                "floor_ms": row["floor_ms"],
                "antialiasing": q.antialiasing,
                "triangles": row["triangles"],
                "ratio": round(row["frame_ms"] / row["floor_ms"], 2),
                "scene": name,
                "mesh_factor": MESH_FACTORS[q.mesh],
                "effects": q.effects,
                "render_scale": q.scale,
                "scenes": {n: rows[q.name] for n, rows in per_scene},
            }
        )
        if "passes" in row:
            report_levels[-1]["passes"] = row["passes"]
            report_levels[-1]["passes_total_ms"] = row["passes_total_ms"]
        if args.ssim:
            for key in ("ssim", "ssim_edges"):
                report_levels[-1][key] = round(
                    statistics.mean(rows[q.name][key] for _, rows in per_scene), 4
                )
    target = target_ms(config, None)
    # The levels this kiosk's governor may use here (exhibit.kiosk.governor.kiosk_levels: its
    # [quality] pins; no MSAA and no smaller render scales on software GL).
    usable = {q.name for q in kiosk_levels(config.quality, renderer_name)[0]}
    for r in report_levels:
        r["used_here"] = r["name"] in usable
    candidates = [r for r in report_levels if r["used_here"]] or report_levels
    chosen = candidates[pick([r["frame_ms"] for r in candidates], target)]["name"]
    report: dict[str, Any] = {
        "size": list(size),
        "renderer": renderer_name,
        "levels": report_levels,
        "chosen": chosen,
        "target_ms": round(target, 2),
        "frames": frames,
        "cpu": cpu_model(),
        "cpus": os.cpu_count(),
        "scenes": names,
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }
    if args.breakdown:
        report["pass_timer"] = renderer_timer_mode
    if args.ssim:  # no antialiasing at all, for comparison
        report["no_antialiasing"] = {
            key: round(statistics.mean(rows["none"][key] for _, rows in per_scene), 4)
            for key in ("ssim", "ssim_edges")
        }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(
        f"renderer: {renderer_name}; {report['cpus']} x {report['cpu']}; {size[0]}x{size[1]}; "
        f"{len(names)} scenes, medians of {frames} frames; load {report['load_average']}"
    )
    print(
        f"{'level':>9} {'aa':>5} {'slowest scene':>20} {'triangles':>9} {'frame':>9} "
        f"{'floor':>8} {'ratio':>6}"
    )
    for r in report_levels:
        mark = (
            "  <- chosen"
            if r["name"] == chosen
            else ""
            if r["used_here"]
            else "  (the kiosk leaves it out here)"
        )
        quality = f"  SSIM {r['ssim']:.4f}, edges {r['ssim_edges']:.4f}" if "ssim" in r else ""
        print(
            f"{r['name']:>9} {r['antialiasing']:>5} {r['scene']:>20} {r['triangles']:>9} "
            f"{r['frame_ms']:>7.1f}ms {r['floor_ms']:>6.1f}ms {r['ratio']:>5.2f}x"
            f"{quality}{mark}"
        )
    if args.ssim:
        none = report["no_antialiasing"]
        print(
            f"no antialiasing: SSIM {none['ssim']:.4f}, edges {none['ssim_edges']:.4f} "
            "(all against MSAA 4x at full scale)"
        )
    if args.breakdown:
        how = (
            "wall time to glFinish at each pass boundary"
            if report["pass_timer"] == "wall"
            else "GL timer queries"
        )
        print(f"per pass, ms and share of a measured frame ({how}; medians, slowest scene):")
        for r in report_levels:
            if "passes" in r:
                print(breakdown_line(r["name"], r["scene"], r["passes"], r["passes_total_ms"]))
    print(f"target {target:.1f} ms per frame; the governor settles on {chosen}")
    return 0
