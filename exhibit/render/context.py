"""GL contexts for the two targets: an offscreen EGL context (no display needed) and, in
window.py, a GLFW window. Both hand a moderngl.Context to the same Renderer."""

from __future__ import annotations

import moderngl

from exhibit.errors import ExhibitError

#: The renderer needs gl_ClipDistance, geometry shaders and instancing: OpenGL 3.3 core.
REQUIRED_VERSION = 330


class RenderUnavailable(ExhibitError):
    """No usable OpenGL (no EGL/Mesa, or too old a GL): a user-fixable setup problem."""


def headless_context() -> moderngl.Context:
    """A standalone EGL context; on a machine without a GPU Mesa's llvmpipe renders in software."""
    try:
        # moderngl's stubs type each **settings value as Dict[str, Any]; it is glcontext's
        # keyword arguments, and backend is a str
        ctx = moderngl.create_context(
            standalone=True,
            backend="egl",  # type: ignore[arg-type]
            require=REQUIRED_VERSION,
        )
    except Exception as exc:  # noqa: BLE001 - moderngl/glcontext raise plain Exception (EGL's)
        major, minor = REQUIRED_VERSION // 100, REQUIRED_VERSION % 100 // 10
        raise RenderUnavailable(
            f"cannot create a headless OpenGL {major}.{minor}"
            f" context with EGL ({exc}); on Debian install libegl1 libgl1-mesa-dri"
        ) from None
    return ctx


def describe(ctx: moderngl.Context) -> str:
    """'renderer, GL version' for benchmark reports and the HUD's debug line."""
    info = ctx.info
    return f"{info.get('GL_RENDERER', '?')}, {info.get('GL_VERSION', '?')}"
