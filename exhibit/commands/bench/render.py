"""`exhibit bench render`: frame times of the renderer at 1280x720 on the Hopf scene.

For each mesh size, three ways to draw the same triangles into the same framebuffer, timed
frame by frame in turn (so a noisy machine slows all three alike):

* pipeline: the real surface pass — buffers uploaded once, per frame only uniforms; the vertex
  shader does pose, sensor projection, eye, gl_ClipDistance and the Lemma 1(c) normal;
* cpu_baseline: numpy computes clip positions, clip distances and projected normals each frame and
  uploads them (the "project on the CPU" design), drawn with the same lighting;
* floor: the same vertex buffers through a bare pass-through shader (one matrix, flat colour):
  what rasterising these triangles costs at all.

frame_ms adds the rest of a kiosk frame: background, live silhouettes (geometry shader), curves
and the HUD. intersections_ms is what the intersection curves of the 3D image add to the
surface pass: the same surfaces drawn with each pixel's sheet and depth plane beside the colour,
then the full-screen pass that inks the crossings (sheets_ms), less pipeline_ms. slice_ms is what
the glowing slice w = c adds to the whole frame (sliced_frame_ms less frame_ms: its marching in
the silhouette pass). The time-slice inset costs inset_cpu_ms (the slice traced and refined onto
the exact surface on the CPU, each time c changes) and inset_gpu_ms (its curves uploaded and
drawn at the inset's size, 0.36 of the height). Every frame turns the view a little, as a
visitor would, and moves the slice.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import time
from typing import TYPE_CHECKING

import moderngl
import numpy as np

from exhibit.errors import ExhibitError
from exhibit.geometry.pipeline import clip_transform
from exhibit.render import shaders

if TYPE_CHECKING:
    from exhibit.geometry.view import ViewState
    from exhibit.render.renderer import Renderer
    from exhibit.surfaces.mesh import Mesh4D

HELP = "renderer frame times: pipeline vs CPU baseline vs pass-through floor (Hopf scene)"
DEFAULT_TRIANGLES = "20k,200k,1M"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument(
        "--size", default="1280x720", metavar="WxH", help="framebuffer size (default: %(default)s)"
    )
    parser.add_argument(
        "--triangles",
        default=DEFAULT_TRIANGLES,
        metavar="N,...",
        help="approximate triangle counts, k/M suffixes (default: %(default)s)",
    )
    parser.add_argument(
        "--frames",
        default="15",
        metavar="N",
        help="timed frames per variant (default: %(default)s)",
    )
    parser.add_argument(
        "--samples", default="0", metavar="S", help="multisampling samples (default: %(default)s)"
    )


def parse_count(text: str) -> int:
    t = text.strip().lower()
    factor = 1
    if t.endswith("k"):
        factor, t = 1000, t[:-1]
    elif t.endswith("m"):
        factor, t = 1_000_000, t[:-1]
    try:
        value = float(t) * factor
    except ValueError:
        raise ExhibitError(f"--triangles: {text!r} is not a count like 20k or 1M") from None
    if not 100 <= value <= 20_000_000:
        raise ExhibitError(f"--triangles: {text!r} must lie between 100 and 20M")
    return int(value)


class CpuBaseline:
    """Per frame on the CPU: clip position, clip distances, Lemma 1(c) normal, view vector."""

    def __init__(self, ctx: moderngl.Context, renderer: Renderer, mesh: Mesh4D) -> None:
        self.ctx = ctx
        self.program = shaders.program(ctx, "baseline.glsl")
        self.renderer = renderer
        self.parts = []
        for s in mesh.surfaces:
            vbo = ctx.buffer(reserve=len(s.positions) * 12 * 4, dynamic=True)
            ibo = ctx.buffer(np.ascontiguousarray(s.triangles, dtype=np.int32).tobytes())
            vao = ctx.vertex_array(
                self.program,
                [(vbo, "4f 2f 3f 3f", "in_clip", "in_clip_distance", "in_normal", "in_to_eye")],
                index_buffer=ibo,
                index_element_size=4,
            )
            self.parts.append((s, vbo, ibo, vao))

    def draw(self, view: ViewState, size: tuple[int, int]) -> None:
        ct = clip_transform(view, size[0] / size[1])
        rotation, offset = ct.pose[:4, :4], ct.pose[:4, 4]
        r1, r2 = view.sensor_r, view.eye_r
        prog = self.program
        lights = np.zeros((2, 3), dtype=np.float32)
        lights[: len(view.lights[:2])] = view.lights[:2]
        uniform(prog, "u_lights").write(lights.tobytes())
        self.renderer.clip_distances(True)
        self.ctx.polygon_offset = (1.0, 1.0)
        for s, vbo, _, vao in self.parts:
            p = s.positions
            q = p @ rotation.T + offset
            m1 = s.normals[:, 0] @ rotation.T
            m2 = s.normals[:, 1] @ rotation.T
            rho = -r1 * q
            rho[:, 3] += 1.0
            a = np.einsum("ij,ij->i", m2, rho)[:, None]
            b = np.einsum("ij,ij->i", m1, rho)[:, None]
            data = np.empty((len(p), 12), dtype=np.float32)
            data[:, 0:4] = p @ ct.matrix[:, :4].T + ct.matrix[:, 4]
            data[:, 4:6] = p @ ct.clip_planes[:, :4].T + ct.clip_planes[:, 4]
            data[:, 6:9] = (a * m1 - b * m2)[:, :3]
            data[:, 9:12] = -r2 * q[:, :3]
            data[:, 11] += rho[:, 3]
            vbo.write(data.tobytes())
            uniform(prog, "u_color").value = tuple(s.material.color)
            vao.render(moderngl.TRIANGLES)
        self.ctx.polygon_offset = (0.0, 0.0)
        self.renderer.clip_distances(False)

    def release(self) -> None:
        for _, vbo, ibo, vao in self.parts:
            vao.release()
            vbo.release()
            ibo.release()
        self.program.release()


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def run(args: argparse.Namespace) -> int:
    from exhibit import scenes
    from exhibit.commands.render import parse_size
    from exhibit.render import Headless, HudInfo, RenderOptions, describe
    from exhibit.render.inset import inset_mesh, inset_view

    size = parse_size(args.size)
    counts = [parse_count(t) for t in args.triangles.split(",")]
    try:
        frames = int(args.frames)
        samples = int(args.samples)
    except ValueError:
        raise ExhibitError("--frames and --samples must be whole numbers") from None
    if not 3 <= frames <= 1000 or not 0 <= samples <= 16:
        raise ExhibitError("--frames must lie in [3, 1000] and --samples in [0, 16]")

    scene = scenes.get("hopf")
    headless = Headless()
    ctx, renderer = headless.ctx, headless.renderer
    target = headless.target(size, samples)
    fbo = target.framebuffer
    sheets = headless.pipeline.target(size, samples, "sheets")
    hud = HudInfo(scene.title, scene.caption, scene.axes)
    results = []
    try:
        for count in counts:
            resolution = max(4, round(math.sqrt(count / 6)))  # 3 tori x 2 n^2 triangles
            mesh = scene.build({}, resolution)
            gpu = renderer.upload(mesh)
            baseline = CpuBaseline(ctx, renderer, mesh)

            def surfaces_only(draw):
                fbo.use()
                ctx.viewport = (0, 0, *size)
                ctx.fbo.depth_mask = True
                fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
                ctx.enable(moderngl.DEPTH_TEST)
                draw()

            def with_sheets(v):
                sheets.framebuffer.use()
                ctx.viewport = (0, 0, *size)
                ctx.fbo.depth_mask = True
                sheets.clear()
                ctx.enable(moderngl.DEPTH_TEST)
                assert sheets.sheet_framebuffer is not None  # the "sheets" target has one
                sheets.sheet_framebuffer.use()
                renderer.draw_surfaces(gpu, v, size, sheets=True)
                sheets.framebuffer.use()
                renderer.draw_intersections(gpu, sheets, size, options, v)

            options = RenderOptions()
            inset_size = (round(0.48 * size[1]), round(0.36 * size[1]))
            inset_target = headless.target(inset_size, samples)
            inset_meshes = []

            def inset_cpu(v):
                inset_meshes.append(inset_mesh(scene, {}, mesh, 3, v.slice_at))

            def inset_gpu(v):
                world = inset_meshes.pop()
                inset_gpu_mesh = renderer.upload(world)
                renderer.render(
                    inset_gpu_mesh,
                    inset_view(v, world, inset_size),
                    inset_target.framebuffer,
                    RenderOptions(hud=False),
                )
                inset_gpu_mesh.release()

            variants = {
                "sheets_ms": with_sheets,
                "pipeline_ms": lambda v: surfaces_only(
                    lambda: renderer.draw_surfaces(gpu, v, size)
                ),
                "cpu_baseline_ms": lambda v: surfaces_only(lambda: baseline.draw(v, size)),
                "floor_ms": lambda v: surfaces_only(
                    lambda: renderer.draw_surfaces(gpu, v, size, key="floor")
                ),
                "frame_ms": lambda v: renderer.render(gpu, v, fbo, RenderOptions(), hud),
                "sliced_frame_ms": lambda v: renderer.render(
                    gpu, v.replace(slice_axis=3), fbo, RenderOptions(), hud
                ),
                "inset_cpu_ms": inset_cpu,
                "inset_gpu_ms": inset_gpu,
            }
            times: dict[str, list[float]] = {key: [] for key in variants}
            for i in range(frames + 2):  # two warm-up frames
                view = scene.view.replace(
                    angles=(0.02 * i, -0.3 + 0.01 * i, -0.2, 0.4, -0.3, 0.0),
                    slice_at=0.3 * math.sin(0.2 * i),
                )
                for key, draw in variants.items():
                    start = time.perf_counter()
                    draw(view)
                    ctx.finish()
                    if i >= 2:
                        times[key].append((time.perf_counter() - start) * 1000.0)
            row: dict[str, float] = {"triangles": gpu.triangle_count}
            row.update({k: round(statistics.median(v), 2) for k, v in times.items()})
            row["intersections_ms"] = round(row["sheets_ms"] - row["pipeline_ms"], 2)
            row["slice_ms"] = round(row["sliced_frame_ms"] - row["frame_ms"], 2)
            results.append(row)
            baseline.release()
            gpu.release()
        renderer_name = describe(ctx)
        error = ctx.error
    finally:
        headless.release()
    if error != "GL_NO_ERROR":
        raise ExhibitError(f"OpenGL reported {error} during the benchmark")
    report = {
        "size": list(size),
        "renderer": renderer_name,
        "samples": samples,
        "cpu": cpu_model(),
        "cpus": os.cpu_count(),
        "results": results,
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(
        f"renderer: {renderer_name}; {report['cpus']} x {report['cpu']}; "
        f"{size[0]}x{size[1]}, {samples or 'no'} MSAA samples; medians of {frames} frames"
    )
    print(
        f"{'triangles':>10} {'pipeline':>10} {'cpu base':>10} {'floor':>10} "
        f"{'pipe/floor':>10} {'base/pipe':>10} {'full frame':>11} {'intersect':>10} "
        f"{'slice':>8} {'inset cpu':>10} {'inset gpu':>10}"
    )
    for r in results:
        print(
            f"{r['triangles']:>10} {r['pipeline_ms']:>8.1f}ms {r['cpu_baseline_ms']:>8.1f}ms "
            f"{r['floor_ms']:>8.1f}ms {r['pipeline_ms'] / r['floor_ms']:>9.2f}x "
            f"{r['cpu_baseline_ms'] / r['pipeline_ms']:>9.2f}x {r['frame_ms']:>9.1f}ms "
            f"{r['intersections_ms']:>+8.1f}ms {r['slice_ms']:>+6.1f}ms "
            f"{r['inset_cpu_ms']:>8.1f}ms {r['inset_gpu_ms']:>8.1f}ms"
        )
    return 0


def uniform(program: moderngl.Program, name: str) -> moderngl.Uniform:
    """A program's uniform by name (moderngl types the lookup as any member)."""
    member = program[name]
    assert isinstance(member, moderngl.Uniform), name
    return member
