"""The moderngl renderer: the paper's z-buffer pipeline for 2-surfaces in 4D (see
docs/RENDERING.md). Headless EGL (offscreen.Headless) and a GLFW window (window.Window) share one
Renderer; shaders are the .glsl files in shaders/."""

from exhibit.render.context import RenderUnavailable, describe, headless_context
from exhibit.render.gpu import GpuMesh
from exhibit.render.offscreen import Headless, Offscreen, save_png
from exhibit.render.options import RenderOptions
from exhibit.render.renderer import HudInfo, Renderer

__all__ = [
    "GpuMesh",
    "Headless",
    "HudInfo",
    "Offscreen",
    "RenderOptions",
    "RenderUnavailable",
    "Renderer",
    "describe",
    "headless_context",
    "save_png",
]
