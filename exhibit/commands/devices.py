"""`exhibit devices`: the configured devices with their state, and what is plugged in.

Each configured device is opened and given ``--wait`` seconds for its handshake; then every
serial port (with its /dev/serial/by-id name) and every HID device seen by hidapi's two backends
is listed, with the layout that would read it. For installers: "is the board there, under which
name, and does the exhibit talk to it?"
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from exhibit.commands import _arg_types as _args
from exhibit.commands._device_options import add_config_arguments, config_from_args
from exhibit.devices.base import State
from exhibit.devices.hid import load_layouts
from exhibit.devices.hub import DeviceSet

HELP = "list configured devices with their state, and detected serial and HID devices"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    parser.add_argument("--json", action="store_true", help="one JSON document")
    parser.add_argument(
        "--wait",
        type=_args.number(0, 60),
        default=1.5,
        help="seconds to give each device to connect (default 1.5)",
    )


def detected_serial() -> list[dict]:
    try:
        from serial.tools import list_ports
    except ImportError:  # pragma: no cover - pyserial is a dependency
        return []
    by_id = {}
    d = Path("/dev/serial/by-id")
    if d.is_dir():
        for link in d.iterdir():
            by_id[os.path.realpath(link)] = str(link)
    return [
        {
            "path": by_id.get(os.path.realpath(port.device), port.device),
            "device": port.device,
            "vid_pid": f"{port.vid:04x}:{port.pid:04x}" if port.vid is not None else None,
            "description": port.description,
        }
        for port in list_ports.comports()
    ]


def detected_hid(layout_dirs: Iterable[str | Path] | None) -> list[dict]:
    layouts = load_layouts(layout_dirs)
    found: list[dict[str, Any]] = []  # one JSON object a device
    for backend in ("hid", "hidraw"):
        try:
            api = __import__(backend)
            entries = api.enumerate()
        except (ImportError, OSError) as exc:
            found.append({"backend": backend, "error": str(exc)})
            continue
        for e in entries:
            vp = (e.get("vendor_id", 0), e.get("product_id", 0))
            layout = next((lay.name for lay in layouts.values() if vp in lay.match), None)
            found.append(
                {
                    "backend": backend,
                    "vid_pid": f"{vp[0]:04x}:{vp[1]:04x}",
                    "path": e.get("path", b"").decode(errors="replace"),
                    "product": e.get("product_string") or "",
                    "serial": e.get("serial_number") or "",
                    "usage_page": e.get("usage_page", 0),
                    "layout": layout,
                    "url": f"{backend}://{vp[0]:04x}:{vp[1]:04x}",
                }
            )
    return found


def run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    with DeviceSet(config) as devices:
        end = time.monotonic() + args.wait
        while time.monotonic() < end:
            devices.poll()
            if all(b.state is State.CONNECTED for b in devices.backends):
                break
            time.sleep(0.01)
        configured = devices.statuses()
    report = {
        "configured": configured,
        "serial": detected_serial(),
        "hid": detected_hid(config.layout_dirs),
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"configured ({config.source}):")
    for s in configured:
        print(f"  {s['name']:<12} {s['state']:<12} {s['url']}")
        if s["detail"]:
            print(f"  {'':<12} {s['detail']}")
    print("serial ports:" if report["serial"] else "serial ports: none")
    for s in report["serial"]:
        print(f"  {s['path']}  {s['vid_pid'] or ''}  {s['description']}")
    hid = [h for h in report["hid"] if "error" not in h]
    print("HID devices:" if hid else "HID devices: none")
    for h in hid:
        layout = f"layout {h['layout']}" if h["layout"] else "no layout"
        print(
            f"  {h['url']:<24} {h['product'] or '?'}  ({layout}, usage page "
            f"0x{h['usage_page']:04x}, {h['path']})"
        )
    for h in report["hid"]:
        if "error" in h:
            print(f"  ({h['backend']}: {h['error']})")
    return 0
