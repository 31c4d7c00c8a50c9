"""Load the renderer's GLSL programs from the .glsl files beside this module.

One file per program, stages split by ``#if defined VERTEX_SHADER`` (as moderngl-window does), and
a minimal ``#include "file.glsl"`` so the pipeline uniforms and the line clipper are written once
and shared by every program that draws 4D geometry.
"""

from __future__ import annotations

import re
from functools import lru_cache
from importlib import resources

import moderngl

VERSION = "#version 330 core"
STAGES = {"vertex_shader": "VERTEX_SHADER", "geometry_shader": "GEOMETRY_SHADER",
          "fragment_shader": "FRAGMENT_SHADER"}
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)


@lru_cache(maxsize=None)
def source(name: str) -> str:
    """The text of shaders/NAME with its includes expanded (each file at most once)."""
    return _expand(name, set())


def _expand(name: str, seen: set[str]) -> str:
    if name in seen:
        return ""
    seen.add(name)
    text = resources.files("exhibit.render").joinpath("shaders", name).read_text(encoding="utf-8")
    return _INCLUDE.sub(lambda m: _expand(m.group(1), seen), text)


def program(ctx: moderngl.Context, name: str, defines: tuple[str, ...] = ()) -> moderngl.Program:
    """Compile shaders/NAME; a stage is built when the file mentions its macro."""
    text = source(name)
    extra = "".join(f"#define {d}\n" for d in defines)
    stages = {}
    for keyword, macro in STAGES.items():
        if macro in text:
            stages[keyword] = f"{VERSION}\n#define {macro}\n{extra}#line 1\n{text}"
    return ctx.program(**stages)
