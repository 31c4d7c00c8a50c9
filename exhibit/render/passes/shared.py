"""What every pass of the picture shares, written once: the frame's inputs (the scene passes'
FrameInputs, the post chain's PostFrame), the 4x5 clip map
computed once a frame and uploaded to any program, the clip planes, the blend modes, and a
mesh's vertex arrays, which each pass binds to its own programs on first use and keeps on the
GpuMesh (so they are freed with the mesh, and a new variant touches only its pass's file)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import moderngl
import numpy as np

from exhibit.geometry.pipeline import ClipTransform, clip_transform
from exhibit.geometry.view import ViewState
from exhibit.render import shaders
from exhibit.render.gpu import (
    CURVE_ATTRIBUTES,
    SURFACE_ATTRIBUTES,
    GpuMesh,
    GpuSurface,
    attribute_format,
)
from exhibit.render.frame_request import FrameRequest
from exhibit.render.options import RenderOptions
from exhibit.render.scene_target import SceneTarget

GL_CLIP_DISTANCE0 = 0x3000
GL_CLIP_DISTANCE1 = 0x3001
#: Blending for everything drawn over the scene: straight alpha in, premultiplied out, so an
#: offscreen scene cleared to transparent composites correctly over the background later.
BLEND_OVER = (
    moderngl.SRC_ALPHA,
    moderngl.ONE_MINUS_SRC_ALPHA,
    moderngl.ONE,
    moderngl.ONE_MINUS_SRC_ALPHA,
)
BLEND_PREMULTIPLIED = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)


@dataclass(frozen=True)
class FrameInputs:
    """What one frame's passes draw: the mesh, the view, the drawable size, the options and,
    on frames that ink intersections, the scene target with its sheet buffer (``sheets``)."""

    gpu: GpuMesh
    view: ViewState
    size: tuple[int, int]
    options: RenderOptions
    sheets: SceneTarget | None = None

    @property
    def width_scale(self) -> float:
        """Line widths' factor at this frame's height (RenderOptions.width_scale)."""
        return self.options.width_scale(self.size[1])


@dataclass(frozen=True)
class PostFrame:
    """What a kiosk frame's post chain (exhibit.render.passes.post) works on, decided before
    its first pass (exhibit.render.frame.FramePipeline.plan): the request, its options at the
    quality level, where the frame goes (``destination``, drawable ``size``), the scene's size
    and antialiasing, the offscreen scene ``target`` (None on the direct path, which draws
    straight into the destination) and the FXAA texture of a smaller render scale
    (``smooth``), the crossfade's ``snapshot``, whose words the HUD shows (``words``) at which
    opacity (``alpha``), and the inset's label marks, which the inset pass appends to
    (``texts``)."""

    request: FrameRequest
    options: RenderOptions
    destination: moderngl.Framebuffer
    size: tuple[int, int]
    scene_size: tuple[int, int]
    antialiasing: str
    target: SceneTarget | None = None
    smooth: SceneTarget | None = None
    snapshot: moderngl.Texture | None = None
    words: FrameRequest | None = None
    alpha: float = 1.0
    texts: list = field(default_factory=list)

    @property
    def inked(self) -> bool:
        """Whether the scene target has the sheet buffer (the intersection curves)."""
        return self.target is not None and self.target.sheet_framebuffer is not None

    def scene_target(self) -> SceneTarget:
        """The offscreen scene target (the post passes run only on frames that have one)."""
        if self.target is None:
            raise RuntimeError("the direct path has no scene target")
        return self.target


class RenderPass(Protocol):
    """A pass of the picture: it owns its programs, binds its vertex arrays, sets its own
    uniforms and GL state, and says what it reads and writes (names of buffers of the frame:
    "scene colour", "scene depth", "sheets", "screen")."""

    name: ClassVar[str]
    reads: ClassVar[tuple[str, ...]]
    #: Read only where an earlier pass wrote them (the curves' centre test reads the sheets
    #: on frames that have them).
    optional_reads: ClassVar[tuple[str, ...]]
    writes: ClassVar[tuple[str, ...]]
    programs: dict[str, moderngl.Program]

    def draw(self, frame: FrameInputs) -> None: ...

    def release(self) -> None: ...


def _mat(m: np.ndarray) -> bytes:
    """Row-major numpy matrix to GLSL's column-major bytes."""
    return np.ascontiguousarray(np.asarray(m, dtype=np.float32).T).tobytes()


def pipeline_uniforms(ct: ClipTransform, view: ViewState, size: tuple[int, int]) -> dict[str, Any]:
    """The values of shaders/pipeline.glsl's uniforms for a clip transform (tests check that
    each name here is declared there)."""

    def vector(v: np.ndarray) -> tuple[float, ...]:
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


class Pipeline:
    """The view's clip transform, computed once a frame for every pass (surfaces, silhouettes,
    curves, the HUD's marker labels), and its upload to a program."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self._key: tuple[ViewState, float] | None = None
        self._ct: ClipTransform | None = None

    def clip_transform(self, view: ViewState, size: tuple[int, int]) -> ClipTransform:
        """exhibit.geometry.clip_transform for this view and size, computed once per frame."""
        aspect = size[0] / size[1]
        if (
            self._key is None
            or self._key[1] != aspect
            or not (self._key[0] is view or self._key[0] == view)
        ):
            self._key, self._ct = (view, aspect), clip_transform(view, aspect)
        assert self._ct is not None  # set together with _key
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

    def clip_distances(self, on: bool) -> None:
        """Turn the two gl_ClipDistance planes (sensor, front) on or off: the lit surface pass
        and the CPU baseline write them; the floor and the lines do not."""
        for enum in (GL_CLIP_DISTANCE0, GL_CLIP_DISTANCE1):
            (self.ctx.enable_direct if on else self.ctx.disable_direct)(enum)


def surface_array(
    ctx: moderngl.Context, surface: GpuSurface, program: moderngl.Program, key: str
) -> moderngl.VertexArray:
    """The surface's vertex array for ``program``, made on first use and kept on the surface
    under ``key`` (a pass's own name for the variant); made again if the key was bound to
    another program (a second renderer on the same context)."""
    vao = surface.vaos.get(key)
    if vao is None or vao.program is not program:
        if vao is not None:
            vao.release()
        fmt, used = attribute_format(program, SURFACE_ATTRIBUTES)
        vao = surface.vaos[key] = ctx.vertex_array(
            program, [(surface.vbo, fmt, *used)], index_buffer=surface.ibo, index_element_size=4
        )
    return vao


def segment_array(
    ctx: moderngl.Context,
    gpu: GpuMesh,
    buffer: moderngl.Buffer,
    program: moderngl.Program,
    key: str,
) -> moderngl.VertexArray:
    """A vertex array of instanced segments (gpu.segment_rows' layout) over ``buffer`` for
    ``program``, made on first use and kept on the mesh under ``key``."""
    vao = gpu.vaos.get(key)
    if vao is None or vao.program is not program:
        if vao is not None:
            vao.release()
        vao = gpu.vaos[key] = ctx.vertex_array(
            program, [(buffer, "4f 4f 4f 1f/i", *CURVE_ATTRIBUTES)]
        )
    return vao


def set_uniforms(program: moderngl.Program, **values: Any) -> None:
    """shaders.set_uniforms with keywords."""
    shaders.set_uniforms(program, values)
