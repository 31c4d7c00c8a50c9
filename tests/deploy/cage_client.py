"""A minimal Wayland client for tests/deploy/test_cage_kiosk.py: a fullscreen window from the same
GLFW build as the exhibit (PYGLFW_LIBRARY_VARIANT=wayland, OpenGL 3.3 core through Mesa's EGL,
swap interval 1), that shows one flat colour at a time and nothing else. It isolates what the
compositor does with a client's frames from what the exhibit draws.

    python cage_client.py

prints `ready WIDTHxHEIGHT` once its window exists, then reads commands from stdin, one a line:

    R G B     clear to this colour (0-255 each), commit that one frame, give the compositor
              SETTLE_S to take it (dispatching its events meanwhile), then print `shown R G B`.
              Between commands it commits nothing.

It exits 0 at the end of stdin. Standard library, glfw and moderngl only.
"""

from __future__ import annotations

import select
import sys
import time

#: After a frame has been taken (its frame callback came), how long to let the compositor
#: finish with it before saying `shown`: cage handles a commit within milliseconds.
SETTLE_S = 0.25


def main() -> int:
    import glfw
    import moderngl

    if not glfw.init():
        print("cannot start GLFW", file=sys.stderr)
        return 1
    for hint, value in (
        (glfw.CONTEXT_VERSION_MAJOR, 3),
        (glfw.CONTEXT_VERSION_MINOR, 3),
        (glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE),
        (glfw.OPENGL_FORWARD_COMPAT, True),
        (glfw.AUTO_ICONIFY, False),
    ):
        glfw.window_hint(hint, value)
    monitor = glfw.get_primary_monitor()
    mode = glfw.get_video_mode(monitor)
    window = glfw.create_window(mode.size.width, mode.size.height, "cage-client", monitor, None)
    if not window:
        print("cannot open a window", file=sys.stderr)
        return 1
    glfw.make_context_current(window)
    glfw.swap_interval(1)
    ctx = moderngl.create_context(require=330)
    width, height = glfw.get_framebuffer_size(window)
    print(f"ready {width}x{height}", flush=True)
    try:
        while True:
            readable, _, _ = select.select([sys.stdin], [], [], 0.05)
            glfw.poll_events()
            if not readable:
                continue
            line = sys.stdin.readline()
            if not line:
                return 0
            rgb = [int(v) for v in line.split()]
            ctx.clear(*(v / 255 for v in rgb))
            glfw.swap_buffers(window)
            deadline = time.monotonic() + SETTLE_S
            while time.monotonic() < deadline:
                glfw.poll_events()
                time.sleep(0.01)
            print("shown " + " ".join(map(str, rgb)), flush=True)
    finally:
        ctx.release()
        glfw.destroy_window(window)
        glfw.terminate()


if __name__ == "__main__":
    sys.exit(main())
