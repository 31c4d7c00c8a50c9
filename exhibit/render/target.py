"""What the kiosk draws into and hears from: one interface, two targets.

The kiosk (exhibit.kiosk.app) needs a surface to draw frames on and the input that surface
receives: keys, focus, requests to close. The GLFW window (exhibit.render.window.Window) gives
both on a screen; :class:`HeadlessTarget` gives them offscreen on the EGL context, with input
events a test (or a replay) posts, so the whole kiosk loop (attract, takeover, idle return,
maintenance keys, focus loss, scene switching) runs in-process on a simulated clock, without a
display. The events are toolkit-neutral: nothing above this layer knows GLFW's key codes.

A target has: ``ctx``, ``renderer``, ``size``, ``refresh_hz`` (None: unknown), ``frame_ms``
(what the latest kiosk frame cost, or None); ``draw`` and ``capture`` (of a FrameRequest,
exhibit.render.frame_request: the frame as one value), ``notice``, ``read``,
``swap`` (shows the frame, then delivers the input that arrived), ``should_close``, ``close``;
and ``set_input(handler)``, ``hide_cursor()``, ``close_allowed`` (False: a close request is
reported to the handler but does not close the target; the kiosk decides).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol
from collections.abc import Callable

import moderngl
import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render.frame_request import FrameRequest
from exhibit.render.gpu import GpuMesh
from exhibit.render.hud_info import HudInfo
from exhibit.render.layout import TextSizes
from exhibit.render.options import RenderOptions
from exhibit.render.pass_timer import PassTimes
from exhibit.render.renderer import Renderer

if TYPE_CHECKING:
    from exhibit.render.frame import FramePipeline, FrameTimer
    from exhibit.render.offscreen import Headless

__all__ = [
    "Key",
    "Focus",
    "CloseRequest",
    "InputEvent",
    "RenderTarget",
    "HeadlessTarget",
    "MODIFIERS",
]

#: Modifier names as keys and quit combinations use them.
MODIFIERS = ("ctrl", "alt", "shift", "super")


@dataclass(frozen=True)
class Key:
    """A key went down (``pressed``) or up; ``name`` as exhibit.devices.keyboard takes it (the
    layout's printable name in lower case, or a special key's name); key repeats are not sent."""

    name: str
    pressed: bool
    mods: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Focus:
    """The target gained or lost the input focus (a notification, another window, a VNC
    session): a key held when it went away never sends its release."""

    focused: bool


@dataclass(frozen=True)
class CloseRequest:
    """The window system asked to close (Alt+F4, the compositor)."""


InputEvent = Key | Focus | CloseRequest
InputHandler = Callable[[InputEvent], None]


class RenderTarget(Protocol):
    ctx: moderngl.Context
    renderer: Renderer
    frame_ms: float | None
    close_allowed: bool

    @property
    def size(self) -> tuple[int, int]: ...

    @property
    def refresh_hz(self) -> float | None: ...

    @property
    def should_close(self) -> bool: ...

    def draw(self, request: FrameRequest) -> None: ...

    def capture(self, request: FrameRequest) -> None: ...

    def warm_hud(self, huds: list[HudInfo], text: TextSizes) -> None: ...

    def release_snapshot(self) -> None: ...

    def measure_passes(self) -> None: ...

    @property
    def pass_times(self) -> PassTimes | None: ...

    def notice(self, lines: list[str], drift: tuple[float, float] = (0.0, 0.0)) -> None: ...

    def read(self) -> np.ndarray: ...

    def swap(self) -> None: ...

    def set_input(self, handler: InputHandler | None) -> None: ...

    def hide_cursor(self) -> None: ...

    def close(self) -> None: ...


class FrameDrawing:
    """draw() and capture() as the window and the headless target share them: a request
    (exhibit.render.frame_request.FrameRequest) drawn as a plain picture (``quality`` None), or
    as a whole kiosk frame at that quality level (FramePipeline), timed into ``frame_ms`` for
    the frame governor, with the captured frame laid over it at opacity ``fade`` (a crossfade)
    and ``inset`` over it. A target says where its frames go and gives its pipeline and
    timer."""

    renderer: Renderer
    frame_ms: float | None

    @property
    def size(self) -> tuple[int, int]:
        raise NotImplementedError

    def _framebuffer(self) -> moderngl.Framebuffer:
        """Where frames go, with this target's context made current."""
        raise NotImplementedError

    def _pipeline(self) -> FramePipeline:
        raise NotImplementedError

    def _frame_timer(self) -> FrameTimer:
        raise NotImplementedError

    def _draw_into(
        self, framebuffer: moderngl.Framebuffer, request: FrameRequest, timed: bool = True
    ) -> None:
        if request.quality is None:
            r = request
            self.renderer.render(r.gpu, r.view, framebuffer, r.options, r.hud, size=self.size)
            return
        timer = self._frame_timer() if timed else None
        if timer is not None:
            timer.begin()
        self._pipeline().draw(request, framebuffer, self.size)
        if timer is not None:
            self.frame_ms = timer.end()

    def warm_hud(self, huds: list[HudInfo], text: TextSizes) -> None:
        """Lay out and upload the HUD panels of ``huds`` at this target's size now, so the
        frame that first shows them does not (exhibit.kiosk.warm_up)."""
        self.renderer.hud.warm(self.size, huds, text)

    def measure_passes(self) -> None:
        """Time each pass of the next frame drawn (exhibit.render.pass_timer): the kiosk asks
        for one frame now and then, so the health file says what a frame costs."""
        self.renderer.measure_next_frame()

    @property
    def pass_times(self) -> PassTimes | None:
        """The latest measured frame's per-pass times (None before the first)."""
        return self.renderer.pass_times

    def release_snapshot(self) -> None:
        """Drop the crossfade's captured frame: it holds the outgoing frame's mesh (a review or
        a test that builds many kiosks on one context frees it)."""
        self._pipeline().release_snapshot()

    def capture(self, request: FrameRequest) -> None:
        """Draw a kiosk frame (``options.quality`` set) offscreen as the start of a crossfade:
        the following draw()s with ``fade`` lay it over the new frames."""
        if request.quality is None:
            raise ValueError("capture() draws a kiosk frame: options.quality must be set")
        self._framebuffer()  # this target's context, current
        self._pipeline().capture(request, self.size)


class HeadlessTarget(FrameDrawing):
    """The offscreen target: frames are drawn by the kiosk's own FramePipeline into an EGL
    framebuffer the size of the screen; ``post`` queues input that the next ``swap`` delivers,
    as a window system delivers what arrived between two frames. ``headless`` is an
    exhibit.render.Headless; ``image`` is the latest frame (top row first)."""

    def __init__(self, headless: Headless, size: tuple[int, int], refresh_hz: float | None = 60.0):
        self.headless = headless
        self.ctx, self.renderer = headless.ctx, headless.renderer
        # current from the start, as a window's context is: the kiosk uploads its meshes before
        # the first draw, and another context in the process may have been current (or released)
        headless.activate()
        self._size = (int(size[0]), int(size[1]))
        self._refresh_hz = refresh_hz
        self.frame_ms: float | None = None
        self.close_allowed = True
        self.image: np.ndarray | None = None
        #: The latest frame drawn (None before one, or after a notice).
        self.request: FrameRequest | None = None
        self.cursor_hidden = False
        self._handler: InputHandler | None = None
        self._queue: deque[InputEvent] = deque()
        self._should_close = False
        self._timer: FrameTimer | None = None

    @property
    def size(self) -> tuple[int, int]:
        return self._size

    @property
    def refresh_hz(self) -> float | None:
        return self._refresh_hz

    @property
    def should_close(self) -> bool:
        return self._should_close

    def _target(self):
        self.headless.activate()
        return self.headless.target(self._size, 0)

    def _framebuffer(self) -> moderngl.Framebuffer:
        return self._target().framebuffer

    def _pipeline(self) -> FramePipeline:
        return self.headless.pipeline

    def _frame_timer(self) -> FrameTimer:
        if self._timer is None:
            from exhibit.render.frame import FrameTimer

            self._timer = FrameTimer(self.ctx)
        return self._timer

    @property
    def drawn(self) -> tuple[GpuMesh, ViewState, RenderOptions, HudInfo | None] | None:
        """(gpu, view, options, hud) of the latest frame drawn (``request``'s)."""
        r = self.request
        return None if r is None else (r.gpu, r.view, r.options, r.hud)

    def draw(self, request: FrameRequest) -> None:
        target = self._target()
        self._draw_into(target.framebuffer, request)
        self.image = target.read()
        self.request = request

    def redraw(self) -> np.ndarray:
        """The latest frame drawn again with the same request and read back (``image`` is left
        as it was): a check draws it with something changed, e.g. the HUD's ``ink`` off."""
        if self.request is None:
            raise RuntimeError("nothing has been drawn yet")
        target = self._target()
        self._draw_into(target.framebuffer, self.request, timed=False)
        return target.read()

    def notice(self, lines: list[str], drift: tuple[float, float] = (0.0, 0.0)) -> None:
        target = self._target()
        target.framebuffer.use()
        self.renderer.notice(lines, self._size, drift)
        self.image = target.read()
        self.request = None

    def read(self) -> np.ndarray:
        if self.image is None:
            raise RuntimeError("nothing has been drawn yet")
        return self.image

    def post(self, event: InputEvent) -> None:
        """Input for the next swap (what a person at the window would do)."""
        self._queue.append(event)

    def swap(self) -> None:
        while self._queue:
            event = self._queue.popleft()
            if isinstance(event, CloseRequest):
                self._should_close = self.close_allowed
            if self._handler is not None:
                self._handler(event)

    def set_input(self, handler: InputHandler | None) -> None:
        self._handler = handler

    def hide_cursor(self) -> None:
        self.cursor_hidden = True

    def close(self) -> None:
        self._handler = None
        self._queue.clear()
        if self._timer is not None:
            self._timer.release()
            self._timer = None


if TYPE_CHECKING:
    _headless_is_a_target: type[RenderTarget] = HeadlessTarget
