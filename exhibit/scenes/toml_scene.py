"""Scenes written by curators as TOML files: no code, only formulas, colours and a view.

    name = "veronese"                      # unique; letters, digits and dashes
    title = "..."                          # shown to visitors
    caption = "..."
    axes = ["x", "y", "z", "w"]            # optional names of the four coordinates
    resolution = 48                        # optional default mesh resolution

    [parameters.a]                         # optional, any number of them
    default = 0.2
    min = -1.0
    max = 1.0
    help = "what it changes"

    [[surface]]                            # one or more
    name = "..."
    color = [0.3, 0.6, 0.9]                # optional; style = "solid" | "wire"
    f1 = "x^2 + y^2 + z^2 + w^2 - 1"       # implicit: f1 = f2 = 0 inside box
    f2 = "x*y - z*w - a"
    box = [[-1.2, 1.2], [-1.2, 1.2], [-1.2, 1.2], [-1.2, 1.2]]
    # or parametric: point = ["...", "...", "...", "..."] in s and t, with
    # s = [start, stop, periodic] and t = [start, stop, periodic]

    [view]                                 # optional; angles in degrees
    angles = [0, -30, -20, 0, 0, 0]
    sensor_distance = 3.0                  # or "inf"
    eye_azimuth = 20
    eye_incidence = -60
    half_height = 1.5
    fit = true                             # framed into the screen's free area (default)

Every problem is reported with the file and the key, and what was wrong: the structure by the
typed layer (:mod:`exhibit.schema`), each formula by :func:`check_expression` on its own box.
"""

from __future__ import annotations

import hashlib
import math
import re
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, PlainValidator

from exhibit.errors import ConfigError, ExhibitError
from exhibit.geometry.view import ViewState
from exhibit.scenes.base import Parameter, Scene
from exhibit.scenes.implicit_scene import mesh_implicit
from exhibit.schema import Model, read_bytes, read_toml, validate
from exhibit.schema.types import (
    MAX_COORDINATE,
    Angle,
    Caption,
    Distance,
    HalfHeight,
    Name,
    Number,
    Numbers,
    Resolution,
    Text,
    distance_to_r,
    fail,
    numbers_check,
    text_check,
)
from exhibit.scenes import checked
from exhibit.surfaces.expressions import (
    MAX_LENGTH,
    ExpressionError,
    check_expression,
    compile_field,
)
from exhibit.surfaces.mesh import Material, Mesh4D
from exhibit.surfaces.parametric import Interval, tessellate

NAME = re.compile(r"^[a-z0-9][a-z0-9-]{0,63}$")
#: Scene parameters are bounded so no formula meets a value it cannot evaluate.
MAX_PARAMETER = 1e6


def _scene_name(value: Any) -> str:
    if not isinstance(value, str) or not NAME.match(value):
        raise fail("must be lower-case letters, digits and dashes (at most 64)", value)
    return value


def _axes(value: Any) -> tuple[str, str, str, str]:
    if (
        not isinstance(value, list)
        or len(value) != 4
        or len(set(value)) != 4
        or not all(isinstance(a, str) and a.isidentifier() and len(a) <= 16 for a in value)
    ):
        raise fail("must be four different names", value)
    x, y, z, w = value
    return (x, y, z, w)


def _box_pair(value: Any) -> tuple[float, float]:
    low, high = numbers_check(2, -MAX_COORDINATE, MAX_COORDINATE)(value)
    if low >= high:
        raise fail(f"low {low:g} must be below high {high:g}", show=False)
    return low, high


BoxPair = Annotated[tuple[float, float], PlainValidator(_box_pair)]


def _interval(value: Any) -> Interval:
    if not isinstance(value, list) or len(value) != 3 or not isinstance(value[2], bool):
        raise fail("must be [start, stop, periodic] with periodic true or false", value)
    start, stop = numbers_check(2, -MAX_COORDINATE, MAX_COORDINATE)(value[:2])
    if stop <= start:
        raise fail(f"stop {stop:g} must be above start {start:g}", show=False)
    return Interval(start, stop, value[2])


Formula = Annotated[str, Text(MAX_LENGTH)]
_formula = text_check(MAX_LENGTH)


def _formulas(value: Any) -> list[str]:
    if not isinstance(value, list) or len(value) != 4:
        raise fail("must be four formulas in s and t, one per axis", value)
    return [_formula(v) for v in value]


class ParameterSpec(Model):
    default: Annotated[float, Number(-MAX_PARAMETER, MAX_PARAMETER)]
    min: Annotated[float, Number(-MAX_PARAMETER, MAX_PARAMETER)] = -MAX_PARAMETER
    max: Annotated[float, Number(-MAX_PARAMETER, MAX_PARAMETER)] = MAX_PARAMETER
    help: Annotated[str, Text(500, empty_ok=True)] = ""


class SurfaceSpec(Model):
    name: Name | None = None
    color: Annotated[tuple[float, float, float], Numbers(3, 0.0, 1.0)] = (0.7, 0.7, 0.7)
    style: Literal["solid", "wire"] = "solid"
    f1: Formula | None = None
    f2: Formula | None = None
    box: Annotated[list[BoxPair], Field(min_length=4, max_length=4)] | None = None
    point: Annotated[list[str], PlainValidator(_formulas)] | None = None
    s: Annotated[Interval, PlainValidator(_interval)] | None = None
    t: Annotated[Interval, PlainValidator(_interval)] | None = None


class ViewSpec(Model):
    angles: Annotated[tuple[float, ...], Numbers(6, -3600, 3600)] | None = None
    sensor_distance: Distance | None = None
    eye_distance: Distance | None = None
    eye_azimuth: Angle | None = None
    eye_incidence: Angle | None = None
    twist: Angle | None = None
    half_height: HalfHeight | None = None
    reading: Literal["screen", "object"] | None = None
    fit: bool = True


class SceneFile(Model):
    name: Annotated[str, PlainValidator(_scene_name)]
    title: Annotated[str, Text(200)]
    caption: Caption
    axes: Annotated[tuple[str, str, str, str], PlainValidator(_axes)] = ("x", "y", "z", "w")
    resolution: Resolution = 48
    parameters: dict[str, ParameterSpec] = {}
    surface: list[SurfaceSpec] = []
    view: ViewSpec = ViewSpec()


def load_scene_file(path: Path) -> Scene:
    """A scene from a curator's file; ExhibitError (a ConfigError) lists every problem."""
    path = Path(path)
    data = read_toml(path)
    spec = validate(SceneFile, data, str(path))
    problems: list[str] = []

    def problem(key: str, reason: str) -> None:
        problems.append(f"{path}: {key}: {reason}")

    parameters = []
    for pname, p in spec.parameters.items():
        if not pname.isidentifier() or pname in spec.axes or len(pname) > 32:
            problem(f"parameters.{pname}", "must be a name that is not an axis")
        elif not p.min <= p.default <= p.max:
            problem(
                f"parameters.{pname}.default", f"{p.default:g} is outside [{p.min:g}, {p.max:g}]"
            )
        else:
            parameters.append(Parameter(pname, p.default, p.min, p.max, p.help))
    if not spec.surface:
        problem("surface", "at least one [[surface]] table is needed")
    defaults = {p.name: p.default for p in parameters}
    specs = []
    formulas: list[_Formula] = []
    for index, surface in enumerate(spec.surface):
        try:
            specs.append(
                _surface_spec(path, index, surface, spec.axes, defaults, parameters, formulas)
            )
        except ConfigError as exc:
            problems.extend(exc.problems)
    if problems:
        raise ConfigError(problems)

    def build(params: dict, resolution: int) -> Mesh4D:
        mesh = Mesh4D()
        for index, make in enumerate(specs):
            try:
                mesh.surfaces.append(make(params, resolution))
            except ExpressionError as exc:  # e.g. x/(a-1) with a = 1: checked at the defaults
                raise ExhibitError(
                    f"{path}: surface[{index}]: cannot be built with {params}: {exc}"
                ) from None
        return mesh

    return Scene(
        name=spec.name,
        title=spec.title,
        caption=spec.caption,
        parameters=tuple(parameters),
        build_mesh=build,
        view=_view(path, spec.view),
        axes=spec.axes,
        default_resolution=spec.resolution,
        # what labels and claims may name: the file's surfaces (it draws nothing else)
        objects=tuple(_surface_name(i, s) for i, s in enumerate(spec.surface)),
        fit=spec.view.fit,
        version=hashlib.sha256(read_bytes(path)).hexdigest()[:16],
        source=path,
        check=_domain_check(path, formulas, defaults),
    )


#: One formula as the file gives it: its key, text, variables and the box it is drawn on.
_Formula = tuple[str, str, tuple[str, ...], list[tuple[float, float]]]


def _domain_check(path: Path, formulas: list[_Formula], defaults: dict[str, float]):
    """Scene.check for a curator's scene: every formula, at the parameter values asked for, held
    to the check it passed at the defaults when the file was loaded (check_expression on its box:
    a constant part undefined, as log(a) at a = -0.5, or the value undefined on nearly all of the
    box). So a timeline's ``params`` that the kiosk could not build are refused by check-config,
    not found when the kiosk drops the scene. A pass is remembered (exhibit.scenes.checked), so
    only new values cost sympy; the defaults were checked at load."""
    verdicts: dict[tuple, str | None] = {}

    def check(params: dict) -> str | None:
        values = {k: float(v) for k, v in params.items()}
        if values == defaults:
            return None
        key = tuple(sorted(values.items()))
        if key not in verdicts:
            verdicts[key] = None
            at = ", ".join(f"{k} = {v:g}" for k, v in key)
            for where, text, variables, box in formulas:
                try:
                    checked.check(text, variables, values, box)
                except ExpressionError as exc:
                    verdicts[key] = f"{path.name}: {where}: cannot be built at {at}: {exc}"
                    break
            if verdicts[key] is None:
                checked.save()
        return verdicts[key]

    return check


def _check(path, key, text, variables, defaults, box) -> str:
    """The formula, checked on its box (symbolically and on samples): a formula that cannot be
    evaluated there is refused now, by file and key, not when the kiosk builds it."""
    try:
        check_expression(text, variables, defaults)  # cheap: syntax, names, sizes
        checked.check(text, variables, defaults, box)
    except ExpressionError as exc:
        raise ConfigError(f"{path}: {key}: {exc}") from None
    return text


def _surface_name(index: int, surface: SurfaceSpec) -> str:
    """A [[surface]]'s name: its ``name``, else "surface N" (N from 1, in the file's order)."""
    return surface.name or f"surface {index + 1}"


def _surface_spec(path: Path, index: int, surface: SurfaceSpec, axes, defaults, parameters, checks):
    """How to build one [[surface]]; its formulas, checked at the defaults, join ``checks``."""
    where = f"surface[{index}]"
    name = _surface_name(index, surface)
    material = Material(color=surface.color, style=surface.style)
    implicit = surface.f1 is not None or surface.f2 is not None or surface.box is not None
    parametric = surface.point is not None or surface.s is not None or surface.t is not None
    if implicit == parametric:
        raise ConfigError(
            f"{path}: {where}: give either f1, f2 and box (implicit) or point, s and t (parametric)"
        )
    needed = ("f1", "f2", "box") if implicit else ("point", "s", "t")
    missing = [f"{path}: {where}.{key}: missing" for key in needed if getattr(surface, key) is None]
    if missing:
        raise ConfigError(missing)
    if implicit:
        box = surface.box
        assert box is not None  # not missing (above)
        f1 = _check(path, f"{where}.f1", surface.f1, axes, defaults, box)
        f2 = _check(path, f"{where}.f2", surface.f2, axes, defaults, box)
        pairs = [(float(b[0]), float(b[1])) for b in box]
        checks += [(f"{where}.f{k}", f, tuple(axes), pairs) for k, f in ((1, f1), (2, f2))]
        lo, hi = [b[0] for b in box], [b[1] for b in box]

        def build_implicit(params, resolution):
            return mesh_implicit(name, f1, f2, axes, params, lo, hi, resolution, material).surface

        return build_implicit

    s_range, t_range, formulas = surface.s, surface.t, surface.point
    assert s_range is not None and t_range is not None and formulas is not None  # not missing
    intervals = (s_range, t_range)
    box = [(i.start, i.stop) for i in intervals]
    point = [
        _check(path, f"{where}.point[{k}]", text, ("s", "t"), defaults, box)
        for k, text in enumerate(formulas)
    ]
    checks += [(f"{where}.point[{k}]", text, ("s", "t"), box) for k, text in enumerate(point)]

    def build_parametric(params, resolution):
        fields = [compile_field(text, ("s", "t"), params) for text in point]

        def position(s, t):
            grid = np.stack([s, t], -1)
            return np.stack([f.value(grid) for f in fields], -1)

        def tangents(s, t):
            grid = np.stack([s, t], -1)
            gradients = [f.gradient(grid) for f in fields]  # each (..., 2)
            return (
                np.stack([g[..., 0] for g in gradients], -1),
                np.stack([g[..., 1] for g in gradients], -1),
            )

        return tessellate(
            name, position, intervals[0], intervals[1], (resolution, resolution), tangents, material
        )

    return build_parametric


def _view(path: Path, spec: ViewSpec) -> ViewState:
    changes: dict = {}
    if spec.angles is not None:
        changes["angles"] = [math.radians(a) for a in spec.angles]
    for key in ("eye_azimuth", "eye_incidence", "twist"):
        if getattr(spec, key) is not None:
            changes[key] = math.radians(getattr(spec, key))
    if spec.half_height is not None:
        changes["half_height"] = spec.half_height
    if spec.reading is not None:
        changes["reading"] = spec.reading
    if spec.sensor_distance is not None:
        changes["sensor_r"] = distance_to_r(spec.sensor_distance)
    if spec.eye_distance is not None:
        changes["eye_r"] = distance_to_r(spec.eye_distance)
    try:
        return ViewState(**changes)
    except ValueError as exc:
        raise ConfigError(f"{path}: view: {exc}") from None
