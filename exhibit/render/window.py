"""The window target: a GLFW window (fullscreen on the kiosk) whose context gets the same Renderer
as the headless target. One process uses one kind of target: with Mesa, once EGL (the headless
target) has been initialised, GLX refuses to make a window context current (BadAccess). The kiosk owns the loop; view() below is a small interactive viewer for
staff (`exhibit render SCENE --window`)."""

from __future__ import annotations

import math

import moderngl
import numpy as np

from exhibit.render.context import REQUIRED_VERSION, RenderUnavailable
from exhibit.render.options import RenderOptions
from exhibit.render.renderer import HudInfo, Renderer


class Window:
    """A GLFW window with an OpenGL 3.3 core context and a Renderer on it."""

    def __init__(self, size: tuple[int, int] = (1280, 720), title: str = "exhibit",
                 fullscreen: bool = False, samples: int = 4, visible: bool = True,
                 vsync: bool = True, monitor: int = 0):
        import glfw

        self._glfw = glfw
        glfw.ERROR_REPORTING = "raise"  # GLFW errors as exceptions, not warnings
        try:
            ok = glfw.init()
        except glfw.GLFWError as exc:
            raise RenderUnavailable(f"cannot start GLFW ({exc}); is DISPLAY set?") from None
        if not ok:
            raise RenderUnavailable("cannot start GLFW (no display?); use the headless target")
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, REQUIRED_VERSION // 100)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, REQUIRED_VERSION % 100 // 10)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.SAMPLES, samples)
        glfw.window_hint(glfw.VISIBLE, visible)
        if fullscreen:
            # The configured monitor if it is connected, else the primary one (never no picture).
            monitors = glfw.get_monitors() or [glfw.get_primary_monitor()]
            monitor = monitors[monitor] if monitor < len(monitors) else monitors[0]
        else:
            monitor = None
        if monitor is not None:
            mode = glfw.get_video_mode(monitor)
            size = (mode.size.width, mode.size.height)
        try:
            self.handle = glfw.create_window(size[0], size[1], title, monitor, None)
        except glfw.GLFWError as exc:
            glfw.terminate()
            raise RenderUnavailable(f"cannot open an OpenGL 3.3 window ({exc})") from None
        glfw.make_context_current(self.handle)
        glfw.swap_interval(1 if vsync else 0)
        self.ctx = moderngl.create_context(require=REQUIRED_VERSION)
        self.renderer = Renderer(self.ctx)

    @property
    def size(self) -> tuple[int, int]:
        return tuple(self._glfw.get_framebuffer_size(self.handle))

    def draw(self, gpu, view, options: RenderOptions = RenderOptions(),
             hud: HudInfo | None = None) -> None:
        """Render one frame into the back buffer (call swap() to show it)."""
        self._glfw.make_context_current(self.handle)
        self.renderer.render(gpu, view, self.ctx.screen, options, hud, size=self.size)

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
        self._glfw.swap_buffers(self.handle)
        self._glfw.poll_events()

    @property
    def should_close(self) -> bool:
        return bool(self._glfw.window_should_close(self.handle))

    def close(self) -> None:
        if self.handle is None:
            return
        self.renderer.release()
        self.ctx.release()
        self._glfw.destroy_window(self.handle)
        self._glfw.terminate()
        self.handle = None


#: Viewer keys: 1-6 turn θ1..θ6 (Shift: backwards), Up/Down move the sensor (r), D depth colour.
ANGLE_STEP = math.radians(2.0)


def view(window: Window, gpu, view_state, hud: HudInfo | None = None) -> None:
    """A staff viewer: keys drive the six angles and the sensor until the window is closed."""
    glfw = window._glfw
    options = RenderOptions()
    while not window.should_close:
        shift = -1.0 if glfw.get_key(window.handle, glfw.KEY_LEFT_SHIFT) == glfw.PRESS else 1.0
        angles = list(view_state.angles)
        for i in range(6):
            if glfw.get_key(window.handle, glfw.KEY_1 + i) == glfw.PRESS:
                angles[i] += shift * ANGLE_STEP
        r = view_state.sensor_r
        if glfw.get_key(window.handle, glfw.KEY_UP) == glfw.PRESS:
            r = min(r + 0.005, 0.95)
        if glfw.get_key(window.handle, glfw.KEY_DOWN) == glfw.PRESS:
            r = max(r - 0.005, 0.0)
        if glfw.get_key(window.handle, glfw.KEY_ESCAPE) == glfw.PRESS:
            break
        options = RenderOptions(depth_colour=glfw.get_key(window.handle, glfw.KEY_D) == glfw.PRESS)
        view_state = view_state.replace(angles=tuple(angles), sensor_r=r)
        window.draw(gpu, view_state, options, hud)
        window.swap()
