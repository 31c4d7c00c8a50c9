"""The object-id pass: every named object of a scene (each surface, curve and marker) drawn in a
flat colour that is its id, depth-tested as the picture draws them, and read back.

Why: a caption's claims about the picture ("the green doughnut grows", "the red curve is
visible") are measured on what is on screen, never by colour (two objects may share one, and a
colour-blind visitor cannot tell them apart either). The pass reads the mesh's GPU buffers and
writes an RGBA8 colour and a depth buffer of its own; it also draws each triangle in its own id,
which the clipping tests read back.

Reads: GpuMesh (surfaces' vertex arrays "object_ids"/"ids", the mesh's curves and markers),
ViewState. Writes: its own framebuffer of the asked size, no multisampling. GL state on return:
depth test and blending off, clip distances off.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render import shaders
from exhibit.render.gpu import (
    CENTRE_UNITS,
    LINE_BIAS,
    MARKER_MIN,
    MARKER_SCALE,
    SLICE_WIDTH,
    GpuMesh,
    GpuSurface,
    curve_rows,
    segment_rows,
    silhouette_key,
    wire_rows,
)
from exhibit.render.options import RenderOptions
from exhibit.render.passes.shared import Pipeline, segment_array, surface_array

#: Object ids are 24-bit colours; 0 is the background.
MAX_OBJECTS = (1 << 24) - 1
#: The marks the silhouette pass finds live, after the mesh's own objects: the Lemma 3
#: outlines, the Lemma 2 points' discs and the glowing slice (when the view has one).
MARKS = ("outline", "pinch points", "slice")


@dataclass(frozen=True)
class ObjectCoverage:
    """What one id frame shows: per object name, the pixels where it is in front; the frame's
    size. Objects of one name (a curve drawn in several pieces) add up."""

    pixels: dict[str, int]
    size: tuple[int, int]

    def share(self, name: str) -> float:
        """The share of the screen ``name`` covers (0..1)."""
        return self.pixels.get(name, 0) / float(self.size[0] * self.size[1])


def object_names(gpu: GpuMesh) -> list[str]:
    """The objects in id order (id = index + 1): solid surfaces, then wire surfaces and curves
    in the order the mesh lists them, then markers."""
    mesh = gpu.mesh
    wires = [s.name for s in mesh.surfaces if s.material.style == "wire"]
    return (
        [s.name for s in gpu.surfaces]
        + wires
        + [c.name for c in mesh.curves]
        + [m.name for m in mesh.markers]
        + list(MARKS)
    )


def _id_colour(i: int) -> tuple[float, float, float]:
    return ((i & 255) / 255.0, ((i >> 8) & 255) / 255.0, ((i >> 16) & 255) / 255.0)


def _decode(rgb: np.ndarray) -> np.ndarray:
    rgb = rgb.astype(np.int64)
    return rgb[..., 0] | (rgb[..., 1] << 8) | (rgb[..., 2] << 16)


class ObjectIdPass:
    """Owns the id programs. What it needs of a mesh (vertex arrays on its programs, the curves
    and markers in id colours) is made on first use and kept on the GpuMesh, so it is freed with
    the mesh (GpuMesh.release)."""

    def __init__(self, ctx: moderngl.Context, pipeline: Pipeline) -> None:
        self.ctx, self.pipeline = ctx, pipeline
        self.programs = {
            "object_ids": shaders.program(ctx, "surface.glsl", ("OBJECT_IDS",)),
            "ids": shaders.program(ctx, "surface.glsl", ("TRIANGLE_IDS",)),
            "curves": shaders.program(ctx, "curves.glsl"),
            "silhouette": shaders.program(ctx, "silhouette.glsl"),
            "silhouette_slice": shaders.program(ctx, "silhouette.glsl", ("TOUCHING",)),
        }
        self._targets: dict[tuple[int, int], tuple] = {}

    # ------------------------------------------------------------------ frames

    def objects(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions = RenderOptions(),
        covered: np.ndarray | None = None,
        image: np.ndarray | None = None,
    ) -> ObjectCoverage:
        """Each object's pixels in front at ``view`` and ``size`` (curves and markers as wide
        as ``options`` draws them at that size), leaving out those ``covered`` marks (a
        (height, width) boolean mask: what the HUD covers, exhibit.render.hud_cover);
        ``image``: the id image of that view and size when already read."""
        names = object_names(gpu)
        ids = self.image(gpu, view, size, options) if image is None else image
        shown = ids if covered is None else ids[~covered]
        counts = np.bincount(shown.ravel(), minlength=len(names) + 1)
        pixels: dict[str, int] = {}
        for i, name in enumerate(names):
            pixels[name] = pixels.get(name, 0) + int(counts[i + 1])
        return ObjectCoverage(pixels, (int(size[0]), int(size[1])))

    def image(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions = RenderOptions(),
    ) -> np.ndarray:
        """(height, width) object id per pixel, top row first: 0 the background, i + 1 the
        i-th of object_names(gpu)."""
        names = object_names(gpu)
        if len(names) > MAX_OBJECTS:
            raise ValueError(f"{len(names)} objects: more than {MAX_OBJECTS} ids")
        framebuffer = self._begin(size)
        prog = self.programs["object_ids"]
        self.pipeline.set_pipeline(prog, view, size)
        self.pipeline.clip_distances(True)
        self.ctx.polygon_offset = (1.0, 1.0)  # as the picture's surfaces: curves on them win
        for i, surface in enumerate(gpu.surfaces):
            prog["u_id_offset"] = i + 1
            self._surface_vao(surface, "object_ids").render(moderngl.TRIANGLES)
        self.ctx.polygon_offset = (0.0, 0.0)
        self.pipeline.clip_distances(False)
        # As the picture: the outlines, the curves over them, the discs and the slice on top.
        marks = len(names) - len(MARKS) + 1
        self._marks(gpu, view, size, options, first_id=marks, outlines=True)
        self._curves(gpu, view, size, options, first_id=len(gpu.surfaces) + 1)
        self._marks(gpu, view, size, options, first_id=marks, outlines=False)
        return self._end(framebuffer, size)

    def footprints(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions = RenderOptions(),
        surfaces: tuple[int, ...] = (),
    ) -> dict[str, int]:
        """Each object's pixels with nothing in front of it: the surfaces whose indices are
        in ``surfaces`` each drawn alone, the curves and markers together without the
        surfaces (they seldom cross each other). A claim that an object is visible compares
        what shows of it with this."""
        names = object_names(gpu)
        counts = np.zeros(len(names) + 1, dtype=np.int64)
        prog = self.programs["object_ids"]
        for i in surfaces:
            framebuffer = self._begin(size)
            self.pipeline.set_pipeline(prog, view, size)
            self.pipeline.clip_distances(True)
            prog["u_id_offset"] = i + 1
            self._surface_vao(gpu.surfaces[i], "object_ids").render(moderngl.TRIANGLES)
            self.pipeline.clip_distances(False)
            counts[i + 1] = int(np.count_nonzero(self._end(framebuffer, size)))
        framebuffer = self._begin(size)
        self.ctx.disable(moderngl.DEPTH_TEST)
        self._curves(gpu, view, size, options, first_id=len(gpu.surfaces) + 1)
        lines = np.bincount(self._end(framebuffer, size).ravel(), minlength=len(names) + 1)
        counts[len(gpu.surfaces) + 1 :] = lines[len(gpu.surfaces) + 1 : len(names) + 1]
        out: dict[str, int] = {}
        for i, name in enumerate(names):
            out[name] = out.get(name, 0) + int(counts[i + 1])
        return out

    def triangles(self, gpu: GpuMesh, view: ViewState, size: tuple[int, int]) -> np.ndarray:
        """(height, width) triangle id + 1 per pixel (0 = background; surfaces numbered in
        order): the clipping tests check each pixel against the exact triangle."""
        framebuffer = self._begin(size)
        prog = self.programs["ids"]
        self.pipeline.set_pipeline(prog, view, size)
        self.pipeline.clip_distances(True)
        offset = 0
        for surface in gpu.surfaces:
            prog["u_id_offset"] = offset
            self._surface_vao(surface, "ids").render(moderngl.TRIANGLES)
            offset += surface.triangle_count
        self.pipeline.clip_distances(False)
        return self._end(framebuffer, size)

    # ------------------------------------------------------------------ parts

    def _begin(self, size: tuple[int, int]) -> moderngl.Framebuffer:
        size = (int(size[0]), int(size[1]))
        if size not in self._targets:
            colour = self.ctx.renderbuffer(size, 4)
            depth = self.ctx.depth_renderbuffer(size)
            self._targets[size] = (self.ctx.framebuffer([colour], depth), colour, depth)
        framebuffer = self._targets[size][0]
        framebuffer.use()
        self.ctx.viewport = (0, 0, *size)
        framebuffer.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.depth_func = "<"
        return framebuffer

    def _end(self, framebuffer: moderngl.Framebuffer, size: tuple[int, int]) -> np.ndarray:
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        data = framebuffer.read(components=3, alignment=1)
        rgb = np.frombuffer(data, dtype=np.uint8).reshape(size[1], size[0], 3)[::-1]
        return _decode(rgb)

    def _surface_vao(self, surface: GpuSurface, key: str) -> moderngl.VertexArray:
        # kept on the surface under a name of this pass's own (passes.shared.surface_array)
        return surface_array(self.ctx, surface, self.programs[key], "ids:" + key)

    def _curves(self, gpu, view, size, options: RenderOptions, first_id: int) -> None:
        """Wire surfaces, curves and markers, each segment in its object's id, opaque cores
        only (the picture's pass 0), depth-tested against the surfaces."""
        if "object_ids" not in gpu.buffers and "object_ids_markers" not in gpu.buffers:
            self._upload_lines(gpu, first_id)
        prog = self.programs["curves"]
        self.pipeline.set_pipeline(prog, view, size)
        shaders.set_uniforms(
            prog,
            {
                "u_line_bias": LINE_BIAS,
                "u_width_scale": options.width_scale(size[1]) * options.curve_width,
                "u_centre_test": 0,
                # samplers of two types may not share a unit, even unread
                "u_surface_depth": CENTRE_UNITS[0],
                "u_surface_depth_ms": CENTRE_UNITS[1],
                "u_pass": 0,
            },
        )
        self.ctx.depth_func = "<="
        for key in ("object_ids", "object_ids_markers"):
            if key == "object_ids_markers":
                # The HUD draws a labelled marker again above the surfaces (a ring where it is
                # behind one): it is never hidden.
                self.ctx.disable(moderngl.DEPTH_TEST)
            if key in gpu.buffers:
                buffer = gpu.buffers[key]
                vao = segment_array(self.ctx, gpu, buffer, prog, "ids:" + key)
                vao.render(moderngl.TRIANGLE_STRIP, vertices=4, instances=buffer.size // (13 * 4))
        self.ctx.depth_func = "<"

    def _marks(
        self, gpu, view, size, options: RenderOptions, first_id: int, outlines: bool
    ) -> None:
        """The silhouette pass's marks as the picture draws them (depth-tested, no depth
        writes), each kind in its own id: the outlines (``outlines``, before the curves), or
        the Lemma 2 discs and the slice (after them). Opaque cores only (pass 0)."""
        if not gpu.surfaces:
            return
        sliced = view.slice_axis is not None
        axis = np.zeros(4)
        if sliced:
            axis[view.slice_axis] = 1.0
        outline, pinch, slice_ = (_id_colour(first_id + k) for k in range(3))
        ink = options.silhouette_width if options.silhouettes else 0.0
        disc = options.pinch_size if options.pinch_points and options.silhouettes else 0.0
        self.ctx.depth_func = "<="
        self.ctx.fbo.depth_mask = False
        ink_width, slice_width, disc_width = (
            (ink, 0.0, 0.0) if outlines else (0.0, SLICE_WIDTH if sliced else 0.0, disc)
        )
        if ink_width or slice_width or disc_width:
            for surface in gpu.surfaces:
                key = silhouette_key(surface, view, slice_width)
                prog = self.programs[key]
                self.pipeline.set_pipeline(prog, view, size)
                shaders.set_uniforms(
                    prog,
                    {
                        "u_line_bias": LINE_BIAS,
                        "u_width_scale": options.width_scale(size[1]),
                        "u_pass": 0,
                        "u_slice_axis": tuple(axis),
                        "u_slice_at": view.slice_at,
                        "u_pinch": (*pinch, disc_width),
                        "u_slice_style": (*slice_, slice_width),
                        "u_ink": (*outline, ink_width),
                    },
                )
                self._surface_vao(surface, key).render(moderngl.TRIANGLES)
        self.ctx.fbo.depth_mask = True
        self.ctx.depth_func = "<"

    def _upload_lines(self, gpu: GpuMesh, first_id: int) -> None:
        mesh = gpu.mesh
        rows: list[np.ndarray] = []
        next_id = first_id
        for surface in mesh.surfaces:
            if surface.material.style != "wire":
                continue
            rows.append(wire_rows(surface, _id_colour(next_id)))
            next_id += 1
        for curve in mesh.curves:
            row = curve_rows(curve, _id_colour(next_id))
            if row is not None:
                rows.append(row)
            next_id += 1
        markers = []
        for marker in mesh.markers:
            width = max(MARKER_SCALE * marker.material.line_width, MARKER_MIN) + 3.0
            p = marker.position[None]
            markers.append(segment_rows(p, p, _id_colour(next_id), width))
            next_id += 1
        for key, parts in (("object_ids", rows), ("object_ids_markers", markers)):
            if not parts:
                continue
            data = np.concatenate(parts).astype(np.float32)
            gpu.buffers[key] = self.ctx.buffer(data.tobytes())

    # ------------------------------------------------------------------ lifetime

    def release(self) -> None:
        for framebuffer, colour, depth in self._targets.values():
            framebuffer.release()
            colour.release()
            depth.release()
        self._targets.clear()
        for prog in self.programs.values():
            prog.release()
