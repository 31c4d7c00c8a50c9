"""The HID layouts (configs/devices/*.toml) against the devices' report descriptors, read by an
independent parser: hid-tools (``hidtools.hid.ReportDescriptor``), not our own code.

- The knob box: the descriptor the firmware sends (firmware/common/knob_report.h, found byte
  for byte in the AVR build) against the knobbox layout: report id, size, every value's bit
  position and width, signedness, logical range, relative flag and usage.
- Reports built by the firmware's own knob_report.c, compiled for the host, decoded by the host
  HID backend into events, and by hid-tools into values: the two agree, and the detents add up.
- The SpaceMouse layout against two published descriptors (the split-report SpaceNavigator, the
  combined-report SpaceMouse Wireless; sources in tests/firmware/descriptors/ and the layout).

Each check is also run on a descriptor or a layout changed alone, and must then fail.
"""

from __future__ import annotations

import ctypes
import dataclasses
import os
import random
from pathlib import Path

import pytest

from exhibit.devices.base import Kind
from exhibit.devices.fakehid import FakeHidBus, FakeHidDevice
from exhibit.devices.hid import HidBackend, Layout, load_layouts

from .conftest import u8

try:
    import hidtools.hid as hid
except ImportError:  # like a missing toolchain: skipped, except in CI, which installs the extras
    if os.environ.get("CI") == "true":
        raise
    pytest.skip("needs hid-tools: pip install -e '.[test]'", allow_module_level=True)

DESCRIPTORS = Path(__file__).resolve().parent / "descriptors"
GENERIC_DESKTOP, BUTTON_PAGE, VENDOR = 0x01, 0x09, 0xFF00
_SIGNED = {"i8": (-128, 127), "i16": (-32768, 32767), "i16be": (-32768, 32767),
           "u8": (0, 255), "u16": (0, 65535), "u16be": (0, 65535)}


def published(name: str) -> bytes:
    text = (DESCRIPTORS / name).read_text()
    return bytes.fromhex(" ".join(l for l in text.splitlines() if not l.startswith("#")))


def firmware_descriptor(fw) -> bytes:
    n = ctypes.c_size_t.in_dll(fw, "shim_hid_descriptor_len").value
    return bytes((ctypes.c_uint8 * n).in_dll(fw, "shim_hid_descriptor"))


def knob_usage(kind: Kind, channel: int) -> int:
    """Usages of the knob box (PROTOCOL.md, "Knob box"): vendor page, 2 = deltas, 3 = buttons."""
    return VENDOR << 16 | (2 if kind is Kind.REL else 3)


def spacemouse_usage(kind: Kind, channel: int) -> int:
    """Axis channels 0..5 are X Y Z Rx Ry Rz; button channel i is Button i+1."""
    if kind is Kind.ABS:
        return GENERIC_DESKTOP << 16 | (0x30 + channel)
    return BUTTON_PAGE << 16 | (channel + 1)


def layout_values(report):
    """(start bit, width, kind, channel, field) of every value a layout report reads."""
    out = []
    for f in report.fields:
        if f.kind is Kind.BUTTON:
            out += [((f.offset * 8) + i, 1, f.kind, f.index + i, f) for i in range(f.count)]
        else:
            width = 8 if f.type in ("i8", "u8") else 16
            out += [(f.offset * 8 + i * width, width, f.kind, f.index + i, f)
                    for i in range(f.count)]
    return out


def check(layout: Layout, rdesc: bytes, usage_of, *, covers, ignore=()) -> list[str]:
    """Problems between a layout and a report descriptor, as parsed by hid-tools. ``covers``:
    the (report id, size) of the layout's reports this device sends; ``ignore``: input report
    ids of the device the layout leaves alone on purpose (a battery level)."""
    parsed = hid.ReportDescriptor.from_bytes(list(rdesc))
    problems = []
    by_key = {(r.id, r.size): r for r in layout.reports}
    for rid, rep in sorted(parsed.input_reports.items()):
        if rid in ignore:
            continue
        key = (rid or None, rep.size)
        where = f"input report {rid} ({rep.size} bytes)"
        lr = by_key.get(key)
        if lr is None:
            problems.append(f"{where}: no layout report with id {rid} and size {rep.size}")
            continue
        values = {v[0]: v for v in layout_values(lr)}
        data_bits = set()
        for f in rep.fields:
            bits = set(range(f.start, f.start + f.size * max(f.count, 1)))
            if f.is_const:
                continue
            data_bits |= bits
            v = values.get(f.start)
            if v is None:
                problems.append(f"{where}: bit {f.start} ({f.usage:#x}) is read by no layout field")
                continue
            start, width, kind, channel, lf = v
            if width != f.size:
                problems.append(f"{where}: bit {start}: {f.size}-bit value, layout reads {width}")
            if kind is Kind.BUTTON:
                if (f.logical_min, f.logical_max) != (0, 1):
                    problems.append(f"{where}: button {channel}: range {f.logical_min}..{f.logical_max}")
            else:
                lo, hi = _SIGNED[lf.type]
                if not lo <= f.logical_min <= f.logical_max <= hi:
                    problems.append(f"{where}: bit {start}: range {f.logical_min}..{f.logical_max} "
                                    f"does not fit the layout's {lf.type}")
                if kind is Kind.REL and not f.type & 0x04:
                    problems.append(f"{where}: bit {start}: the layout's delta is absolute here")
                if kind is Kind.ABS and lf.scale != max(-f.logical_min, f.logical_max):
                    problems.append(f"{where}: bit {start}: scale {lf.scale:g}, logical range "
                                    f"{f.logical_min}..{f.logical_max}")
            if f.usage != usage_of(kind, channel):
                problems.append(f"{where}: bit {start}: usage {f.usage:#x}, layout's {kind.value} "
                                f"{channel} means {usage_of(kind, channel):#x}")
        for start, width, kind, channel, _ in values.values():
            if start + width > rep.size * 8:
                problems.append(f"{where}: layout {kind.value} {channel} lies past the report")
    for key in covers:
        if not any((rid or None, rep.size) == key for rid, rep in parsed.input_reports.items()):
            problems.append(f"layout report {key}: the device has no such input report")
    return problems


# ---- the knob box ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def layouts():
    return load_layouts()


def test_knob_box_descriptor_matches_its_layout(fw, layouts):
    layout = layouts["knobbox"]
    rdesc = firmware_descriptor(fw)
    assert check(layout, rdesc, knob_usage, covers=[(1, 9)]) == []
    parsed = hid.ReportDescriptor.from_bytes(list(rdesc))
    app = parsed.input_reports[1].fields[0].application
    assert (app >> 16, app & 0xFFFF) == (layout.usage_page, 1)  # vendor page, usage 1
    assert list(parsed.input_reports) == [1] and not parsed.output_reports


def test_the_avr_build_sends_that_descriptor(fw, avr_build):
    """The bytes checked above are the bytes in the knob box image (PROGMEM, in .text)."""
    assert firmware_descriptor(fw) in (avr_build / "knobbox" / "knobbox.elf").read_bytes()


@pytest.mark.parametrize("edit, complaint", [
    ((0x95, 0x07, 0x81, 0x06), (0x95, 0x06, 0x81, 0x06)),  # six deltas instead of seven
    ((0x15, 0x81, 0x25, 0x7F, 0x75, 0x08), (0x15, 0x81, 0x25, 0x7F, 0x75, 0x10)),  # 16-bit
    ((0x95, 0x07, 0x81, 0x06), (0x95, 0x07, 0x81, 0x02)),  # absolute deltas
    ((0x85, 0x01), (0x85, 0x02)),  # another report id
    ((0x09, 0x02, 0x15), (0x09, 0x05, 0x15)),  # another usage
])
def test_a_descriptor_changed_alone_fails_the_check(fw, layouts, edit, complaint):
    rdesc = firmware_descriptor(fw)
    changed = rdesc.replace(bytes(edit), bytes(complaint), 1)
    assert changed != rdesc
    assert check(layouts["knobbox"], changed, knob_usage, covers=[(1, 9)]) != []


@pytest.mark.parametrize("change", [
    lambda f: dataclasses.replace(f, offset=f.offset + 1) if f.kind is Kind.BUTTON else f,
    lambda f: dataclasses.replace(f, type="i16") if f.kind is Kind.REL else f,
    lambda f: dataclasses.replace(f, count=6) if f.kind is Kind.REL else f,
    lambda f: dataclasses.replace(f, kind=Kind.ABS, scale=127) if f.kind is Kind.REL else f,
])
def test_a_layout_changed_alone_fails_the_check(fw, layouts, change):
    layout = layouts["knobbox"]
    reports = tuple(dataclasses.replace(r, fields=tuple(change(f) for f in r.fields))
                    for r in layout.reports)
    changed = dataclasses.replace(layout, reports=reports)
    assert check(changed, firmware_descriptor(fw), knob_usage, covers=[(1, 9)]) != []


class Reporter:
    """firmware/common/knob_report.c, compiled for the host."""

    def __init__(self, fw):
        self.fw = fw
        self.state = ctypes.create_string_buffer(fw.shim_knob_report_size())
        fw.knob_report_init(self.state, u8([0] * 7), 0)

    def build(self, counts, buttons, force=0) -> bytes:
        out = (ctypes.c_uint8 * 9)()
        n = self.fw.knob_report_build(self.state, u8([c & 0xFF for c in counts]), buttons, force, out)
        return bytes(out[:n])


def test_firmware_reports_decode_into_the_expected_events(fw, layouts):
    """Random turning (up to the 128 detents between reports the firmware allows, counter wrap,
    -128 split into -127 and -1) and button presses: the firmware builds reports, the host backend turns them into events, and
    hid-tools reads the same values from the same bytes. Every detent arrives, once."""
    layout = layouts["knobbox"]
    parsed = hid.ReportDescriptor.from_bytes(list(firmware_descriptor(fw)))
    fields = parsed.input_reports[1].fields
    rng = random.Random(15)
    device = FakeHidDevice(0x2341, 0x8037, usage_page=0xFF00, layout=layout, clock=lambda: 0.0)
    backend = HidBackend(name="knobs", clock=lambda: 0.0, layout=layout, backend="hidraw",
                         vid=0x2341, pid=0x8037, api=FakeHidBus([device])).open()
    rep = Reporter(fw)
    counts, buttons = [0] * 7, 0
    turned = [0] * 7
    events = []
    for step in range(400):
        for k in range(7):
            d = rng.choice([0, 0, 1, -1, 3, -5, 40]) if step % 50 else rng.choice([-128, 127, rng.randint(-128, 127)])
            counts[k] += d
            turned[k] += d
        if rng.random() < 0.2:
            buttons ^= 1 << rng.randrange(7)
        while True:  # -128 detents take two reports
            report = rep.build(counts, buttons)
            if not report:
                break
            values = [f.get_values(list(report))[0] for f in fields if not f.is_const]
            got = backend_events(device, backend, report)
            events += got
            want = [(Kind.REL, k, float(v)) for k, v in enumerate(values[:7]) if v]
            assert [(e.kind, e.index, e.value) for e in got if e.kind is Kind.REL] == want
            assert all(-127 <= v <= 127 for v in values[:7])
            assert values[7:] == [(buttons >> k) & 1 for k in range(7)]
    per_knob = [sum(e.value for e in events if e.kind is Kind.REL and e.index == k) for k in range(7)]
    assert per_knob == turned
    held = {}
    for e in events:
        if e.kind is Kind.BUTTON:
            held[e.index] = e.value
    assert [held.get(k, 0.0) for k in range(7)] == [float((buttons >> k) & 1) for k in range(7)]
    assert backend.reports_unknown == 0
    backend.close()


def backend_events(device, backend, report):
    device.push(report)
    return backend.poll()


# ---- SpaceMouse ----------------------------------------------------------------------------


def test_spacemouse_layout_matches_the_published_descriptors(layouts):
    layout = layouts["spacemouse"]
    navigator = published("spacenavigator_046d_c626.txt")
    wireless = published("spacemouse_wireless_256f_c62e.txt")
    assert (len(navigator), len(wireless)) == (217, 270)  # as published
    assert check(layout, navigator, spacemouse_usage, covers=[(1, 7), (2, 7), (3, 3)]) == []
    assert check(layout, wireless, spacemouse_usage, covers=[(1, 13), (3, 3)],
                 ignore=(0x17,)) == []  # 0x17: battery level, not an input for the exhibit
    assert {(r.id, r.size) for r in layout.reports} == {(1, 7), (2, 7), (3, 3), (1, 13)}
    assert (0x046D, 0xC626) in layout.match and (0x256F, 0xC62E) in layout.match


def test_spacemouse_check_fails_on_a_wrong_scale_or_axis_order(layouts):
    layout = layouts["spacemouse"]
    wireless = published("spacemouse_wireless_256f_c62e.txt")
    swapped = wireless.replace(bytes([0x09, 0x30, 0x09, 0x31]), bytes([0x09, 0x31, 0x09, 0x30]), 1)
    assert check(layout, swapped, spacemouse_usage, covers=[(1, 13)], ignore=(0x17,)) != []
    reports = tuple(dataclasses.replace(r, fields=tuple(dataclasses.replace(f, scale=512)
                                                        if f.kind is Kind.ABS else f
                                                        for f in r.fields))
                    for r in layout.reports)
    rescaled = dataclasses.replace(layout, reports=reports)
    assert check(rescaled, wireless, spacemouse_usage, covers=[(1, 13)], ignore=(0x17,)) != []


# ---- PowerMate -----------------------------------------------------------------------------


def test_powermate_layout_reads_what_the_linux_driver_reads(layouts):
    """No report descriptor of the PowerMate is published; the Linux driver is the reference
    (drivers/input/misc/powermate.c, powermate_irq): button = data[0] & 1, rotation =
    (signed char) data[1]. Every value of both bytes, through the host backend."""
    layout = layouts["powermate"]
    assert layout.backend == "hid" and (0x077D, 0x0410) in layout.match
    device = FakeHidDevice(0x077D, 0x0410, layout=layout, clock=lambda: 0.0)
    backend = HidBackend(name="pm", clock=lambda: 0.0, layout=layout, backend="hid",
                         vid=0x077D, pid=0x0410, api=FakeHidBus([device])).open()
    button = 0.0
    for b0 in (0x00, 0x01, 0xFE, 0xFF):
        for b1 in range(256):
            got = backend_events(device, backend, bytes([b0, b1, 0, 0, 0, 0]))  # 6-byte reports
            rotation = b1 - 256 if b1 > 127 else b1
            want = [(Kind.REL, 0, float(rotation))] if rotation else []
            if float(b0 & 1) != button:
                button = float(b0 & 1)
                want.insert(0, (Kind.BUTTON, 0, button))
            assert sorted((e.kind.value, e.index, e.value) for e in got) == \
                sorted((k.value, i, v) for k, i, v in want), (b0, b1)
    backend.close()
