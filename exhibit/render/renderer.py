"""The renderer: one object per GL context, serving the offscreen EGL target and the GLFW window.

A frame is: background, surfaces (the 4D pipeline in the vertex shader, clipped at the sensor
hyperplane and the front plane by gl_ClipDistance, lit two-sided with the Lemma 1(c) normal),
live silhouettes (Lemma 3 curves and Lemma 2 points, found per triangle in a geometry shader),
curves and markers as screen-space capsules depth-tested against the surfaces, then the HUD.
Per frame only uniforms change, plus a few HUD instances and any text that changed.

Why one module of this size: the passes share the programs, the uniforms and each frame's clip
transform."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import moderngl
import numpy as np

from exhibit.geometry.pipeline import ClipTransform, clip_transform
from exhibit.geometry.view import ViewState
from exhibit.render import shaders
from exhibit.render.gpu import (
    CENTRE_UNITS,
    LINE_BIAS,
    SLICE_WIDTH,
    GpuMesh,
    silhouette_key,
    surface_sample,
    upload,
)
from exhibit.render.hud import PINCH_COLOR, Hud
from exhibit.render.options import RenderOptions
from exhibit.render.text import GlyphAtlas, TextCache, line_height, text_width

if TYPE_CHECKING:  # compiled on first use (Renderer.ids)
    from exhibit.render.passes.ids import ObjectIdPass
from exhibit.surfaces.mesh import Mesh4D
from exhibit.surfaces.slice import SLICE_MATERIAL

GL_CLIP_DISTANCE0 = 0x3000
GL_CLIP_DISTANCE1 = 0x3001
OVERLAY_FLOATS = 9  # a (2), b (2), rgba (4), width (1)
GLYPH_FLOATS = 12  # rect (4), texel rect (4), rgba (4)
#: Blending for everything drawn over the scene: straight alpha in, premultiplied out, so an
#: offscreen scene cleared to transparent composites correctly over the background later.
BLEND_OVER = (
    moderngl.SRC_ALPHA,
    moderngl.ONE_MINUS_SRC_ALPHA,
    moderngl.ONE,
    moderngl.ONE_MINUS_SRC_ALPHA,
)
BLEND_PREMULTIPLIED = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
#: Intersection curves (intersect.glsl): two front pixels belong to different sheets when their
#: 4D depths differ by more than SHEET_GAP x the mesh's radius (different parts are offset by
#: SHEET_OFFSET x radius, so they always do); ink colour; the widest curve the 3x3
#: neighbourhood draws whole, as a half width in pixels (a 1 px core and a 1 px antialiased rim:
#: a pixel up to 1 px from the crossing always has a neighbour across it).
SHEET_GAP = 0.05
SHEET_OFFSET = 16.0
#: Crossings the curves show: the sine of the angle between the two sheets (depth scaled to
#: pixels by the mesh's extent on screen, from gpu.surface_sample's vertices). The ink fades in
#: linearly from MIN_CROSSING (none) to FULL_CROSSING (full): the angle is continuous along a
#: crossing curve but noisy from facet to facet, and a hard cut-off (0.2 until issue 32) drew a
#: curve whose angle runs near it in dashes (Figure 16).
MIN_CROSSING = 0.1
FULL_CROSSING = 0.3
INTERSECTION_INK = (0.05, 0.05, 0.07)
#: The slice curve drawn live (ViewState.slice_axis/slice_at): the slice's colour (its width:
#: gpu.SLICE_WIDTH).
SLICE_COLOR = SLICE_MATERIAL.color
INTERSECTION_MAX_HALF_WIDTH = 0.5


@dataclass(frozen=True)
class HudInfo:
    """Words for visitors; the numbers (angles, sensor distance) come from the ViewState."""

    title: str = ""
    caption: str = ""
    axes: tuple[str, str, str, str] = ("x", "y", "z", "w")
    #: Labels of the mesh's markers are drawn too; this is an extra line under the caption.
    note: str = ""
    #: The gizmo's label, in the language on screen (exhibit.kiosk.language).
    axes_label: str = "4D axes"
    #: The HUD's other words in the language on screen, (English, shown) pairs: the numbers
    #: panel's "sensor", "eye", "fov" and the words of marker labels ("first contact").
    #: A tuple, not a dict, so the HUD can key its caches by it.
    words: tuple[tuple[str, str], ...] = ()
    #: Objects the caption names, each tagged on screen with words in the language on screen
    #: (exhibit.render.object_tags): (object name or the start of names, words).
    tags: tuple[tuple[str, str], ...] = ()

    def word(self, english: str) -> str:
        """``english`` in the language on screen (itself when there is no translation)."""
        return dict(self.words).get(english, english)


def _mat(m: np.ndarray) -> bytes:
    """Row-major numpy matrix to GLSL's column-major bytes."""
    return np.ascontiguousarray(np.asarray(m, dtype=np.float32).T).tobytes()


def darker(color: tuple[float, float, float], factor: float = 0.32) -> tuple[float, float, float]:
    r, g, b = color
    return (float(r) * factor, float(g) * factor, float(b) * factor)


def pipeline_uniforms(ct, view: ViewState, size: tuple[int, int]) -> dict:
    """The values of shaders/pipeline.glsl's uniforms for a clip transform (tests check that
    each name here is declared there)."""

    def vector(v):
        return tuple(float(x) for x in v)

    return {
        "u_M": _mat(ct.matrix[:, :4]),
        "u_m": vector(ct.matrix[:, 4]),
        "u_R": _mat(ct.pose[:4, :4]),
        "u_t": vector(ct.pose[:4, 4]),
        "u_plane_n0": vector(ct.clip_planes[0, :4]),
        "u_plane_d0": float(ct.clip_planes[0, 4]),
        "u_plane_n1": vector(ct.clip_planes[1, :4]),
        "u_plane_d1": float(ct.clip_planes[1, 4]),
        "u_r1": view.sensor_r,
        "u_r2": view.eye_r,
        "u_viewport": (float(size[0]), float(size[1])),
    }


class Renderer:
    """Compiles the programs once per context; draws any uploaded mesh in any ViewState."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        p = shaders.program
        self.programs = {
            "surface": p(ctx, "surface.glsl"),
            "surface_depth": p(ctx, "surface.glsl", ("DEPTH_COLOUR",)),
            "surface_sheets": p(ctx, "surface.glsl", ("GBUFFER",)),
            "surface_depth_sheets": p(ctx, "surface.glsl", ("DEPTH_COLOUR", "GBUFFER")),
            "intersect": p(ctx, "intersect.glsl", ("TILES",)),
            "intersect_gate": p(ctx, "intersect.glsl", ("GATE",)),
            "intersect_ms": p(ctx, "intersect.glsl", ("MULTISAMPLE",)),
            "silhouette": p(ctx, "silhouette.glsl"),
            # With the slice's tangency test (and the two vec4 per vertex it needs): only
            # frames that draw a slice pay for it.
            "silhouette_slice": p(ctx, "silhouette.glsl", ("TOUCHING",)),
            "curves": p(ctx, "curves.glsl"),
            "overlay": p(ctx, "overlay.glsl"),
            "text": p(ctx, "text.glsl"),
            "glyphs": p(ctx, "glyphs.glsl"),
            "image": p(ctx, "glyphs.glsl", ("RGBA_TEXTURE",)),
            "background": p(ctx, "background.glsl"),
            "floor": p(ctx, "floor.glsl"),
        }
        self._empty = {
            name: ctx.vertex_array(self.programs[name], [])
            for name in ("text", "background", "intersect", "intersect_gate", "intersect_ms")
        }
        self._overlay_buffer = ctx.buffer(reserve=64 * OVERLAY_FLOATS * 4, dynamic=True)
        self._overlay_vao = ctx.vertex_array(
            self.programs["overlay"],
            [(self._overlay_buffer, "2f 2f 4f 1f/i", "in_a", "in_b", "in_color", "in_width")],
        )
        self._glyph_buffer = ctx.buffer(reserve=256 * GLYPH_FLOATS * 4, dynamic=True)
        self._glyph_vaos = {
            name: ctx.vertex_array(
                self.programs[name],
                [(self._glyph_buffer, "4f 4f 4f/i", "in_rect", "in_uv", "in_color")],
            )
            for name in ("glyphs", "image")
        }
        self.text = TextCache(ctx)
        self.atlas = GlyphAtlas(ctx)
        #: The HUD's cached panels and layout (exhibit.render.hud).
        self.hud = Hud(self)
        #: The last view's clip transform, so one frame computes it once for every pass.
        self._ct_key: tuple | None = None
        self._ct: ClipTransform | None = None
        self._ids: ObjectIdPass | None = None

    # ------------------------------------------------------------------ meshes

    def upload(self, mesh: Mesh4D) -> GpuMesh:
        """Buffers for a mesh, written once; draw it in any view with render()."""
        return upload(self.ctx, mesh, self.programs)

    # ------------------------------------------------------------------ a frame

    def clip_transform(self, view: ViewState, size: tuple[int, int]) -> ClipTransform:
        """exhibit.geometry.clip_transform for this view and size, computed once per frame (the
        surfaces, silhouettes, curves and marker labels all use it)."""
        aspect = size[0] / size[1]
        if (
            self._ct_key is None
            or self._ct_key[1] != aspect
            or not (self._ct_key[0] is view or self._ct_key[0] == view)
        ):
            self._ct_key, self._ct = (view, aspect), clip_transform(view, aspect)
        assert self._ct is not None  # set together with _ct_key
        return self._ct

    def set_pipeline(
        self, program: moderngl.Program, view: ViewState, size: tuple[int, int]
    ) -> ClipTransform:
        """Upload the view's 4x5 clip map, pose, clip planes and centres to one program (those
        of pipeline.glsl's uniforms that the program's own source declares)."""
        ct = self.clip_transform(view, size)
        declared = (program.extra or {}).get("uniforms", ())
        shaders.set_uniforms(
            program,
            {
                name: value
                for name, value in pipeline_uniforms(ct, view, size).items()
                if name in declared
            },
        )
        return ct

    def _set(self, program, **values) -> None:
        shaders.set_uniforms(program, values)

    def render(
        self,
        gpu: GpuMesh,
        view: ViewState,
        framebuffer: moderngl.Framebuffer,
        options: RenderOptions = RenderOptions(),
        hud: HudInfo | None = None,
        size: tuple[int, int] | None = None,
    ) -> None:
        """Draw one frame of gpu in view into framebuffer; size overrides the framebuffer's own
        (a window's default framebuffer changes size with the window). The direct path: the
        background is a pass of its own and antialiasing is the framebuffer's multisampling
        (the kiosk's frames go through exhibit.render.frame, which draws its "direct" quality
        level, and its crossfade snapshot at that level, with this)."""
        ctx = self.ctx
        framebuffer.use()
        width, height = size or framebuffer.size
        ctx.viewport = (0, 0, width, height)
        size = (width, height)
        # The background is the clear: it writes every pixel's colour, and (at the far plane,
        # the depth test always passing, depth writes on) its depth of 1.0, so the frame needs
        # no clear of its own (on llvmpipe a clear, even of depth alone, costs more than the
        # depth writes: docs/PERFORMANCE.md).
        ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "1"  # GL_ALWAYS
        ctx.fbo.depth_mask = True
        top, bottom = options.background
        self._set(self.programs["background"], u_top=tuple(top), u_bottom=tuple(bottom))
        self._empty["background"].render(moderngl.TRIANGLES, vertices=3)
        ctx.depth_func = "<"
        self.render_scene(gpu, view, size, options)
        if options.hud and hud is not None:
            self.render_hud(gpu, view, hud, size, options.hud_drift, options.text)

    def render_scene(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions = RenderOptions(),
        sheets=None,
    ) -> None:
        """Surfaces, live silhouettes, curves and markers into the current framebuffer (its
        viewport set, colour and depth cleared): everything that lives in the 4D scene.

        ``sheets`` (exhibit.render.frame.SceneTarget with sheets, cleared): the surfaces are
        drawn into its framebuffer with the per-pixel sheet and depth plane beside the colour,
        and the intersection curves of the 3D image are inked from them (intersect.glsl);
        everything else goes to its colour-only framebuffer."""
        ctx = self.ctx
        width, height = size
        scale = options.width_scale(height)
        ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
        ctx.depth_func = "<"
        ctx.fbo.depth_mask = True

        # Surfaces.
        ctx.enable(moderngl.DEPTH_TEST)
        inked = sheets is not None and options.surfaces and options.intersections and gpu.surfaces
        if options.surfaces:
            if inked:
                sheets.sheet_framebuffer.use()
                ctx.viewport = (0, 0, width, height)
            self.draw_surfaces(gpu, view, size, options.depth_colour, sheets=bool(inked))
        if inked:
            sheets.framebuffer.use()
            ctx.viewport = (0, 0, width, height)
            self.draw_intersections(gpu, sheets, size, options, view)

        ctx.enable(moderngl.BLEND)
        ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
        ctx.depth_func = "<="
        # The live outlines (Lemma 3) first, depth-tested against the surfaces and writing no
        # depth (Framebuffer.depth_mask: moderngl's Context has none), so no segment hides its
        # own next one; then the curves over them: a scene curve that is itself an outline (the
        # offset curve of Figures 9-14 lies on the tube's outline) covers the ink, where the
        # ink drawn after the curves, at the same depth to a hair, cut it into dashes.
        sliced = view.slice_axis is not None
        ink = options.silhouette_width if options.silhouettes else 0.0
        if ink > 0 and gpu.surfaces:
            self._silhouette_pass(gpu, view, size, scale, ink, 0.0, 0.0)
        # Curves and markers: opaque cores with depth writes, then antialiased rims blended.
        if options.curves:
            prog = self.programs["curves"]
            self.set_pipeline(prog, view, size)
            # Where the frame has the sheet buffer, curves are hidden where their centre is
            # (centre_test.glsl, at each segment end); the direct path has none.
            centre_test = 0
            if inked:
                unit = CENTRE_UNITS[1 if sheets.samples else 0]
                sheets.sheet_texture.use(unit)
                centre_test = 2 if sheets.samples else 1
            self._set(
                prog,
                u_line_bias=LINE_BIAS,
                u_width_scale=scale * options.curve_width,
                u_centre_test=centre_test,
                u_sag=gpu.sag,
                u_surface_depth=CENTRE_UNITS[0],
                u_surface_depth_ms=CENTRE_UNITS[1],
            )
            for key, count in (("lines", gpu.line_count), ("markers", gpu.marker_count)):
                if not count:
                    continue
                for pass_ in (0, 1):
                    prog["u_pass"] = pass_
                    ctx.fbo.depth_mask = pass_ == 0
                    gpu.vaos[key].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=count)
            ctx.fbo.depth_mask = True
        # Then Lemma 2 points and the slice, over everything: the lifted discs and the slice
        # stay above the wire frames, the curves and the ink. The slice's pass runs the program
        # with the tangency test ("silhouette_slice") on a surface only when the slice is near
        # one of its critical values (GpuSurface.critical).
        pinch = options.pinch_size if options.pinch_points and options.silhouettes else 0.0
        if (sliced or pinch > 0) and gpu.surfaces:
            slice_width = SLICE_WIDTH if sliced else 0.0
            self._silhouette_pass(gpu, view, size, scale, 0.0, slice_width, pinch)

        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        ctx.depth_func = "<"

    def _silhouette_pass(
        self, gpu: GpuMesh, view: ViewState, size, scale: float, ink_width, slice_width, pinch
    ) -> None:
        """One pass of silhouette.glsl over every surface, depth-tested and writing no depth:
        the ink (``ink_width``), or the slice and the Lemma 2 discs (zero widths tell the
        geometry shader what to skip). Two passes, since with no depth writes what a later
        triangle emits covers what an earlier one did: one pass would let ink cross the discs."""
        axis = np.zeros(4)
        if view.slice_axis is not None:
            axis[view.slice_axis] = 1.0
        self.ctx.fbo.depth_mask = False
        ready: dict[str, moderngl.Program] = {}  # programs with this pass's uniforms set
        for surface in gpu.surfaces:
            key = silhouette_key(surface, view, slice_width)
            if key not in ready:
                ready[key] = prog = self.programs[key]
                self.set_pipeline(prog, view, size)
                self._set(
                    prog,
                    u_line_bias=LINE_BIAS,
                    u_width_scale=scale,
                    u_pass=1,
                    u_slice_axis=tuple(axis),
                    u_slice_at=view.slice_at,
                    u_pinch=(*PINCH_COLOR, pinch),
                    u_slice_style=(*SLICE_COLOR, slice_width),
                )
            ready[key]["u_ink"] = (*darker(surface.color), ink_width)
            surface.vaos[key].render(moderngl.TRIANGLES)
        self.ctx.fbo.depth_mask = True

    def _screen_extent(self, gpu: GpuMesh, view: ViewState, size):
        """(pixels per unit of window depth, scissor box) from a sample of the mesh's vertices
        on screen: the intersection pass measures crossing angles with depth in the same units
        as x and y, and runs only over the box around the surfaces (padded, since the sample
        leaves vertices out; the whole screen when a vertex is clipped, e.g. near the sensor)."""
        sample = surface_sample(gpu)
        width, height = size
        ndc, ok = self.clip_transform(view, size).to_ndc(sample)
        if ok.sum() < 2:
            return 1.0, None
        box = None
        if ok.all():
            lo, hi = ndc[:, :2].min(axis=0), ndc[:, :2].max(axis=0)
            pad = 0.1 * (hi - lo) + 8.0 / np.array([width, height])
            x0, y0 = np.floor((np.clip(lo - pad, -1, 1) + 1) * 0.5 * (width, height)).astype(int)
            x1, y1 = np.ceil((np.clip(hi + pad, -1, 1) + 1) * 0.5 * (width, height)).astype(int)
            box = (int(x0), int(y0), int(x1 - x0), int(y1 - y0))
        ndc = ndc[ok]
        span = np.ptp(ndc, axis=0)
        pixels = max(span[0] * width, span[1] * height) * 0.5
        depth = span[2] * 0.5
        return (float(pixels / depth) if depth > 1e-12 else 1.0), box

    def draw_intersections(
        self, gpu: GpuMesh, sheets, size, options: RenderOptions, view: ViewState | None = None
    ) -> None:
        """Ink where sheets of the 3D image cross, over ``sheets.framebuffer`` (colour only; the
        surfaces were drawn with ``sheets=True`` into ``sheets.sheet_framebuffer``): a gate pass
        at one texel per tile, then one point per marked tile (a multisampled target: one
        full-screen pass). Leaves the depth test on and blending off."""
        ctx = self.ctx
        key = "intersect_ms" if sheets.samples else "intersect"
        prog = self.programs[key]
        sheets.sheet_texture.use(0)
        half = 0.5 * options.intersection_width * options.width_scale(size[1])
        scale, box = self._screen_extent(gpu, view, size) if view is not None else (1.0, None)
        self._set(
            prog,
            u_geometry=0,
            u_size=(float(size[0]), float(size[1])),
            u_depth_scale=scale,
            u_half_width=min(half, INTERSECTION_MAX_HALF_WIDTH),
            u_sheet_gap=SHEET_GAP * gpu.radius,
            u_min_angle=MIN_CROSSING,
            u_full_angle=FULL_CROSSING,
            u_ink=INTERSECTION_INK,
        )
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        if sheets.samples:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
            ctx.scissor = box
            self._empty[key].render(moderngl.TRIANGLES, vertices=3)
        else:
            # The gate, one pixel per tile, then one point per tile, drawn only where the gate
            # found two sheets: the ink's 9 taps run on the tiles along the crossings alone.
            framebuffer = sheets.framebuffer
            gate = self.programs["intersect_gate"]
            self._set(
                gate,
                u_geometry=0,
                u_size=(float(size[0]), float(size[1])),
                u_sheet_gap=SHEET_GAP * gpu.radius,
                u_depth_scale=scale,
                u_min_angle=MIN_CROSSING,
            )
            sheets.gate_framebuffer.use()
            ctx.viewport = (0, 0, *sheets.gate_size)
            self._empty["intersect_gate"].render(moderngl.TRIANGLES, vertices=3)
            framebuffer.use()
            ctx.viewport = (0, 0, *size)
            sheets.gate_texture.use(1)
            self._set(prog, u_gate=1, u_tiles_x=sheets.gate_size[0])
            ctx.enable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
            ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
            ctx.scissor = box
            self._empty[key].render(
                moderngl.POINTS, vertices=sheets.gate_size[0] * sheets.gate_size[1]
            )
            ctx.disable(moderngl.PROGRAM_POINT_SIZE)
        ctx.scissor = None
        ctx.disable(moderngl.BLEND)
        ctx.enable(moderngl.DEPTH_TEST)

    def draw_surfaces(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size,
        depth_colour: bool = False,
        key: str | None = None,
        sheets: bool = False,
    ) -> None:
        """The surface pass alone (depth test on, current framebuffer): also what the benchmark
        times against its CPU baseline and its pass-through floor (key="floor"). With
        ``sheets`` the current framebuffer has a second, float attachment for each pixel's sheet
        and depth plane (the intersection curves' input)."""
        ctx = self.ctx
        key = key or ("surface_depth" if depth_colour else "surface")
        if sheets:
            key += "_sheets"
        prog = self.programs[key]
        self.set_pipeline(prog, view, size)
        if "u_lights" in prog:
            lights = np.zeros((2, 3), dtype=np.float32)  # key and fill light; more are ignored
            lights[: len(view.lights[:2])] = view.lights[:2]
            shaders.uniform(prog, "u_lights").write(lights.tobytes())
        lit = key != "floor"  # the floor: one matrix and a flat colour, no clipping
        if lit:
            w0 = view.offset[3]
            self._set(prog, u_w_range=(w0 - gpu.radius, w0 + gpu.radius))
        self.clip_distances(lit)
        ctx.polygon_offset = (1.0, 1.0)
        for i, surface in enumerate(gpu.surfaces):
            if lit:
                self._set(prog, u_color=tuple(surface.color), u_sheet=SHEET_OFFSET * i * gpu.radius)
            surface.vaos[key].render(moderngl.TRIANGLES)
        ctx.polygon_offset = (0.0, 0.0)
        self.clip_distances(False)

    def clip_distances(self, on: bool) -> None:
        """Turn the two gl_ClipDistance planes (sensor, front) on or off: the lit surface pass
        and the CPU baseline write them; the floor and the lines do not."""
        for enum in (GL_CLIP_DISTANCE0, GL_CLIP_DISTANCE1):
            (self.ctx.enable_direct if on else self.ctx.disable_direct)(enum)

    # ------------------------------------------------------------------ object ids

    @property
    def ids(self):
        """The object-id pass (exhibit.render.passes.ids), compiled on first use: only reviews
        and tests read ids, so the kiosk's start does not pay for it."""
        if self._ids is None:
            from exhibit.render.passes.ids import ObjectIdPass

            self._ids = ObjectIdPass(self.ctx, self)
        return self._ids

    # ------------------------------------------------------------------ HUD

    def notice(
        self, lines: list[str], size: tuple[int, int], drift: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        """Lines of text centred on a dark screen, into the current framebuffer: what the kiosk
        shows when it has nothing else, so the screen says what is wrong instead of staying
        black. ``drift`` moves the text (burn-in care: it may stay up for weeks)."""
        ctx, (width, height) = self.ctx, size
        ctx.viewport = (0, 0, width, height)
        ctx.fbo.clear(0.06, 0.06, 0.08, 1.0)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        px = max(10, round(0.03 * height))
        step = line_height("sans", px)
        y = (height - step * len(lines)) / 2 + drift[1]
        for line in lines:
            x = (width - text_width(line, "sans", px)) / 2 + drift[0]
            self._text(
                line, "sans", px, x, y, (0.85, 0.85, 0.82, 1.0), (float(width), float(height))
            )
            y += step
        ctx.disable(moderngl.BLEND)

    def _text(self, text: str, style: str, size: int, x: float, y: float, color, viewport):
        """Draw text with its top-left corner at (x, y) in pixels from the top-left, as its own
        texture (the notice screen; the HUD uses the glyph atlas)."""
        if not text:
            return 0, 0
        item = self.text.get(text, style, size)
        x, y = round(x), round(y)
        prog = self.programs["text"]
        item.texture.use(0)
        prog["u_texture"] = 0
        prog["u_viewport"] = viewport
        prog["u_rect"] = (x, viewport[1] - y - item.height, item.width, item.height)
        prog["u_color"] = tuple(color)
        self._empty["text"].render(moderngl.TRIANGLE_STRIP, vertices=4)
        return item.width, item.height

    def _overlay(self, items: list[tuple], viewport) -> None:
        """Draw 2D capsules (a, b, rgba, width) given in pixels from the top-left."""
        if not items:
            return
        rows = np.array(
            [
                (ax, viewport[1] - ay, bx, viewport[1] - by, *rgba, width)
                for (ax, ay), (bx, by), rgba, width in items
            ],
            dtype=np.float32,
        )
        data = rows.tobytes()
        if len(data) > self._overlay_buffer.size:
            self._overlay_buffer.orphan(len(data))
        self._overlay_buffer.write(data)
        prog = self.programs["overlay"]
        prog["u_viewport"] = viewport
        prog["u_pass"] = 1
        self.ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
        self._overlay_vao.render(moderngl.TRIANGLE_STRIP, vertices=4, instances=len(rows))

    def _quads(self, program: str, texture, texture_size, rows: list[tuple], viewport) -> None:
        """Instanced HUD quads (x, y, w, h, u, v, tw, th, r, g, b, a), premultiplied blending."""
        if not rows:
            return
        data = np.asarray(rows, dtype=np.float32).tobytes()
        if len(data) > self._glyph_buffer.size:
            self._glyph_buffer.orphan(max(len(data), 2 * self._glyph_buffer.size))
        self._glyph_buffer.write(data)
        prog = self.programs[program]
        texture.use(0)
        prog["u_texture"] = 0
        prog["u_viewport"] = viewport
        prog["u_texture_size"] = tuple(float(v) for v in texture_size)
        self.ctx.blend_func = BLEND_PREMULTIPLIED
        self._glyph_vaos[program].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=len(rows))

    def _glyph_rows(
        self, text: str, style: str, px: int, x: float, y: float, color, rows: list
    ) -> tuple[int, int, int, int]:
        """Instances for one line of text whose top-left corner is at (x, y); returns the box
        its glyph images cover, (x0, y0, x1, y1) in pixels (empty at (x, y) for no glyphs)."""
        x, y = round(x), round(y)
        x0 = x1 = x
        y1 = y
        for i, (dx, g) in enumerate(self.atlas.layout(text, style, px)):
            rows.append((x + dx, y, g.width, g.height, g.u, g.v, g.width, g.height, *color))
            x0 = x + dx if i == 0 else min(x0, x + dx)
            x1, y1 = max(x1, x + dx + g.width), max(y1, y + g.height)
        return (x0, y, x1, y1)

    def _panel_row(self, x, y, w, h, color, rows: list) -> None:
        g = self.atlas.solid
        rows.append(
            (round(x), round(y), round(w), round(h), g.u + 0.5, g.v + 0.5, 1.0, 1.0, *color)
        )

    def render_hud(
        self,
        gpu: GpuMesh,
        view: ViewState,
        hud: HudInfo,
        size,
        drift: tuple[float, float] = (0.0, 0.0),
        sizes=None,
        alpha: float = 1.0,
    ) -> None:
        """The HUD over the current framebuffer at its full resolution (exhibit.render.hud);
        ``sizes``: exhibit.render.layout.TextSizes (None: the defaults); ``alpha`` fades it."""
        self.hud.draw(gpu, view, hud, size, drift, sizes, alpha)

    def release(self) -> None:
        self.text.release()
        self.atlas.release()
        self.hud.release()
        if self._ids is not None:
            self._ids.release()
        for vao in [*self._empty.values(), self._overlay_vao, *self._glyph_vaos.values()]:
            vao.release()
        self._overlay_buffer.release()
        self._glyph_buffer.release()
        for prog in self.programs.values():
            prog.release()
