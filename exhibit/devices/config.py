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
unknown parameter 'theta7'``), never a traceback.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from exhibit.devices.base import DeviceError, Kind
from exhibit.devices.mapping import PARAMS, Binding, MappingConfig, ParamLimits
from exhibit.devices.url import backend_for_url

__all__ = ["DeviceConfig", "load_config", "parse_config", "DEFAULT_CONFIG"]

DEFAULT_CONFIG = Path(__file__).resolve().parents[2] / "configs" / "devices" / "default.toml"
_INPUTS = {"axis": Kind.ABS, "delta": Kind.REL, "button": Kind.BUTTON}


@dataclass(frozen=True)
class DeviceConfig:
    devices: dict[str, str] = field(default_factory=dict)  # name -> URL
    mapping: MappingConfig = field(default_factory=MappingConfig)
    activity_threshold: float = 0.15
    layout_dirs: tuple[Path, ...] | None = None
    source: str = "<config>"


def _num(table, key, where, default, low=None, high=None, strict_low=False):
    v = table.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise DeviceError(f"{where}.{key}: expected a number, got {v!r}")
    v = float(v)
    if math.isnan(v) or (low is not None and (v <= low if strict_low else v < low)) or (
            high is not None and v > high):
        rng = f"{'>' if strict_low else '>='} {low}" if high is None else f"in [{low}, {high}]"
        raise DeviceError(f"{where}.{key}: must be {rng}, got {v}")
    return v


def _keys(table: dict, allowed: set[str], where: str) -> None:
    for k in table:
        if k not in allowed:
            raise DeviceError(f"{where}: unknown key {k!r} (allowed: {', '.join(sorted(allowed))})")


def parse_config(doc: dict, source: str = "<config>", base: Path | None = None) -> DeviceConfig:
    """A DeviceConfig from parsed TOML (only the devices/mapping/activity/layouts tables are
    read, so a kiosk config can hold other tables too)."""
    layout_dirs = None
    if "layouts" in doc:
        dirs = doc["layouts"]
        if not isinstance(dirs, list) or not all(isinstance(d, str) for d in dirs):
            raise DeviceError(f"{source}: layouts: expected a list of directories")
        from exhibit.devices.hid import LAYOUT_DIR

        base = base or Path(".")
        layout_dirs = (LAYOUT_DIR, *[(base / d) for d in dirs])
    devices: dict[str, str] = {}
    raw_devices = doc.get("devices", {})
    if not isinstance(raw_devices, dict):
        raise DeviceError(f"{source}: devices: expected a table of [devices.NAME]")
    for name, table in raw_devices.items():
        where = f"{source}: devices.{name}"
        if not isinstance(table, dict):
            raise DeviceError(f"{where}: expected a table with url = \"...\"")
        _keys(table, {"url"}, where)
        url = table.get("url")
        if not isinstance(url, str):
            raise DeviceError(f"{where}.url: missing (e.g. url = \"serial:///dev/exhibit-controller\")")
        try:
            backend_for_url(url, name, layout_dirs=layout_dirs)  # checks options and layouts
        except DeviceError as exc:
            raise DeviceError(f"{where}.url: {exc}") from None
        devices[name] = url

    m = doc.get("mapping", {})
    where = f"{source}: mapping"
    if not isinstance(m, dict):
        raise DeviceError(f"{where}: expected a table")
    _keys(m, {"sensor_min_distance", "bind", "limits", "home_angles", "home_sensor_distance"}, where)
    min_d = _num(m, "sensor_min_distance", where, 2.0, 0.0, strict_low=True)
    home_d = _num(m, "home_sensor_distance", where, math.inf, 0.0, strict_low=True)
    home = m.get("home_angles", [0.0] * 6)
    if (not isinstance(home, list) or len(home) != 6
            or not all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in home)):
        raise DeviceError(f"{where}.home_angles: expected six angles in degrees, got {home!r}")

    limits: dict[str, ParamLimits] = {}
    raw_limits = m.get("limits", {})
    if not isinstance(raw_limits, dict):
        raise DeviceError(f"{where}.limits: expected a table, e.g. theta2 = [-180, 0]")
    for param, pair in raw_limits.items():
        lw = f"{where}.limits.{param}"
        if param not in PARAMS[:6]:
            raise DeviceError(f"{lw}: limits are for theta1..theta6 (the sensor has "
                              "sensor_min_distance)")
        if (not isinstance(pair, list) or len(pair) != 2 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in pair)
                or not pair[0] < pair[1]):
            raise DeviceError(f"{lw}: expected [low, high] in degrees with low < high, got {pair!r}")
        limits[param] = ParamLimits(float(pair[0]), float(pair[1]))

    bindings = []
    raw_bind = m.get("bind", [])
    if not isinstance(raw_bind, list):
        raise DeviceError(f"{where}.bind: expected [[mapping.bind]] tables")
    for i, b in enumerate(raw_bind):
        bw = f"{where}.bind[{i}]"
        if not isinstance(b, dict):
            raise DeviceError(f"{bw}: expected a table")
        _keys(b, {"device", "input", "param", "step", "rate", "dead_zone", "curve", "invert",
                  "action"}, bw)
        device = b.get("device")
        if not isinstance(device, str):
            raise DeviceError(f"{bw}.device: missing (the name of a [devices.NAME] table)")
        if devices and device not in devices and device != "*":
            raise DeviceError(f"{bw}.device: no device {device!r} (configured: "
                              f"{', '.join(devices)})")
        inp = b.get("input")
        words = inp.split() if isinstance(inp, str) else []
        if len(words) != 2 or words[0] not in _INPUTS or not words[1].isdigit() or int(words[1]) < 1:
            raise DeviceError(f"{bw}.input: expected 'axis N', 'delta N' or 'button N' "
                              f"(N from 1), got {inp!r}")
        kind, index = _INPUTS[words[0]], int(words[1]) - 1
        param, action = b.get("param"), b.get("action")
        invert = b.get("invert", False)
        if not isinstance(invert, bool):
            raise DeviceError(f"{bw}.invert: expected true or false, got {invert!r}")
        if kind is Kind.BUTTON:
            if action != "home" or param is not None:
                raise DeviceError(f"{bw}: a button takes action = \"home\" (no param)")
            bindings.append(Binding(device, kind, index, action="home"))
            continue
        if action is not None:
            raise DeviceError(f"{bw}.action: only buttons have actions")
        if param not in PARAMS:
            raise DeviceError(f"{bw}.param: unknown parameter {param!r} (one of "
                              f"{', '.join(PARAMS)})")
        if kind is Kind.REL:
            for k in ("rate", "dead_zone", "curve"):
                if k in b:
                    raise DeviceError(f"{bw}.{k}: only for axes; a {words[0]} takes step")
            step = _num(b, "step", bw, 5.0 if param != "sensor" else 0.025)
            bindings.append(Binding(device, kind, index, param, step=step, invert=invert))
        else:
            if "step" in b:
                raise DeviceError(f"{bw}.step: only for deltas; an axis takes rate")
            rate = _num(b, "rate", bw, 90.0 if param != "sensor" else 0.25)
            dz = _num(b, "dead_zone", bw, 0.0, 0.0, 0.95)
            curve = _num(b, "curve", bw, 1.0, 0.2, 5.0)
            bindings.append(Binding(device, kind, index, param, rate=rate, dead_zone=dz,
                                    curve=curve, invert=invert))

    act = doc.get("activity", {})
    if not isinstance(act, dict):
        raise DeviceError(f"{source}: activity: expected a table")
    _keys(act, {"threshold"}, f"{source}: activity")
    threshold = _num(act, "threshold", f"{source}: activity", 0.15, 0.0, 1.0)

    mapping = MappingConfig(tuple(bindings), min_d, limits, tuple(float(a) for a in home), home_d)
    return DeviceConfig(devices, mapping, threshold, layout_dirs, source)


def load_config(path: str | Path | None = None) -> DeviceConfig:
    path = Path(path) if path is not None else DEFAULT_CONFIG
    try:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    except OSError as exc:
        raise DeviceError(f"cannot read device config {path}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise DeviceError(f"{path}: not valid TOML: {exc}") from None
    return parse_config(doc, str(path), path.parent)
