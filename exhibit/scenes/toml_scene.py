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

Every problem is reported with the file and the key, and what was wrong.
"""

from __future__ import annotations

import hashlib
import math
import re
import tomllib
from pathlib import Path

import numpy as np

from exhibit.errors import ExhibitError
from exhibit.geometry.view import ViewState
from exhibit.scenes.base import Parameter, Scene
from exhibit.scenes.implicit_scene import mesh_implicit
from exhibit.surfaces.expressions import ExpressionError, check_expression, compile_field
from exhibit.surfaces.mesh import Material, Mesh4D
from exhibit.surfaces.parametric import Interval, tessellate

TOP_KEYS = {"name", "title", "caption", "axes", "resolution", "parameters", "surface", "view"}
SURFACE_KEYS = {"name", "color", "style", "f1", "f2", "box", "point", "s", "t"}
PARAMETER_KEYS = {"default", "min", "max", "help"}
VIEW_KEYS = {"angles", "sensor_distance", "eye_azimuth", "eye_incidence", "twist",
             "eye_distance", "half_height", "reading"}
NAME = re.compile(r"^[a-z0-9][a-z0-9-]*$")


class _Checker:
    """Reads values out of the TOML table and raises ExhibitError naming file and key."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, key: str, reason: str):
        raise ExhibitError(f"{self.path}: {key}: {reason}")

    def unknown(self, table: dict, allowed: set, where: str):
        for key in table:
            if key not in allowed:
                self.fail(f"{where}{key}", f"unknown key (allowed: {', '.join(sorted(allowed))})")

    def string(self, table, key, where="", required=True, default=""):
        if key not in table:
            if required:
                self.fail(where + key, "missing")
            return default
        if not isinstance(table[key], str) or not table[key].strip():
            self.fail(where + key, "must be a non-empty string")
        return table[key]

    def number(self, table, key, where="", default=None, allow_inf=False):
        if key not in table:
            if default is None:
                self.fail(where + key, "missing")
            return default
        value = table[key]
        if allow_inf and value == "inf":
            return math.inf
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(where + key, f"must be a finite number, got {value!r}")
        return float(value)

    def numbers(self, value, count, key):
        if not isinstance(value, list) or len(value) != count or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in value):
            self.fail(key, f"must be a list of {count} finite numbers, got {value!r}")
        return [float(v) for v in value]


def load_scene_file(path: Path) -> Scene:
    path = Path(path)
    check = _Checker(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ExhibitError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise ExhibitError(f"{path}: not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise ExhibitError(f"{path}: not valid TOML: {exc}") from None
    check.unknown(data, TOP_KEYS, "")
    name = check.string(data, "name")
    if not NAME.match(name):
        check.fail("name", f"{name!r} must be lower-case letters, digits and dashes")
    title = check.string(data, "title")
    caption = check.string(data, "caption")
    axes = data.get("axes", ["x", "y", "z", "w"])
    if (not isinstance(axes, list) or len(axes) != 4 or len(set(axes)) != 4
            or not all(isinstance(a, str) and a.isidentifier() for a in axes)):
        check.fail("axes", f"must be four different names, got {axes!r}")
    resolution = int(check.number(data, "resolution", default=48.0))
    if not 4 <= resolution <= 512:
        check.fail("resolution", f"must lie between 4 and 512, got {resolution}")

    parameters = []
    raw_params = data.get("parameters", {})
    if not isinstance(raw_params, dict):
        check.fail("parameters", "must be a table of [parameters.NAME] tables")
    for pname, table in raw_params.items():
        where = f"parameters.{pname}."
        if not isinstance(table, dict):
            check.fail(f"parameters.{pname}", "must be a table with default, min, max, help")
        if not pname.isidentifier() or pname in axes:
            check.fail(f"parameters.{pname}", "must be a name that is not an axis")
        check.unknown(table, PARAMETER_KEYS, where)
        default = check.number(table, "default", where)
        low = check.number(table, "min", where, default=-math.inf)
        high = check.number(table, "max", where, default=math.inf)
        if not low <= default <= high:
            check.fail(where + "default", f"{default} is outside [{low}, {high}]")
        parameters.append(Parameter(pname, default, low, high, table.get("help", "")))
    defaults = {p.name: p.default for p in parameters}

    surfaces = data.get("surface")
    if not isinstance(surfaces, list) or not surfaces:
        check.fail("surface", "at least one [[surface]] table is needed")
    specs = [_surface_spec(check, index, table, axes, defaults)
             for index, table in enumerate(surfaces)]

    def build(params: dict, resolution: int) -> Mesh4D:
        mesh = Mesh4D()
        for spec in specs:
            mesh.surfaces.append(spec(params, resolution))
        return mesh

    view = _view(check, data.get("view", {}))
    return Scene(name=name, title=title, caption=caption, parameters=tuple(parameters),
                 build_mesh=build, view=view, axes=tuple(axes), default_resolution=resolution,
                 version=hashlib.sha256(path.read_bytes()).hexdigest()[:16])


def _surface_spec(check: _Checker, index: int, table, axes, defaults):
    where = f"surface[{index}]."
    if not isinstance(table, dict):
        check.fail(f"surface[{index}]", "must be a table")
    check.unknown(table, SURFACE_KEYS, where)
    name = check.string(table, "name", where, required=False, default=f"surface {index + 1}")
    color = check.numbers(table.get("color", [0.7, 0.7, 0.7]), 3, where + "color")
    try:
        material = Material(color=tuple(color), style=table.get("style", "solid"))
    except ValueError as exc:
        check.fail(where + ("style" if "style" in str(exc) else "color"), str(exc))

    def formula(key, variables):
        text = check.string(table, key, where)
        try:
            check_expression(text, variables, defaults)
        except ExpressionError as exc:
            check.fail(where + key, str(exc))
        return text

    implicit = "f1" in table or "f2" in table
    parametric = "point" in table
    if implicit == parametric:
        check.fail(f"surface[{index}]", "give either f1, f2 and box (implicit) or point, s and t "
                                        "(parametric)")
    if implicit:
        f1, f2 = formula("f1", axes), formula("f2", axes)
        box = table.get("box")
        if not isinstance(box, list) or len(box) != 4:
            check.fail(where + "box", "must be four [low, high] pairs, one per axis")
        bounds = [check.numbers(pair, 2, f"{where}box[{k}]") for k, pair in enumerate(box)]
        for k, (low, high) in enumerate(bounds):
            if low >= high:
                check.fail(f"{where}box[{k}]", f"low {low} must be below high {high}")
        lo, hi = [b[0] for b in bounds], [b[1] for b in bounds]

        def build_implicit(params, resolution):
            return mesh_implicit(name, f1, f2, axes, params, lo, hi, resolution, material).surface
        return build_implicit

    point = table["point"]
    if not isinstance(point, list) or len(point) != 4:
        check.fail(where + "point", "must be four formulas in s and t, one per axis")
    for k, text in enumerate(point):
        if not isinstance(text, str):
            check.fail(f"{where}point[{k}]", "must be a formula string")
        try:
            check_expression(text, ("s", "t"), defaults)
        except ExpressionError as exc:
            check.fail(f"{where}point[{k}]", str(exc))
    intervals = []
    for key in ("s", "t"):
        raw = table.get(key)
        if (not isinstance(raw, list) or len(raw) != 3 or not isinstance(raw[2], bool)):
            check.fail(where + key, "must be [start, stop, periodic] with periodic true or false")
        start, stop = check.numbers(raw[:2], 2, where + key)
        if stop <= start:
            check.fail(where + key, f"stop {stop} must be above start {start}")
        intervals.append(Interval(start, stop, raw[2]))

    def build_parametric(params, resolution):
        fields = [compile_field(text, ("s", "t"), params) for text in point]

        def position(s, t):
            grid = np.stack([s, t], -1)
            return np.stack([f.value(grid) for f in fields], -1)

        def tangents(s, t):
            grid = np.stack([s, t], -1)
            gradients = [f.gradient(grid) for f in fields]  # each (..., 2)
            return (np.stack([g[..., 0] for g in gradients], -1),
                    np.stack([g[..., 1] for g in gradients], -1))

        return tessellate(name, position, intervals[0], intervals[1], (resolution, resolution),
                          tangents, material)
    return build_parametric


def _view(check: _Checker, table) -> ViewState:
    if not isinstance(table, dict):
        check.fail("view", "must be a table")
    check.unknown(table, VIEW_KEYS, "view.")
    changes = {}
    if "angles" in table:
        changes["angles"] = [math.radians(a) for a in check.numbers(table["angles"], 6,
                                                                     "view.angles")]
    for key in ("eye_azimuth", "eye_incidence", "twist"):
        if key in table:
            changes[key] = math.radians(check.number(table, key, "view."))
    if "half_height" in table:
        changes["half_height"] = check.number(table, "half_height", "view.")
    if "reading" in table:
        changes["reading"] = table["reading"]
    for key, field in (("sensor_distance", "sensor_r"), ("eye_distance", "eye_r")):
        if key in table:
            distance = check.number(table, key, "view.", allow_inf=True)
            if distance <= 0:
                check.fail("view." + key, "must be positive or \"inf\"")
            changes[field] = 0.0 if math.isinf(distance) else 1.0 / distance
    try:
        return ViewState(**changes)
    except ValueError as exc:
        check.fail("view", str(exc))
