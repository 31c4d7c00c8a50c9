"""The URL factory: one string in a config picks the backend, as pyserial's ``serial_for_url``
picks ``loop://`` or ``socket://``. The same tests and the same kiosk then run on a simulated,
recorded or real device by changing only the URL.

==========================================  ================================================
``serial:///dev/serial/by-id/...?baud=N``   the 6-axis controller (baud defaults to 115200)
``hid://VID:PID[/SERIAL][?layout=NAME]``    HID device through hidapi's libusb backend
                                            (the only way to the Griffin PowerMate)
``hidraw://VID:PID[/SERIAL][?layout=NAME]`` HID device through hidraw (not exclusive; vendor
``hidraw:///dev/hidrawN[?layout=NAME]``     usage pages visible); VID:PID survives a replug,
                                            /dev/hidrawN may not
``sim://controller[?script=FILE]``          simulated controller on a pty (the real protocol)
``sim://controller?firmware=ELF``           the controller firmware itself, in simavr, on a pty
``sim://LAYOUT[?script=FILE]``              scripted fake HID device with that layout
``replay://FILE[?speed=X&loop=1]``          a recorded session (``exhibit record``)
``keyboard://``                             keys and mouse, fed by whoever owns the window
==========================================  ================================================
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass

from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from exhibit.devices.base import Backend, Clock, DeviceError
from exhibit.errors import ConfigError
from exhibit.schema import read_text

__all__ = ["backend_for_url", "parse_url", "SCHEMES"]


def parse_url(url: str) -> tuple[str, str, dict[str, str]]:
    """(scheme, target, query) of a device URL; DeviceError says what is wrong with it."""
    if not isinstance(url, str) or "://" not in url:
        raise DeviceError(
            f"device URL {url!r} needs a scheme: one of " + ", ".join(f"{s}://" for s in SCHEMES)
        )
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in SCHEMES:
        raise DeviceError(
            f"device URL {url!r}: unknown scheme {scheme!r} (one of "
            + ", ".join(f"{s}://" for s in SCHEMES)
            + ")"
        )
    target = parts.netloc + parts.path
    query: dict[str, str] = {}
    for key, values in parse_qs(parts.query, keep_blank_values=True).items():
        if key not in SCHEMES[scheme]:
            allowed = ", ".join(sorted(SCHEMES[scheme])) or "none"
            raise DeviceError(f"device URL {url!r}: unknown option {key!r} (allowed: {allowed})")
        if len(values) != 1:
            raise DeviceError(f"device URL {url!r}: option {key!r} given {len(values)} times")
        query[key] = values[0]
    if parts.fragment:
        raise DeviceError(f"device URL {url!r}: unexpected '#{parts.fragment}'")
    return scheme, target, query


def _number(url: str, key: str, value: str, kind, low, high):
    """A URL option's number in (low, high]: finite, so no option can stall or flood a loop."""
    try:
        n = kind(value)
    except (ValueError, OverflowError):
        raise DeviceError(f"device URL {url!r}: option {key}={value!r} is not a number") from None
    if not low < n <= high:  # NaN fails too
        raise DeviceError(
            f"device URL {url!r}: option {key} must lie in ({low:g}, {high:g}], got {value!r}"
        )
    return n


def backend_for_url(
    url: str,
    name: str | None = None,
    *,
    clock: Clock = time.monotonic,
    layout_dirs: Iterable[str | Path] | None = None,
    hid_api: object | None = None,
) -> Backend:
    """A backend for ``url``, not yet opened. ``name`` tags its events (default: the scheme).
    ``layout_dirs`` overrides where HID layouts are looked up; ``hid_api`` replaces the hidapi
    module (tests pass a fake bus)."""
    scheme, target, query = parse_url(url)
    where = _Where(url, target, query, name or scheme, clock, layout_dirs, hid_api, scheme)
    b = _SCHEMES[scheme][1](where)
    b.url = url
    return b


@dataclass(frozen=True)
class _Where:
    """What a scheme's builder needs: the URL and its parts, and the caller's options."""

    url: str
    target: str
    query: dict[str, str]
    name: str
    clock: Clock
    layout_dirs: Iterable[str | Path] | None
    hid_api: object | None
    scheme: str


def _serial(w: _Where) -> Backend:
    from exhibit.devices.controller import SerialController

    if not w.target:
        raise DeviceError(f"device URL {w.url!r}: no port path (serial:///dev/ttyUSB0)")
    baud = _number(w.url, "baud", w.query.get("baud", "115200"), int, 0, 4_000_000)
    return SerialController(name=w.name, clock=w.clock, path=w.target, baud=baud)


def _hid(w: _Where) -> Backend:
    from exhibit.devices.hid import HidBackend, find_layout, load_layouts, parse_vid_pid

    layouts = load_layouts(w.layout_dirs)
    if w.target.startswith("/"):
        if w.scheme == "hid":
            raise DeviceError(
                f"device URL {w.url!r}: hid:// takes VID:PID; use "
                f"hidraw://{w.target} for a /dev/hidraw path"
            )
        vid = pid = serial = None
        path: str | None = w.target
    else:
        vid, pid, serial = parse_vid_pid(w.target, w.url)
        path = None
    layout = find_layout(layouts, w.query.get("layout"), vid, pid, w.url)
    return HidBackend(
        name=w.name,
        clock=w.clock,
        layout=layout,
        backend=w.scheme,
        vid=vid,
        pid=pid,
        serial=serial,
        path=path,
        api=w.hid_api,
    )


def _sim(w: _Where) -> Backend:
    return _sim_backend(w.url, w.target, w.query, w.name, w.clock, w.layout_dirs)


def _replay(w: _Where) -> Backend:
    from exhibit.devices.replay import ReplayBackend

    if not w.target:
        raise DeviceError(f"device URL {w.url!r}: no file (replay://session.jsonl)")
    speed = _number(w.url, "speed", w.query.get("speed", "1"), float, 0, 1000)
    loop = w.query.get("loop", "0") not in ("0", "false", "no", "")
    return ReplayBackend(name=w.name, clock=w.clock, file=Path(w.target), speed=speed, loop=loop)


def _keyboard(w: _Where) -> Backend:
    from exhibit.devices.keyboard import KeyboardBackend

    if w.target:
        raise DeviceError(f"device URL {w.url!r}: keyboard:// takes no path")
    return KeyboardBackend(name=w.name, clock=w.clock)


def _sim_backend(url, target, query, name, clock, layout_dirs) -> Backend:
    script = None
    if "script" in query:
        path = Path(query["script"])
        try:
            text = read_text(path)
        except ConfigError as exc:
            raise DeviceError(f"device URL {url!r}: script {exc}") from None
    seed = _number(url, "seed", query["seed"], int, -1, 2**32 - 1) if "seed" in query else None
    if target == "controller":
        from exhibit.devices.sim import parse_script
        from exhibit.devices.simbackends import SimulatedController

        if "script" in query:
            script = parse_script(text, str(path))
        if "firmware" in query:
            from exhibit.devices.simavr import check_elf, find_harness
            from exhibit.devices.simbackends import SimulatedFirmware

            try:
                find_harness(check_elf(Path(query["firmware"])))
            except DeviceError as exc:
                raise DeviceError(f"device URL {url!r}: {exc}") from None
            return SimulatedFirmware(
                name=name, clock=clock, firmware=query["firmware"], script=script, seed=seed
            )
        return SimulatedController(name=name, clock=clock, script=script, seed=seed)
    from exhibit.devices.hid import find_layout, load_layouts
    from exhibit.devices.simbackends import simulated_hid

    if "firmware" in query:
        raise DeviceError(
            f"device URL {url!r}: firmware= runs the controller firmware: "
            "sim://controller?firmware=ELF"
        )
    layouts = load_layouts(layout_dirs)
    if target not in layouts:
        raise DeviceError(
            f"device URL {url!r}: no simulated device {target!r} (controller or "
            f"a layout: {', '.join(sorted(layouts))})"
        )
    layout = find_layout(layouts, target, None, None, url)
    hid_script = None
    if "script" in query:
        from exhibit.devices.fakehid import parse_hid_script

        hid_script = parse_hid_script(text, str(path), layout)
    return simulated_hid(name=name, clock=clock, layout=layout, script=hid_script, seed=seed)


#: Each scheme once: the query keys it accepts, and how its backend is built.
_SCHEMES = {
    "serial": ({"baud"}, _serial),
    "hid": ({"layout"}, _hid),
    "hidraw": ({"layout"}, _hid),
    "sim": ({"script", "seed", "firmware"}, _sim),
    "replay": ({"speed", "loop"}, _replay),
    "keyboard": (set(), _keyboard),
}
#: scheme -> the query keys it accepts
SCHEMES = {scheme: keys for scheme, (keys, _) in _SCHEMES.items()}
