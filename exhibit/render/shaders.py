"""Load the renderer's GLSL programs from the .glsl files beside this module.

One file per program, stages split by ``#if defined VERTEX_SHADER`` (as moderngl-window does), and
a minimal ``#include "file.glsl"`` so the pipeline uniforms and the line clipper are written once
and shared by every program that draws 4D geometry.
"""

from __future__ import annotations

import logging
import os
import re
from functools import cache
from importlib import resources
from typing import Any

import moderngl

log = logging.getLogger(__name__)

VERSION = "#version 330 core"
STAGES = {
    "vertex_shader": "VERTEX_SHADER",
    "geometry_shader": "GEOMETRY_SHADER",
    "fragment_shader": "FRAGMENT_SHADER",
}
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)
_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.DOTALL)
_UNIFORM = re.compile(r"\buniform\s+(?:(?:lowp|mediump|highp)\s+)?\w+\s+([^;{]+);")
#: Set to 1 (tests/conftest.py does) to make a uniform name no shader declares an error;
#: otherwise it is logged once per program and name, and the frame goes on.
STRICT_ENV = "EXHIBIT_STRICT_UNIFORMS"


class UniformError(RuntimeError):
    """A uniform name the program's source does not declare: a typo on the Python side."""


@cache
def source(name: str) -> str:
    """The text of shaders/NAME with its includes expanded (each file at most once)."""
    return _expand(name, set())


def _expand(name: str, seen: set[str]) -> str:
    if name in seen:
        return ""
    seen.add(name)
    text = resources.files("exhibit.render").joinpath("shaders", name).read_text(encoding="utf-8")
    return _INCLUDE.sub(lambda m: _expand(m.group(1), seen), text)


@cache
def declared_uniforms(name: str) -> frozenset[str]:
    """Every uniform name shaders/NAME (with its includes) declares, in any #if branch."""
    names = set()
    for match in _UNIFORM.finditer(_COMMENT.sub(" ", source(name))):
        for part in match.group(1).split(","):
            names.add(part.split("=")[0].split("[")[0].strip())
    return frozenset(names)


def program(ctx: moderngl.Context, name: str, defines: tuple[str, ...] = ()) -> moderngl.Program:
    """Compile shaders/NAME; a stage is built when the file mentions its macro. The program's
    ``extra`` records its file and declared uniforms for set_uniforms."""
    text = source(name)
    extra = "".join(f"#define {d}\n" for d in defines)
    stages: dict[str, str] = {}
    for keyword, macro in STAGES.items():
        if macro in text:
            stages[keyword] = f"{VERSION}\n#define {macro}\n{extra}#line 1\n{text}"
    prog = ctx.program(
        vertex_shader=stages.get("vertex_shader"),
        geometry_shader=stages.get("geometry_shader"),
        fragment_shader=stages.get("fragment_shader"),
    )
    prog.extra = {"file": name, "uniforms": declared_uniforms(name)}
    return prog


_reported: set[tuple[str, str]] = set()


def uniform(prog: moderngl.Program, name: str) -> moderngl.Uniform:
    """``prog[name]`` as the Uniform it is (a program's members are also its attributes, and
    could be uniform blocks; the renderer's programs declare none)."""
    member = prog[name]
    if not isinstance(member, moderngl.Uniform):
        raise UniformError(
            f"shader {(prog.extra or {}).get('file', '?')}: {name!r} is a "
            f"{type(member).__name__}, not a uniform"
        )
    return member


def set_uniforms(prog: moderngl.Program, values: dict[str, Any]) -> None:
    """Set uniforms by name. A name the source declares but the compiler dropped (unused in
    this variant) is skipped, as it must be; a name the source never declares is a typo: an
    UniformError under EXHIBIT_STRICT_UNIFORMS=1 (tests), else logged once (a kiosk keeps
    drawing). Bytes are written as they are (std140 blocks, matrices)."""
    for name, value in values.items():
        if name in prog:
            if isinstance(value, bytes):
                uniform(prog, name).write(value)
            else:
                prog[name] = value  # Program.__setitem__: the member's .value
            continue
        info = prog.extra or {}
        if name in info.get("uniforms", ()):
            continue
        message = (
            f"shader {info.get('file', '?')}: no uniform {name!r} is declared "
            f"(it declares {', '.join(sorted(info.get('uniforms', ()))) or 'none'})"
        )
        if os.environ.get(STRICT_ENV) == "1":
            raise UniformError(message)
        key = (str(info.get("file")), name)
        if key not in _reported:
            _reported.add(key)
            log.error("%s", message)
