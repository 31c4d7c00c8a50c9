"""Fake HID devices with the methods of hidapi's ``hid.device``, for tests and ``sim://``.

A :class:`FakeHidBus` stands in for the ``hid``/``hidraw`` module (``enumerate()``,
``device()``); each :class:`FakeHidDevice` on it hands out the report bytes a real device would,
from a queue or a script, and raises OSError from ``read`` once unplugged, as hidapi does. The
bus counts open handles, so tests can prove that unplug cycles leak nothing.

Script lines (``sim://knobbox?script=FILE``)::

    turn 3 -2          # knob/delta channel 3 (1-based) two steps back
    press 1            # button 1 (1-based) down; release 1 lets go
    axes 0 0 0.5 0 0 0 # axis deflections in [-1, 1] (layouts with axes)
    report 01 00 ...   # raw report bytes in hex
    wait 0.25
    unplug 1.0         # gone for a second, then back
    repeat
"""

from __future__ import annotations

import itertools
import random
import time
from collections import deque
from collections.abc import Iterable

from exhibit.devices.base import Clock, DeviceError, Kind

from exhibit.devices.hid import Layout
from exhibit.devices.sim import script_lines

__all__ = ["FakeHidDevice", "FakeHidBus", "encode_report", "parse_hid_script"]

_paths = itertools.count(1)


def encode_report(
    layout: Layout,
    deltas: dict[int, int] | None = None,
    axes: dict[int, float] | None = None,
    buttons: int = 0,
) -> bytes:
    """The report bytes the device would send for these values: the smallest report of the
    layout whose fields carry every channel given (button bits go wherever a buttons field is)."""
    deltas, axes = deltas or {}, axes or {}
    want = {(Kind.REL, i) for i in deltas} | {(Kind.ABS, i) for i in axes}
    for report in sorted(layout.reports, key=lambda r: r.size):
        have = {(f.kind, f.index + j) for f in report.fields for j in range(f.count)}
        if not want <= have or (not want and not any(f.kind is Kind.BUTTON for f in report.fields)):
            continue
        data = bytearray(report.size)
        if report.id is not None:
            data[0] = report.id
        for f in report.fields:
            chans = range(f.index, f.index + f.count)
            if f.kind is Kind.REL:
                vals = [max(-127, min(127, deltas.get(c, 0))) for c in chans]
            elif f.kind is Kind.ABS:
                vals = [int(round(axes.get(c, 0.0) * f.scale)) for c in chans]
            else:
                vals = [(buttons >> c) & 1 for c in chans]
            f.pack(vals, data)
        return bytes(data)
    raise ValueError(f"layout {layout.name} has no report carrying {sorted(want)}")


class FakeHidDevice:
    """One simulated HID device: what is plugged in, its reports, and its script."""

    def __init__(
        self,
        vid: int,
        pid: int,
        *,
        product: str = "Fake HID",
        serial: str = "",
        usage_page: int = 0,
        script: list[tuple] | None = None,
        clock: Clock = time.monotonic,
        seed: int | None = None,
        layout: Layout | None = None,
    ) -> None:
        self.vid, self.pid, self.product, self.serial = vid, pid, product, serial
        self.usage_page = usage_page
        self.path = f"fake-hid-{next(_paths)}".encode()
        self.plugged = True
        self.generation = 0  # bumped on every unplug: handles from before go stale
        self.reports: deque[bytes] = deque()
        self.clock = clock
        self.rng = random.Random(seed)
        self.layout = layout
        self.script = script or []
        self._index = 0
        self._resume_at = 0.0
        self._replug_at: float | None = None
        self.buttons = 0

    @property
    def _layout(self) -> Layout:
        """The layout a script's turn, press and axes are encoded in (parse_hid_script parsed
        them against it, so a script that has them has one)."""
        assert self.layout is not None
        return self.layout

    def push(self, *reports: bytes) -> None:
        self.reports.extend(bytes(r) for r in reports)

    def unplug(self) -> None:
        self.plugged = False
        self.generation += 1
        self.reports.clear()

    def plug(self) -> None:
        self.plugged = True

    def advance(self, now: float) -> None:
        """Plays the script up to ``now``."""
        if self._replug_at is not None:
            if now < self._replug_at:
                return
            self._replug_at = None
            self.plug()
        budget = 1000
        while self.script and now >= self._resume_at and self._index < len(self.script) and budget:
            budget -= 1
            cmd, args = self.script[self._index]
            if cmd == "unplug" and self.reports:
                return  # reports sent before the cable was pulled reach the host first
            self._index += 1
            if cmd == "report":
                self.push(args)
            elif cmd == "turn":
                self.push(
                    encode_report(self._layout, deltas={args[0]: args[1]}, buttons=self.buttons)
                )
            elif cmd in ("press", "release"):
                bit = 1 << args
                self.buttons = self.buttons | bit if cmd == "press" else self.buttons & ~bit
                self.push(encode_report(self._layout, buttons=self.buttons))
            elif cmd == "axes":
                self.push(encode_report(self._layout, axes=dict(enumerate(args))))
            elif cmd == "wait":
                self._resume_at = now + args
            elif cmd == "unplug":
                self.unplug()
                self._replug_at = self._resume_at = now + args
                return
            elif cmd == "repeat":
                self._index = 0

    def info(self) -> dict:
        return {
            "path": self.path,
            "vendor_id": self.vid,
            "product_id": self.pid,
            "serial_number": self.serial,
            "release_number": 0x100,
            "manufacturer_string": "Exhibit test",
            "product_string": self.product,
            "usage_page": self.usage_page,
            "usage": 1,
            "interface_number": 0,
        }


class _Handle:
    """What ``hid.device()`` returns: opened on one fake device."""

    def __init__(self, bus: FakeHidBus):
        self._bus = bus
        self._dev: FakeHidDevice | None = None
        self._generation = -1

    def open_path(self, path: bytes) -> None:
        dev = next((d for d in self._bus.devices if d.path == path and d.plugged), None)
        if dev is None:
            raise OSError("open failed")
        self._dev, self._generation = dev, dev.generation
        self._bus.open_handles += 1

    def open(self, vendor_id=0, product_id=0, serial_number=None) -> None:
        for d in self._bus.enumerate(vendor_id, product_id):
            if serial_number in (None, d["serial_number"]):
                return self.open_path(d["path"])
        raise OSError("open failed")

    def set_nonblocking(self, v) -> int:
        return 0

    def read(self, max_length: int, timeout_ms: int = 0) -> list[int]:
        dev = self._dev
        if dev is None:
            raise ValueError("not open")
        dev.advance(dev.clock())
        if not dev.plugged or dev.generation != self._generation:
            raise OSError("read error")
        if not dev.reports:
            return []
        return list(dev.reports.popleft()[:max_length])

    def get_product_string(self) -> str:
        if self._dev is None:
            raise ValueError("not open")
        return self._dev.product

    def close(self) -> None:
        if self._dev is not None:
            self._dev = None
            self._bus.open_handles -= 1


class FakeHidBus:
    """The ``hid``/``hidraw`` module of a machine with these fake devices plugged in."""

    def __init__(self, devices: Iterable[FakeHidDevice] = ()):
        self.devices: list[FakeHidDevice] = list(devices)
        self.open_handles = 0

    def enumerate(self, vendor_id: int = 0, product_id: int = 0) -> list[dict]:
        for d in self.devices:
            d.advance(d.clock())  # a scripted replug happens while nobody has it open
        return [
            d.info()
            for d in self.devices
            if d.plugged and vendor_id in (0, d.vid) and product_id in (0, d.pid)
        ]

    def device(self) -> _Handle:
        return _Handle(self)


def parse_hid_script(text: str, source: str, layout: Layout) -> list[tuple]:
    """Parses a fake HID script for ``layout``; DeviceError names the file and line."""
    caps = layout.capabilities
    out: list[tuple] = []
    for _, where, cmd, rest, words in script_lines(text, source):
        try:
            if cmd == "report":
                data = bytes.fromhex("".join(rest))
                if layout.report_for(data) is None:
                    raise DeviceError(f"{where}: {data.hex()} is no report of layout {layout.name}")
                out.append((cmd, data))
            elif cmd == "turn":
                ch, steps = int(rest[0]), int(rest[1])
                if len(rest) != 2 or not 1 <= ch <= caps.deltas or not -127 <= steps <= 127:
                    raise DeviceError(
                        f"{where}: turn CHANNEL STEPS with channel 1..{caps.deltas}"
                        " and steps -127..127"
                    )
                out.append((cmd, (ch - 1, steps)))
            elif cmd in ("press", "release"):
                b = int(rest[0])
                if len(rest) != 1 or not 1 <= b <= caps.buttons:
                    raise DeviceError(f"{where}: {cmd} BUTTON with button 1..{caps.buttons}")
                out.append((cmd, b - 1))
            elif cmd == "axes":
                vals = tuple(float(w) for w in rest)
                if len(vals) != caps.axes or not all(-1 <= v <= 1 for v in vals):
                    raise DeviceError(f"{where}: axes needs {caps.axes} deflections in [-1, 1]")
                out.append((cmd, vals))
            elif cmd in ("wait", "unplug"):
                v = float(rest[0])
                if len(rest) != 1 or not 0 <= v < 1e6:
                    raise DeviceError(f"{where}: {cmd} SECONDS")
                out.append((cmd, v))
            elif cmd == "repeat":
                if rest:
                    raise DeviceError(f"{where}: repeat takes nothing")
                out.append((cmd, None))
            else:
                raise DeviceError(
                    f"{where}: unknown command {words[0]!r} (report, turn, press, "
                    "release, axes, wait, unplug, repeat)"
                )
        except (ValueError, IndexError):
            raise DeviceError(f"{where}: bad arguments {' '.join(rest)!r} for {cmd}") from None
    return out
