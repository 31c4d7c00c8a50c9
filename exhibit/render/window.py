"""The window target: a GLFW window (fullscreen on the kiosk) whose context gets the same Renderer
as the headless target, behind the interface of exhibit.render.target (GLFW's key codes and
callbacks become toolkit-neutral Key, Focus and CloseRequest events here, and nowhere else).
One process uses one kind of target: with Mesa, once EGL (the headless
target) has been initialised, GLX refuses to make a window context current (BadAccess). The
kiosk owns the loop, and so does the staff viewer (`exhibit render SCENE --window`,
exhibit.commands._staff_viewer), with the kiosk's own keys.

GLFW errors are logged, never raised: on a kiosk that runs for months, an error from the window
system (a monitor unplugged, a focus change GLFW cannot follow) must not end the exhibit.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import moderngl
import numpy as np

from exhibit.devices.keyboard import key_name
from exhibit.render.context import REQUIRED_VERSION, RenderUnavailable
from exhibit.render.frame_request import FrameRequest
from exhibit.render.renderer import Renderer
from exhibit.render.target import CloseRequest, Focus, FrameDrawing, InputHandler, Key

if TYPE_CHECKING:
    from glfw import _GLFWwindowPointerT

    from exhibit.render.frame import FramePipeline, FrameTimer
    from exhibit.render.target import RenderTarget

log = logging.getLogger("exhibit.glfw")


class GlfwErrors:
    """GLFW's error callback: logs each distinct error at once, then a repeat count at most every
    ``every`` seconds, so an error GLFW reports every frame does not flood the journal. It never
    raises (pyGLFW would re-raise it from the next GLFW call, ending the frame loop). ``last``
    is the latest message, for the reason when a window cannot be made."""

    def __init__(self, every: float = 60.0, clock: Callable[[], float] = time.monotonic):
        self.every = every
        self.clock = clock
        self.last = ""
        self._seen: dict[str, list] = {}  # message -> [repeats not logged yet, when logged]

    def __call__(self, code: int, description: bytes | str) -> None:
        try:
            if isinstance(description, bytes):
                description = description.decode("utf-8", "replace")
            self.last = message = f"({code}) {description}"
            now = self.clock()
            seen = self._seen.get(message)
            if seen is None:
                if len(self._seen) < 100:  # beyond that, new messages are not logged at all
                    self._seen[message] = [0, now]
                    log.warning("GLFW error %s", message)
            elif now - seen[1] >= self.every:
                log.warning(
                    "GLFW error %s (%d more times in %.0f s)", message, seen[0] + 1, now - seen[1]
                )
                seen[:] = [0, now]
            else:
                seen[0] += 1
        except Exception:  # noqa: BLE001 - reporting an error must not become one
            pass


class Window(FrameDrawing):
    """A GLFW window with an OpenGL 3.3 core context and a Renderer on it."""

    def __init__(
        self,
        size: tuple[int, int] = (1280, 720),
        title: str = "exhibit",
        fullscreen: bool = False,
        samples: int = 4,
        visible: bool = True,
        vsync: bool = True,
        monitor: int = 0,
        msaa_samples: int = 4,
    ):
        """``samples``: the window's own multisampling (the direct path); ``msaa_samples``:
        the offscreen multisampling of kiosk frames at an "msaa" quality level."""
        import glfw

        self._glfw = glfw
        # Logged, never raised (see GlfwErrors); 'log' in case the callback is ever reset.
        glfw.ERROR_REPORTING = "log"
        self.errors = GlfwErrors()
        glfw.set_error_callback(self.errors)
        if not glfw.init():
            raise RenderUnavailable(
                f"cannot start GLFW ({self.errors.last or 'no display?'}); "
                "is DISPLAY set? Or use the headless target"
            )
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, REQUIRED_VERSION // 100)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, REQUIRED_VERSION % 100 // 10)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.SAMPLES, samples)
        glfw.window_hint(glfw.VISIBLE, visible)
        # A fullscreen window that loses focus would be iconified: a black screen until
        # someone comes, and under X11 without an EWMH window manager a GLFW error instead.
        glfw.window_hint(glfw.AUTO_ICONIFY, False)
        screen = None
        if fullscreen:
            # The configured monitor if it is connected, else the primary one (never no picture).
            monitors = glfw.get_monitors() or [glfw.get_primary_monitor()]
            screen = monitors[monitor] if monitor < len(monitors) else monitors[0]
        if screen is not None:
            mode = glfw.get_video_mode(screen)
            size = (mode.size.width, mode.size.height)
        handle = glfw.create_window(size[0], size[1], title, screen, None)
        if not handle:
            glfw.terminate()
            raise RenderUnavailable(f"cannot open an OpenGL 3.3 window ({self.errors.last})")
        #: The GLFW window; None once closed.
        self.handle: _GLFWwindowPointerT | None = handle
        glfw.make_context_current(handle)
        glfw.swap_interval(1 if vsync else 0)
        self.ctx = moderngl.create_context(require=REQUIRED_VERSION)
        self.renderer = Renderer(self.ctx)
        self.msaa_samples = msaa_samples
        self._kiosk: FramePipeline | None = None  # the kiosk frame pipeline, made at first use
        self._timer: FrameTimer | None = None
        #: What drawing the latest kiosk frame cost (ms; exhibit.render.frame.FrameTimer).
        self.frame_ms: float | None = None
        #: False: a close request (Alt+F4, the compositor) is reported, not obeyed.
        self.close_allowed = True
        self._handler: InputHandler | None = None
        self._install_callbacks()

    @property
    def _window(self) -> _GLFWwindowPointerT:
        """The GLFW window, for the calls that need one (none is made after close())."""
        if self.handle is None:
            raise RuntimeError("the window is closed")
        return self.handle

    # ------------------------------------------------------------------ input

    def _install_callbacks(self) -> None:
        glfw, handle = self._glfw, self._window
        modifiers = (
            ("ctrl", glfw.MOD_CONTROL),
            ("alt", glfw.MOD_ALT),
            ("shift", glfw.MOD_SHIFT),
            ("super", glfw.MOD_SUPER),
        )

        def on_key(_window, key, _scancode, action, mods):
            name = key_name(glfw, key)
            if name and action != glfw.REPEAT and self._handler is not None:
                held = frozenset(m for m, bit in modifiers if mods & bit)
                self._handler(Key(name, action == glfw.PRESS, held))

        def on_focus(_window, focused):
            if self._handler is not None:
                self._handler(Focus(bool(focused)))

        def on_close(_window):
            glfw.set_window_should_close(handle, self.close_allowed)
            if self._handler is not None:
                self._handler(CloseRequest())

        self._callbacks = (on_key, on_focus, on_close)  # pyGLFW keeps no reference of its own
        glfw.set_key_callback(handle, on_key)
        glfw.set_window_focus_callback(handle, on_focus)
        glfw.set_window_close_callback(handle, on_close)

    def set_input(self, handler: InputHandler | None) -> None:
        """Where keys, focus changes and close requests go (delivered during swap())."""
        self._handler = handler

    def hide_cursor(self) -> None:
        self._glfw.set_input_mode(self._window, self._glfw.CURSOR, self._glfw.CURSOR_HIDDEN)

    @property
    def refresh_hz(self) -> float | None:
        """The refresh rate of the monitor the window is on (the primary one when windowed)."""
        glfw = self._glfw
        try:
            monitor = glfw.get_window_monitor(self._window) or glfw.get_primary_monitor()
            mode = glfw.get_video_mode(monitor) if monitor else None
            return float(mode.refresh_rate) if mode and mode.refresh_rate > 0 else None
        except Exception:  # noqa: BLE001 - the governor then assumes 60 Hz
            return None

    @property
    def size(self) -> tuple[int, int]:
        width, height = self._glfw.get_framebuffer_size(self._window)
        return (width, height)

    def _framebuffer(self) -> moderngl.Framebuffer:
        self._glfw.make_context_current(self._window)
        return self.ctx.screen

    def _pipeline(self) -> FramePipeline:
        from exhibit.render.frame import FramePipeline, FrameTimer

        if self._kiosk is None:
            self._kiosk = FramePipeline(self.ctx, self.renderer, self.msaa_samples)
            self._timer = FrameTimer(self.ctx)
        return self._kiosk

    def _frame_timer(self) -> FrameTimer:
        self._pipeline()
        assert self._timer is not None  # made with the pipeline
        return self._timer

    def draw(self, request: FrameRequest) -> None:
        """Render one frame into the back buffer (call swap() to show it): FrameDrawing's."""
        self._draw_into(self._framebuffer(), request)

    def notice(self, lines: list[str], drift: tuple[float, float] = (0.0, 0.0)) -> None:
        """The notice screen (Renderer.notice) in the back buffer (call swap() to show it)."""
        self._glfw.make_context_current(self._window)
        self.ctx.screen.use()
        self.renderer.notice(lines, self.size, drift)

    def read(self) -> np.ndarray:
        """The back buffer as (height, width, 3) uint8, top row first (before swap()).

        moderngl reads the default framebuffer through GL_COLOR_ATTACHMENT0, which GL rejects,
        so the frame is blitted into a renderbuffer and read from there."""
        width, height = self.size
        color = self.ctx.renderbuffer((width, height), 4)
        fbo = self.ctx.framebuffer([color])
        try:
            self.ctx.copy_framebuffer(fbo, self.ctx.screen)
            data = fbo.read(components=3, alignment=1)
        finally:
            fbo.release()
            color.release()
        return np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3)[::-1].copy()

    def swap(self) -> None:
        self._glfw.swap_buffers(self._window)
        self._glfw.poll_events()

    @property
    def should_close(self) -> bool:
        return bool(self._glfw.window_should_close(self._window))

    def close(self) -> None:
        if self.handle is None:
            return
        self._handler = None
        if self._kiosk is not None:
            self._kiosk.release()
        if self._timer is not None:
            self._timer.release()
        self.renderer.release()
        self.ctx.release()
        self._glfw.destroy_window(self.handle)
        self._glfw.terminate()
        self.handle = None


if TYPE_CHECKING:
    _window_is_a_target: type[RenderTarget] = Window
