"""The offscreen target: an EGL context, a multisampled framebuffer, and images as numpy arrays.

Tests, the `exhibit render` command and the benchmark all draw through this; the window target
(window.py) hands its own context to the same Renderer.
"""

from __future__ import annotations

import os
from dataclasses import replace
from typing import TYPE_CHECKING

import moderngl
import numpy as np
from PIL import Image

from exhibit.render.context import headless_context
from exhibit.render.quality import LADDER
from exhibit.render.renderer import Renderer

if TYPE_CHECKING:
    from exhibit.geometry.view import ViewState
    from exhibit.render.frame import FramePipeline
    from exhibit.render.frame_request import FrameRequest, Inset
    from exhibit.render.gpu import GpuMesh
    from exhibit.render.hud_info import HudInfo
    from exhibit.render.options import RenderOptions
    from exhibit.render.passes.ids import ObjectCoverage
    from exhibit.render.quality import Quality

#: 4x MSAA: surfaces' edges antialiased; curves are antialiased by their own coverage.
DEFAULT_SAMPLES = 4


#: The most bytes one texture may take: llvmpipe, the software GL the kiosk runs on, leaves a
#: framebuffer with a larger attachment incomplete (INCOMPLETE_ATTACHMENT or UNSUPPORTED), and
#: a GPU driver's share of memory is no larger in practice.
MAX_TEXTURE_BYTES = 1 << 30
#: Bytes a pixel takes in the largest target of a frame: the intersection curves' sheet buffer
#: (exhibit.render.frame.SceneTarget), RGBA 32-bit floats, once per MSAA sample.
SHEET_BYTES_PER_PIXEL = 16


def size_limits(ctx: moderngl.Context) -> tuple[int, int]:
    """(the longest side, in pixels, any target may have; the most samples) for ``ctx``: the
    least of GL_MAX_TEXTURE_SIZE, GL_MAX_RENDERBUFFER_SIZE and GL_MAX_VIEWPORT_DIMS."""
    info = ctx.info
    sides = [info.get("GL_MAX_TEXTURE_SIZE"), info.get("GL_MAX_RENDERBUFFER_SIZE")]
    sides += list(info.get("GL_MAX_VIEWPORT_DIMS") or ())
    known = [int(v) for v in sides if isinstance(v, (int, float)) and v > 0]
    return (min(known) if known else 4096), max(0, int(ctx.max_samples))


def size_problem(ctx: moderngl.Context, size: tuple[int, int], samples: int = 0) -> str | None:
    """Why frames of ``size`` with ``samples`` MSAA samples cannot be drawn on ``ctx`` (a side
    over the GL's limits, or a target over MAX_TEXTURE_BYTES), in words; None when they can."""
    width, height = int(size[0]), int(size[1])
    side, most_samples = size_limits(ctx)
    if max(width, height) > side:
        return (
            f"{width}x{height} is larger than this GL renderer draws: at most {side} pixels a "
            "side (GL_MAX_TEXTURE_SIZE, GL_MAX_RENDERBUFFER_SIZE, GL_MAX_VIEWPORT_DIMS)"
        )
    layers = max(1, min(samples, most_samples) if samples > 1 else 1)
    needed = width * height * SHEET_BYTES_PER_PIXEL * layers
    if needed > MAX_TEXTURE_BYTES:
        most = int((MAX_TEXTURE_BYTES / (SHEET_BYTES_PER_PIXEL * layers)) ** 0.5)
        with_samples = f" with {layers} samples" if layers > 1 else ""
        return (
            f"{width}x{height}{with_samples} needs a {needed / (1 << 30):.1f} GiB buffer for the "
            f"intersection curves, over the {MAX_TEXTURE_BYTES >> 30} GiB one texture may hold "
            f"(at most about {most}x{most}{with_samples}"
            + ("; fewer --samples allow more" if layers > 1 else "")
            + ")"
        )
    return None


class Offscreen:
    """A colour + depth framebuffer of one size (multisampled, resolved on read)."""

    def __init__(
        self, ctx: moderngl.Context, size: tuple[int, int], samples: int = DEFAULT_SAMPLES
    ):
        width, height = size
        if width < 1 or height < 1:
            raise ValueError(f"image size must be positive, got {width}x{height}")
        samples = min(samples, ctx.max_samples) if samples > 1 else 0
        self.ctx, self.size, self.samples = ctx, (int(width), int(height)), samples
        self._color = ctx.renderbuffer(self.size, 4, samples=samples)
        self._depth = ctx.depth_renderbuffer(self.size, samples=samples)
        self.framebuffer = ctx.framebuffer([self._color], self._depth)
        self._resolved_color: moderngl.Renderbuffer | None = None
        self._resolved = self.framebuffer
        if samples:
            self._resolved_color = ctx.renderbuffer(self.size, 4)
            self._resolved = ctx.framebuffer([self._resolved_color])

    def read(self) -> np.ndarray:
        """(height, width, 3) uint8, top row first."""
        if self.samples:
            self.ctx.copy_framebuffer(self._resolved, self.framebuffer)
        data = self._resolved.read(components=3, alignment=1)
        image = np.frombuffer(data, dtype=np.uint8).reshape(self.size[1], self.size[0], 3)
        return image[::-1].copy()

    def release(self) -> None:
        for obj in (self.framebuffer, self._color, self._depth, self._resolved_color):
            if obj is not None:
                obj.release()
        if self.samples:
            self._resolved.release()


class Headless:
    """An EGL context with its Renderer: the whole offscreen pipeline in one object."""

    def __init__(self, ctx: moderngl.Context | None = None):
        self.ctx = ctx or headless_context()
        self.renderer = Renderer(self.ctx)
        self._targets: dict[tuple[tuple[int, int], int], Offscreen] = {}
        self._pipeline: FramePipeline | None = None

    def activate(self) -> None:
        """Make this context current again (another context in the process may have taken it)."""
        self.ctx.__enter__()

    def target(self, size: tuple[int, int], samples: int = DEFAULT_SAMPLES) -> Offscreen:
        width, height = size
        key = ((width, height), samples)
        if key not in self._targets:
            self._targets[key] = Offscreen(self.ctx, size, samples)
        return self._targets[key]

    def image(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions | None = None,
        hud: HudInfo | None = None,
        samples: int = DEFAULT_SAMPLES,
    ) -> np.ndarray:
        from exhibit.render.options import RenderOptions

        self.activate()
        target = self.target(size, samples)
        self.renderer.render(gpu, view, target.framebuffer, options or RenderOptions(), hud)
        return target.read()

    @property
    def pipeline(self) -> FramePipeline:
        """The kiosk's frame pipeline on this context (exhibit.render.frame.FramePipeline)."""
        if self._pipeline is None:
            from exhibit.render.frame import FramePipeline

            self._pipeline = FramePipeline(self.ctx, self.renderer, DEFAULT_SAMPLES)
        return self._pipeline

    def draw_frame(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions | None = None,
        hud: HudInfo | None = None,
        quality: Quality | None = None,
        inset: Inset | None = None,
    ) -> Offscreen:
        """A whole kiosk frame at a quality level (default: FXAA at full scale) into a
        single-sampled target, as a window's screen gets it (with the time-slice ``inset``,
        exhibit.render.frame.Inset, when given); read() it for the picture."""
        from exhibit.render.frame_request import FrameRequest
        from exhibit.render.options import RenderOptions

        options = replace(options or RenderOptions(), quality=quality or LADDER[1])
        return self.draw_request(FrameRequest(gpu, view, options, hud, inset=inset), size)

    def draw_request(self, request: FrameRequest, size: tuple[int, int]) -> Offscreen:
        """A whole kiosk frame (``request.quality`` set) into a single-sampled target of
        ``size``, as a window's screen gets it; read() it for the picture."""
        self.activate()
        target = self.target(size, 0)
        self.pipeline.draw(request, target.framebuffer, target.size)
        return target

    def frame(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions | None = None,
        hud: HudInfo | None = None,
        quality: Quality | None = None,
        inset: Inset | None = None,
    ) -> np.ndarray:
        """draw_frame()'s picture: (height, width, 3) uint8, top row first."""
        return self.draw_frame(gpu, view, size, options, hud, quality, inset).read()

    def still(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions | None = None,
        hud: HudInfo | None = None,
        samples: int = DEFAULT_SAMPLES,
        inset: Inset | None = None,
    ) -> np.ndarray:
        """A picture through the kiosk's frame pipeline at full quality (MSAA with ``samples``,
        else no antialiasing), so `exhibit render` shows what the kiosk shows, intersection
        curves included."""
        from exhibit.render.frame import FramePipeline

        self.activate()
        wanted = samples if samples > 1 else 0
        if self._pipeline is None or self._pipeline.samples != min(wanted, self.ctx.max_samples):
            if self._pipeline is not None:
                self._pipeline.release()
            self._pipeline = FramePipeline(self.ctx, self.renderer, wanted)
        quality = LADDER[0] if wanted else replace(LADDER[1], name="none", antialiasing="none")
        return self.frame(gpu, view, size, options, hud, quality, inset)

    def ids(self, gpu: GpuMesh, view: ViewState, size: tuple[int, int]) -> np.ndarray:
        """(height, width) int triangle ids + 1 (0 = background), no multisampling."""
        self.activate()
        return self.renderer.ids.triangles(gpu, view, size)

    def objects(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions | None = None,
    ) -> ObjectCoverage:
        """Each named object's pixels in front (exhibit.render.passes.ids.ObjectCoverage)."""
        from exhibit.render.options import RenderOptions

        self.activate()
        return self.renderer.ids.objects(gpu, view, size, options or RenderOptions())

    def release(self) -> None:
        self.activate()
        for target in self._targets.values():
            target.release()
        self._targets.clear()
        if self._pipeline is not None:
            self._pipeline.release()
        self.renderer.release()
        self.ctx.release()


def png_bytes(image: np.ndarray | Image.Image) -> bytes:
    """A picture (an RGB(A) array or a PIL image) as the bytes of a PNG file."""
    import io

    picture = image if isinstance(image, Image.Image) else Image.fromarray(image)
    buffer = io.BytesIO()
    picture.save(buffer, format="PNG")
    return buffer.getvalue()


def save_png(image: np.ndarray | Image.Image, path: str | os.PathLike, sync: bool = True) -> None:
    """A picture to a PNG at ``path`` through the one safe writer (exhibit.schema.files): never
    through a symbolic link, FIFO, device or folder there (UnsafePath, an OSError)."""
    from exhibit.schema.files import write_atomic

    write_atomic(path, png_bytes(image), links=False, sync=sync)
