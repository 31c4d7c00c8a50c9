"""`exhibit monitor [--json]`: the live mapped parameters, for installers wiring a kiosk.

Polls every configured device (as the kiosk does, never blocking), applies the mapping, and
prints the seven parameters, each device's state, the buttons and the idle time a few times a
second. Whenever a device's state or what it says of itself changes (the controller's HELLO:
its firmware version; a HID device's product name; why a device is missing), a line says so. A
button is shown on every line while it is held, and on the next line after a press too
short to be seen held (a tap between two lines), with what the mapping makes it do. With --json
every line is a JSON object, for scripts.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Sequence

from exhibit.commands import _arg_types as _args
from exhibit.commands._device_options import add_config_arguments, config_from_args
from exhibit.devices.base import Event, Kind
from exhibit.devices.hub import DeviceSet
from exhibit.devices.mapping import ActivityDetector, Mapper
from exhibit.geometry.view import ViewState

HELP = "show the live mapped parameters (angles, sensor distance) and device states"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    parser.add_argument("--json", action="store_true", help="one JSON object per line")
    parser.add_argument(
        "--rate", type=_args.number(0.1, 100), default=5.0, help="lines per second (default 5)"
    )
    parser.add_argument(
        "--duration",
        type=_args.seconds(),
        default=None,
        help="stop after this many seconds (default: until Ctrl-C)",
    )


class Buttons:
    """The buttons to show: held now, or pressed since the previous line."""

    def __init__(self) -> None:
        self.held: set[tuple[str, int]] = set()
        self.tapped: set[tuple[str, int]] = set()

    def observe(self, events: list[Event]) -> None:
        for e in events:
            if e.kind is Kind.BUTTON:
                key = (e.device, e.index)
                if e.value > 0:
                    self.held.add(key)
                    self.tapped.add(key)
                else:
                    self.held.discard(key)

    def take(self, mapper: Mapper) -> list[dict]:
        """The buttons for one line (1-based, as on the hardware); forgets the taps."""
        shown = sorted(self.held | self.tapped)
        self.tapped.clear()
        return [
            {
                "device": d,
                "button": i + 1,
                "held": (d, i) in self.held,
                "does": mapper.button_role(d, i),
            }
            for d, i in shown
        ]


def snapshot(
    view: ViewState, devices: DeviceSet, mapper: Mapper, now: float, buttons: Sequence[dict] = ()
) -> dict:
    idle = mapper.activity.idle_for(now)
    return {
        "angles_deg": [round(math.degrees(a), 3) for a in view.angles],
        "sensor_r": round(view.sensor_r, 6),
        "sensor_distance": None if view.sensor_r == 0 else round(view.sensor_distance, 4),
        "buttons": list(buttons),
        "idle_s": None if math.isinf(idle) else round(idle, 2),
        "devices": {s["name"]: s["state"] for s in devices.statuses()},
        "details": {s["name"]: s["detail"] for s in devices.statuses()},
    }


def device_changes(s: dict, seen: dict) -> list[str]:
    """A line per device whose state or detail changed since the last call (``seen`` keeps
    them): what an installer watches while plugging things in."""
    lines = []
    for name, state in s["devices"].items():
        now = (state, s["details"].get(name, ""))
        if seen.get(name) != now:
            seen[name] = now
            lines.append(f"device {name}: {state}" + (f" ({now[1]})" if now[1] else ""))
    return lines


def text_line(s: dict) -> str:
    angles = " ".join(f"θ{i + 1} {a:+7.1f}°" for i, a in enumerate(s["angles_deg"]))
    d = "inf" if s["sensor_distance"] is None else f"{s['sensor_distance']:.2f}"
    devs = ", ".join(f"{k} {v}" for k, v in s["devices"].items())
    idle = "never touched" if s["idle_s"] is None else f"idle {s['idle_s']:.1f} s"
    pressed = ", ".join(
        f"{b['device']} button {b['button']} ({b['does']}{', held' if b['held'] else ''})"
        for b in s["buttons"]
    )
    return f"{angles}  sensor d={d} (r={s['sensor_r']:.3f})  | {devs} | {idle}" + (
        f" | {pressed}" if pressed else ""
    )


def run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    mapper = Mapper(config.mapping, ActivityDetector(config.activity_threshold))
    view = ViewState()
    buttons = Buttons()
    seen: dict = {}
    with DeviceSet(config) as devices:
        start = next_print = time.monotonic()
        while True:
            now = time.monotonic()
            events = devices.poll()
            buttons.observe(events)
            view = mapper.apply(view, events, now)
            if now >= next_print:
                s = snapshot(view, devices, mapper, now, buttons.take(mapper))
                if not args.json:
                    for line in device_changes(s, seen):
                        print(line, flush=True)
                print(json.dumps(s) if args.json else text_line(s), flush=True)
                next_print += 1.0 / args.rate
            if args.duration is not None and now - start >= args.duration:
                break
            time.sleep(0.005)
    return 0
