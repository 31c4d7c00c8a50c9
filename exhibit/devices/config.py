"""Device configuration: which devices (by URL) and how they map onto the seven parameters.

A TOML file (configs/devices/default.toml is the documented example) or the same tables inside a
larger kiosk config::

    [devices.controller]
    url = "serial:///dev/exhibit-controller"

    [mapping]
    sensor_min_distance = 2.0

    [[mapping.bind]]
    device = "controller"
    input = "axis 1"        # axis N, delta N, button N: 1-based, as labelled on the hardware
    param = "theta1"        # theta1..theta6 or sensor
    rate = 90               # degrees per second at full deflection (sensor: r per second)

Every mistake is a DeviceError naming the file and the key (``default.toml: mapping.bind[3].param:
must be 'theta1', ... or 'sensor', got 'theta7'``), all of them at once, never a traceback. The
values are typed by :mod:`exhibit.schema`, with limits that keep the mapping's arithmetic finite:
a step or rate can never carry a parameter to inf or NaN.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from exhibit.devices.base import DeviceConfigError, DeviceError, Kind
from exhibit.devices.mapping import PARAMS, Action, Binding, MappingConfig, Param, ParamLimits
from exhibit.devices.url import backend_for_url
from exhibit.errors import ConfigError
from exhibit.resources import shipped
from exhibit.schema import Model, read_toml, validate
from exhibit.schema.files import parse_int
from exhibit.schema.types import (
    MAX_ANGLE,
    MAX_DISTANCE,
    MIN_DISTANCE,
    Distance,
    Name,
    Number,
    Numbers,
    Text,
)

__all__ = [
    "DeviceConfig",
    "DeviceConfigError",
    "load_config",
    "parse_config",
    "DEFAULT_CONFIG",
    "STEP_LIMITS",
    "RATE_LIMITS",
]

DEFAULT_CONFIG = shipped("configs", "devices", "default.toml")
_INPUTS = {"axis": Kind.ABS, "delta": Kind.REL, "button": Kind.BUTTON}
#: The largest step per detent and rate at full deflection: degrees for angles, r = 1/d for the
#: sensor (whose whole range is [0, 1/sensor_min_distance]).
STEP_LIMITS = {"angle": 180.0, "sensor": 1.0}
RATE_LIMITS = {"angle": 1440.0, "sensor": 20.0}


_Step = Annotated[float, Number(-STEP_LIMITS["angle"], STEP_LIMITS["angle"])]
_Rate = Annotated[float, Number(0.0, RATE_LIMITS["angle"])]


@dataclass(frozen=True)
class DeviceConfig:
    devices: dict[str, str] = field(default_factory=dict)  # name -> URL
    mapping: MappingConfig = field(default_factory=MappingConfig)
    activity_threshold: float = 0.15
    layout_dirs: tuple[Path, ...] | None = None
    source: str = "<config>"


class DeviceEntry(Model):
    url: Annotated[str, Text(1000)]


class BindSpec(Model):
    device: Name
    input: Annotated[str, Text(40)]
    param: Param | None = None
    step: _Step | None = None
    rate: _Rate | None = None
    dead_zone: Annotated[float, Number(0.0, 0.95)] = 0.0
    curve: Annotated[float, Number(0.2, 5.0)] = 1.0
    invert: bool = False
    action: Action | None = None
    hold_s: Annotated[float, Number(0.5, 10.0)] | None = None


class MappingSpec(Model):
    sensor_min_distance: Annotated[float, Number(MIN_DISTANCE, MAX_DISTANCE)] = 2.0
    home_angles: Annotated[tuple[float, ...], Numbers(6, -180.0, 180.0)] = (0.0,) * 6
    home_sensor_distance: Distance = math.inf
    limits: dict[str, Any] = {}
    bind: list[BindSpec] = []


class ActivitySpec(Model):
    threshold: Annotated[float, Number(0.0, 1.0)] = 0.15


class DevicesFile(Model):
    devices: dict[str, DeviceEntry] = {}
    mapping: MappingSpec = MappingSpec()
    activity: ActivitySpec = ActivitySpec()
    layouts: list[Annotated[str, Text(4096)]] | None = None


def _binding(spec: BindSpec, where: str, devices: dict, problem) -> Binding | None:
    """The binding a [[mapping.bind]] table describes, or None after naming its problem.
    ``devices`` are the names configured (a device whose URL is wrong is still named, so its
    bindings get no second error); none configured: any name (devices come from --device)."""
    if devices and spec.device not in devices and spec.device != "*":
        return problem(
            f"{where}.device", f"no device {spec.device!r} (configured: {', '.join(devices)})"
        )
    words = spec.input.split()
    number = None
    if len(words) == 2 and words[0] in _INPUTS:
        with contextlib.suppress(ValueError):
            number = parse_int(words[1], 1, 256)  # ASCII digits only: never "²", "①" or "٣"
    if number is None:
        return problem(
            f"{where}.input",
            "expected 'axis N', 'delta N' or 'button N' (N from 1 "
            f"to 256, in the digits 0-9), got {spec.input!r}",
        )
    kind, index = _INPUTS[words[0]], number - 1
    if kind is Kind.BUTTON and (spec.action is None) == (spec.param is None):
        return problem(
            where,
            'a button takes either action = "home" or "next-scene", or a '
            "param it moves at rate while held",
        )
    if spec.hold_s is not None and spec.action != "language":
        return problem(
            f"{where}.hold_s",
            'only a "language" button waits to be held (a '
            "long press: a button that does something else "
            "when pressed can also switch the language)",
        )
    if kind is Kind.BUTTON and spec.action is not None:
        return Binding(spec.device, kind, index, action=spec.action, hold_s=spec.hold_s)
    if spec.action is not None:
        return problem(f"{where}.action", "only buttons have actions")
    if spec.param is None:
        return problem(f"{where}.param", "missing (theta1..theta6 or sensor)")
    unit = "sensor" if spec.param == "sensor" else "angle"
    if kind is not Kind.ABS:
        for key in ("dead_zone", "curve") + (("rate",) if kind is Kind.REL else ()):
            if key in spec.model_fields_set:
                return problem(
                    f"{where}.{key}",
                    f"only for axes; a {words[0]} takes {'step' if kind is Kind.REL else 'rate'}",
                )
    if kind is Kind.REL:
        step = spec.step if spec.step is not None else (5.0 if unit == "angle" else 0.025)
        if abs(step) > STEP_LIMITS[unit]:
            return problem(
                f"{where}.step",
                f"must lie in [-{STEP_LIMITS[unit]:g}, "
                f"{STEP_LIMITS[unit]:g}] for {spec.param}, got {step}",
            )
        return Binding(spec.device, kind, index, spec.param, step=step, invert=spec.invert)
    if spec.step is not None:
        held = "an axis" if kind is Kind.ABS else "a button"
        return problem(f"{where}.step", f"only for deltas; {held} takes rate")
    rate = spec.rate if spec.rate is not None else (90.0 if unit == "angle" else 0.25)
    if rate > RATE_LIMITS[unit]:
        return problem(
            f"{where}.rate", f"must lie in [0, {RATE_LIMITS[unit]:g}] for {spec.param}, got {rate}"
        )
    return Binding(
        spec.device,
        kind,
        index,
        spec.param,
        rate=rate,
        dead_zone=spec.dead_zone,
        curve=spec.curve,
        invert=spec.invert,
    )


def parse_config(doc: dict, source: str = "<config>", base: Path | None = None) -> DeviceConfig:
    """A DeviceConfig from parsed TOML; DeviceConfigError lists every problem."""
    try:
        spec = validate(DevicesFile, doc, source)
    except ConfigError as exc:
        raise DeviceConfigError(exc.problems) from None
    problems: list[str] = []

    def problem(key: str, reason: str) -> None:
        problems.append(f"{source}: {key}: {reason}")

    layout_dirs = None
    if spec.layouts is not None:
        from exhibit.devices.hid import LAYOUT_DIR

        layout_dirs = (LAYOUT_DIR, *[((base or Path(".")) / d) for d in spec.layouts])
    devices: dict[str, str] = {}
    for name, entry in spec.devices.items():
        try:
            backend_for_url(entry.url, name, layout_dirs=layout_dirs)  # checks options, layouts
            devices[name] = entry.url
        except ConfigError as exc:
            problems.extend(exc.problems)
        except DeviceError as exc:
            problem(f"devices.{name}.url", str(exc))

    m = spec.mapping
    limits: dict[str, ParamLimits] = {}
    for param, pair in m.limits.items():
        where = f"mapping.limits.{param}"
        if param not in PARAMS[:6]:
            problem(where, "limits are for theta1..theta6 (the sensor has sensor_min_distance)")
            continue
        ok = (
            isinstance(pair, list)
            and len(pair) == 2
            and all(
                isinstance(v, (int, float))
                and not isinstance(v, bool)
                and math.isfinite(v)
                and abs(v) <= MAX_ANGLE
                for v in pair
            )
        )
        if not ok or not pair[0] < pair[1]:
            problem(where, f"expected [low, high] in degrees with low < high, got {pair!r}")
            continue
        limits[param] = ParamLimits(float(pair[0]), float(pair[1]))

    bindings = []
    for i, b in enumerate(m.bind):
        binding = _binding(b, f"mapping.bind[{i}]", spec.devices, problem)
        if binding is not None:
            bindings.append(binding)
    if problems:
        raise DeviceConfigError(problems)
    mapping = MappingConfig(
        tuple(bindings), m.sensor_min_distance, limits, m.home_angles, m.home_sensor_distance
    )
    return DeviceConfig(devices, mapping, spec.activity.threshold, layout_dirs, source)


def load_config(path: str | Path | None = None) -> DeviceConfig:
    path = Path(path) if path is not None else DEFAULT_CONFIG
    try:
        doc = read_toml(path)
    except ConfigError as exc:
        raise DeviceConfigError(exc.problems) from None
    return parse_config(doc, str(path), path.parent)
