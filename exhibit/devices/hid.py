"""HID input devices through hidapi: the knob box, the Griffin PowerMate, SpaceMice, and any
other device a museum describes with a layout file.

A *layout* (configs/devices/*.toml with a ``[layout]`` table) is data: which VID:PIDs it fits,
which hidapi backend reaches it, and where each value sits in each input report. Reports are
told apart by their report id (first byte, when the device uses ids) and their length, so a
SpaceMouse's split reports (1 = translation, 2 = rotation, 3 = buttons) and the newer combined
six-axis report 1 live in one layout.

hidapi on Linux has two backends that cannot open each other's paths: ``hid`` (libusb: claims
the interface, sees real USB only, usage pages read 0; the only way to the PowerMate, which the
kernel hides from hidraw) and ``hidraw`` (/dev/hidrawN: not exclusive, usage pages visible). The
URL scheme picks one; a layout names the one its device needs. Unplug shows as OSError from
``read``: the device is closed and looked for again every ``retry_s`` (the binding has no
hotplug callbacks).

Why one module of this size: the HID layout files and the backend that decodes reports with
them."""

from __future__ import annotations

import importlib
import struct
from collections.abc import Iterable
from dataclasses import dataclass

from pathlib import Path
from typing import Annotated, Any, Literal, get_args

from pydantic import Field as PydanticField

from exhibit.devices.base import Capabilities, DeviceConfigError, DeviceError, Event, Kind, State
from exhibit.devices.reconnect import ReconnectingBackend
from exhibit.errors import ConfigError
from exhibit.resources import shipped
from exhibit.schema import Model, read_toml, validate
from exhibit.schema.types import Integer, Name, Number, Text
import contextlib

__all__ = [
    "Field",
    "Report",
    "Layout",
    "load_layouts",
    "load_layout",
    "find_layout",
    "HidBackend",
    "LAYOUT_DIR",
]

LAYOUT_DIR = shipped("configs", "devices")

#: The names a layout file gives a field's kind and value type (written out, since a type
#: checker reads no expression in a Literal; the asserts keep them and the tables in step).
_KindName = Literal["axis", "delta", "buttons"]
_TypeName = Literal["i8", "u8", "i16", "u16", "i16be", "u16be", "bits"]
_KINDS: dict[str, Kind] = {"axis": Kind.ABS, "delta": Kind.REL, "buttons": Kind.BUTTON}
_TYPES = {"i8": "b", "u8": "B", "i16": "<h", "u16": "<H", "i16be": ">h", "u16be": ">H"}
assert get_args(_KindName) == tuple(_KINDS)
assert get_args(_TypeName) == tuple(_TYPES) + ("bits",)


@dataclass(frozen=True)
class Field:
    """``count`` values of ``type`` from byte ``offset`` (buttons: ``count`` bits, LSB first),
    channels ``index`` .. ``index + count - 1``; an axis reads ``scale`` at full deflection."""

    kind: Kind
    offset: int
    type: str = "i8"
    count: int = 1
    index: int = 0
    scale: float = 1.0

    @property
    def end(self) -> int:
        if self.kind is Kind.BUTTON:
            return self.offset + (self.count + 7) // 8
        return self.offset + self.count * struct.calcsize(_TYPES[self.type])

    def values(self, data: bytes) -> list[int]:
        if self.kind is Kind.BUTTON:
            bits = int.from_bytes(data[self.offset : self.end], "little")
            return [(bits >> i) & 1 for i in range(self.count)]
        fmt = _TYPES[self.type]
        order = fmt[0] if fmt[0] in "<>" else ""
        return list(struct.unpack_from(order + fmt[-1] * self.count, data, self.offset))

    def pack(self, values: list[int], into: bytearray) -> None:
        if self.kind is Kind.BUTTON:
            bits = sum((1 << i) for i, v in enumerate(values) if v)
            into[self.offset : self.end] = bits.to_bytes(self.end - self.offset, "little")
            return
        fmt = _TYPES[self.type]
        order = fmt[0] if fmt[0] in "<>" else ""
        struct.pack_into(order + fmt[-1] * self.count, into, self.offset, *values)


@dataclass(frozen=True)
class Report:
    """An input report: ``id`` is its first byte (None: the device uses no report ids);
    ``size`` the least length, id included, that carries every field."""

    id: int | None
    size: int
    fields: tuple[Field, ...]


@dataclass(frozen=True)
class Layout:
    name: str
    description: str
    match: tuple[tuple[int, int], ...]
    backend: str
    usage_page: int | None
    reports: tuple[Report, ...]
    source: str = ""

    @property
    def capabilities(self) -> Capabilities:
        n = {k: 0 for k in Kind}
        for r in self.reports:
            for f in r.fields:
                n[f.kind] = max(n[f.kind], f.index + f.count)
        return Capabilities(axes=n[Kind.ABS], deltas=n[Kind.REL], buttons=n[Kind.BUTTON])

    def report_for(self, data: bytes) -> Report | None:
        """The longest report description this report fits (ids first, then length)."""
        best = None
        for r in self.reports:
            if r.id is not None and (not data or data[0] != r.id):
                continue
            if len(data) >= r.size and (best is None or r.size > best.size):
                best = r
        return best


# ---- loading -------------------------------------------------------------------------------


_Offset = Annotated[int, Integer(0, 1023)]


class FieldSpec(Model):
    kind: _KindName
    offset: _Offset
    type: _TypeName | None = None
    count: Annotated[int, Integer(1, 64)] = 1
    index: Annotated[int, Integer(0, 255)] = 0
    scale: Annotated[float, Number(1e-6, 1e6)] = 1.0


class ReportSpec(Model):
    id: Annotated[int, Integer(1, 255)] | None = None
    size: Annotated[int, Integer(1, 1024)] | None = None
    fields: Annotated[list[FieldSpec], PydanticField(min_length=1)]


class LayoutHead(Model):
    name: Name
    description: Annotated[str, Text(500, empty_ok=True)] = ""
    match: list[Annotated[str, Text(40)]] = []
    backend: Literal["hid", "hidraw"] = "hidraw"
    usage_page: Annotated[int, Integer(0, 0xFFFF)] | None = None


class LayoutFile(Model):
    layout: LayoutHead
    report: Annotated[list[ReportSpec], PydanticField(min_length=1)]


def parse_vid_pid(text: str, url: str = "") -> tuple[int, int, str | None]:
    """``VID:PID[/SERIAL]`` in hex -> (vid, pid, serial or None)."""
    ids, _, serial = text.partition("/")
    vid, sep, pid = ids.partition(":")
    try:
        if not sep:
            raise ValueError
        v, p = int(vid, 16), int(pid, 16)
        if not (0 <= v <= 0xFFFF and 0 <= p <= 0xFFFF) or len(vid) > 4 or len(pid) > 4:
            raise ValueError
    except ValueError:
        raise DeviceError(
            f"device URL {url or text!r}: expected VID:PID in hex (e.g. 2341:8037), got {ids!r}"
        ) from None
    return v, p, serial or None


def parse_layout(doc: dict, source: str) -> Layout:
    """A Layout from a parsed TOML document; DeviceError names the file and every bad key."""
    try:
        spec = validate(LayoutFile, doc, source)
    except ConfigError as exc:
        raise DeviceConfigError(exc.problems) from None
    problems: list[str] = []
    match = []
    for i, text in enumerate(spec.layout.match):
        try:
            vid, pid, _ = parse_vid_pid(text)
            match.append((vid, pid))
        except DeviceError:
            problems.append(f'{source}: layout.match[{i}]: expected "VID:PID" in hex, got {text!r}')
    reports = []
    for ri, rep in enumerate(spec.report):
        rw = f"{source}: report[{ri}]"
        first = 1 if rep.id is not None else 0
        fields = []
        for fi, fd in enumerate(rep.fields):
            fw = f"{rw}.fields[{fi}]"
            ftype = fd.type or ("bits" if fd.kind == "buttons" else "i8")
            if (fd.kind == "buttons") != (ftype == "bits"):
                problems.append(f"{fw}.type: buttons are bits and only buttons are, got {ftype!r}")
                continue
            if fd.offset < first:
                problems.append(f"{fw}.offset: {fd.offset} overlaps the report id byte")
                continue
            fields.append(Field(_KINDS[fd.kind], fd.offset, ftype, fd.count, fd.index, fd.scale))
        end = max((f.end for f in fields), default=0)
        size = rep.size if rep.size is not None else end
        if size < end:
            problems.append(f"{rw}.size: {size} is shorter than its fields ({end} bytes)")
        reports.append(Report(rep.id, max(size, end), tuple(fields)))
    if problems:
        raise DeviceConfigError(problems)
    head = spec.layout
    return Layout(
        head.name,
        head.description,
        tuple(match),
        head.backend,
        head.usage_page,
        tuple(reports),
        source,
    )


def _read(path: Path) -> dict:

    try:
        return read_toml(path)
    except ConfigError as exc:
        raise DeviceConfigError(exc.problems) from None


def load_layout(path: Path) -> Layout:
    return parse_layout(_read(path), str(path))


def load_layouts(dirs: Iterable[str | Path] | None = None) -> dict[str, Layout]:
    """Every layout file (a TOML file with a [layout] table) in ``dirs`` (default
    configs/devices), by name; a later directory overrides an earlier one."""
    layouts: dict[str, Layout] = {}
    for d in [LAYOUT_DIR] if dirs is None else [Path(x) for x in dirs]:
        try:
            paths = sorted(Path(d).glob("*.toml"))
        except OSError as exc:
            raise DeviceError(f"{d}: cannot list layouts: {exc.strerror or exc}") from None
        for path in paths:
            doc = _read(path)
            if "layout" in doc:
                layout = parse_layout(doc, str(path))
                layouts[layout.name] = layout
    return layouts


def find_layout(
    layouts: dict[str, Layout], name: str | None, vid: int | None, pid: int | None, url: str
) -> Layout:
    if name is not None:
        if name not in layouts:
            raise DeviceError(
                f"device URL {url!r}: no layout {name!r} (known: "
                f"{', '.join(sorted(layouts)) or 'none'})"
            )
        return layouts[name]
    for layout in layouts.values():
        if (vid, pid) in layout.match:
            return layout
    if vid is None:
        raise DeviceError(
            f"device URL {url!r}: say which layout (?layout=NAME; known: "
            f"{', '.join(sorted(layouts)) or 'none'})"
        )
    raise DeviceError(
        f"device URL {url!r}: no layout matches {vid:04x}:{pid:04x}; add one to "
        f'configs/devices with match = ["{vid:04x}:{pid:04x}"] (docs/DEVICES.md)'
    )


# ---- the backend ---------------------------------------------------------------------------


@dataclass
class HidBackend(ReconnectingBackend):
    """``hid://VID:PID[/SERIAL]``, ``hidraw://VID:PID[/SERIAL]`` or ``hidraw:///dev/hidrawN``."""

    layout: Layout | None = None
    backend: str = "hidraw"
    vid: int | None = None
    pid: int | None = None
    serial: str | None = None
    path: str | None = None
    api: Any = None
    max_reports: int = 64

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.layout is None:
            raise DeviceError("a HID backend needs a layout")
        self.capabilities = self.layout.capabilities
        self.reports_ok = self.reports_unknown = 0
        self._dev: Any | None = None  # a hidapi device (hidapi has no type information)

    @property
    def _layout(self) -> Layout:
        """The layout, which __post_init__ made sure of."""
        assert self.layout is not None
        return self.layout

    @property
    def target(self) -> str:
        if self.path:
            return self.path
        s = f"{self.vid:04x}:{self.pid:04x}"
        return f"{s}/{self.serial}" if self.serial else s

    def _hidapi(self):
        if self.api is None:
            try:
                self.api = importlib.import_module("hid" if self.backend == "hid" else "hidraw")
            except ImportError as exc:
                raise DeviceError(
                    f"hidapi's {self.backend} backend is missing ({exc}); "
                    "pip install 'hidapi>=0.14'"
                ) from None
        return self.api

    def _open(self) -> None:
        self._hidapi()
        super()._open()

    # ---- the handle (ReconnectingBackend does the retries, the loss and the release)

    def _connected(self) -> bool:
        return self._dev is not None

    def _disconnect(self) -> None:
        dev, self._dev = self._dev, None
        if dev is not None:
            with contextlib.suppress(OSError, ValueError):
                dev.close()

    def _candidates(self) -> list[bytes]:
        api = self.api
        if self.path:
            return [self.path.encode()]
        try:
            found = api.enumerate(self.vid, self.pid)
        except (OSError, ValueError):
            return []
        if self.serial:
            found = [d for d in found if d.get("serial_number") == self.serial]
        usage_page = self._layout.usage_page
        if usage_page and self.backend == "hidraw":
            # hidraw shows each top-level collection; pick the layout's (libusb reads 0 here)
            best = [d for d in found if d.get("usage_page") == usage_page]
            found = best or found
        return [d["path"] for d in found]

    def _connect(self, now: float) -> str | None:
        paths = self._candidates()
        if not paths:
            return f"waiting for {self.target} ({self.backend}): not connected"
        dev = self.api.device()
        try:
            dev.open_path(paths[0])
            dev.set_nonblocking(1)
        except (OSError, ValueError) as exc:
            with contextlib.suppress(OSError, ValueError):
                dev.close()
            return (
                f"cannot open {self.target} ({self.backend}): {exc}; check the udev "
                "rule's permissions (docs/DEVICES.md)"
            )
        self._dev = dev
        self.state = State.CONNECTED
        name = self._layout.name
        try:
            product = dev.get_product_string() or name
        except (OSError, ValueError):
            product = name
        self.detail = f"{product} ({name} layout, {self.backend})"
        return None

    def _read(self, now: float) -> None:
        dev = self._dev
        assert dev is not None  # ReconnectingBackend reads only while connected
        for _ in range(self.max_reports):  # bounded work per poll, even for a flooding device
            try:
                data = dev.read(64)
            except (OSError, ValueError) as exc:
                self._lost(now, f"{self.target} unplugged ({exc or 'read error'}); looking for it")
                break
            if not data:
                break
            self._report(bytes(data), now)

    def _report(self, data: bytes, now: float) -> None:
        report = self._layout.report_for(data)
        if report is None:
            self.reports_unknown += 1
            return
        self.reports_ok += 1
        out = self._pending
        for f in report.fields:
            for i, raw in enumerate(f.values(data)):
                ch = f.index + i
                if f.kind is Kind.REL:
                    if raw:
                        out.append(Event(now, self.name, Kind.REL, ch, float(raw)))
                elif f.kind is Kind.ABS:
                    v = max(-1.0, min(1.0, raw / f.scale))
                    if self._axes.get(ch, 0.0) != v:
                        self._axes[ch] = v
                        out.append(Event(now, self.name, Kind.ABS, ch, v))
                else:
                    v = float(raw)
                    if self._buttons.get(ch, 0.0) != v:
                        self._buttons[ch] = v
                        out.append(Event(now, self.name, Kind.BUTTON, ch, v))

    def status(self, now: float | None = None) -> dict:
        d = super().status(now)
        d["link"] = {
            "reports_ok": self.reports_ok,
            "reports_unknown": self.reports_unknown,
            "reconnects": self.reconnects,
        }
        return d
