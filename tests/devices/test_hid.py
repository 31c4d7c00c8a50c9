"""HID backends with fake hidapi objects: layouts as data, the knob box's vectors, PowerMate,
SpaceMouse split and combined reports, unplug/replug, bad layouts."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from exhibit.devices.base import DeviceError, Kind, State
from exhibit.devices.fakehid import FakeHidBus, FakeHidDevice, encode_report
from exhibit.devices.hid import HidBackend, load_layout, load_layouts
from exhibit.devices.url import backend_for_url

from .conftest import Loop

VECTORS = json.loads(
    (Path(__file__).resolve().parents[2] / "firmware" / "vectors" / "protocol.json").read_text()
)["hid"]
LAYOUTS = load_layouts()


def rig(clock, layout_name, vid, pid, backend="hidraw", usage_page=0, **kw):
    layout = LAYOUTS[layout_name]
    dev = FakeHidDevice(vid, pid, usage_page=usage_page, clock=clock, layout=layout)
    bus = FakeHidBus([dev])
    b = HidBackend(
        name=layout_name,
        clock=clock,
        layout=layout,
        backend=backend,
        vid=vid,
        pid=pid,
        api=bus,
        **kw,
    ).open()
    return b, dev, bus


def test_knob_box_vectors_decode_and_encode(clock):
    layout = LAYOUTS["knobbox"]
    assert layout.reports[0].size == VECTORS["report_size"] == 9
    assert layout.reports[0].id == bytes.fromhex(VECTORS["report_descriptor"])[8]  # 85 01
    b, dev, _ = rig(clock, "knobbox", 0x2341, 0x8037, usage_page=0xFF00)
    pressed = 0
    for vec in VECTORS["reports"]:
        data = bytes.fromhex(vec["bytes"])
        assert (
            encode_report(layout, deltas=dict(enumerate(vec["deltas"])), buttons=vec["buttons"])
            == data
        )
        dev.push(data)
        events = b.poll()
        rel = {e.index: e.value for e in events if e.kind is Kind.REL}
        assert rel == {i: d for i, d in enumerate(vec["deltas"]) if d}
        for e in (e for e in events if e.kind is Kind.BUTTON):
            pressed = pressed | (1 << e.index) if e.value else pressed & ~(1 << e.index)
        assert pressed == vec["buttons"]
    assert b.reports_ok == 3 and b.state is State.CONNECTED


def test_knob_box_ignores_foreign_and_short_reports(clock):
    b, dev, _ = rig(clock, "knobbox", 0x2341, 0x8037)
    dev.push(b"\x02" + bytes(8), b"\x01\x05", bytes.fromhex("010300000000000000"))
    events = b.poll()
    assert [(e.kind, e.index, e.value) for e in events] == [(Kind.REL, 0, 3.0)]
    assert b.reports_unknown == 2 and b.reports_ok == 1


def test_powermate_has_no_report_id(clock):
    b, dev, _ = rig(clock, "powermate", 0x077D, 0x0410, backend="hid")
    dev.push(
        bytes([0, 0xFE, 0, 0, 0x50, 0]), bytes([1, 3, 0, 0, 0x50, 0]), bytes([0, 0, 0, 0, 0, 0])
    )
    got = [(e.kind, e.index, e.value) for e in b.poll()]
    assert got == [
        (Kind.REL, 0, -2.0),
        (Kind.BUTTON, 0, 1.0),
        (Kind.REL, 0, 3.0),
        (Kind.BUTTON, 0, 0.0),
    ]


def test_spacemouse_split_and_combined_reports(clock):
    layout = LAYOUTS["spacemouse"]
    b, dev, _ = rig(clock, "spacemouse", 0x046D, 0xC626)
    dev.push(
        bytes.fromhex("015e010000a2fe"),  # translation +350, 0, -350
        bytes.fromhex("020000af000000"),  # rotation ry = 175
        bytes.fromhex("030300"),
    )  # buttons 1 and 2
    got = {(e.kind, e.index): e.value for e in b.poll()}
    assert got == {
        (Kind.ABS, 0): 1.0,
        (Kind.ABS, 2): -1.0,
        (Kind.ABS, 4): 0.5,
        (Kind.BUTTON, 0): 1.0,
        (Kind.BUTTON, 1): 1.0,
    }
    combined = encode_report(layout, axes={0: 0.0, 1: 0.0, 2: 0.0, 3: 0.0, 4: 0.0, 5: -0.2})
    assert len(combined) == 13 and combined[0] == 1
    dev.push(combined, bytes.fromhex("01000000000000"))
    got = [(e.index, e.value) for e in b.poll() if e.kind is Kind.ABS]
    assert got == [(0, 0.0), (2, 0.0), (4, 0.0), (5, pytest.approx(-0.2, abs=0.003))]
    # silence after the release: the last values hold, no events
    assert b.poll() == [] and b.state is State.CONNECTED
    # overrange readings are clamped
    dev.push(bytes.fromhex("01ff7f00800000"))
    assert [(e.index, e.value) for e in b.poll()] == [(0, 1.0), (1, -1.0)]


def test_unplug_releases_and_replug_resumes_within_2_s(clock):
    b, dev, bus = rig(clock, "spacemouse", 0x256F, 0xC635)
    dev.push(
        encode_report(LAYOUTS["spacemouse"], axes={i: 0.5 for i in range(6)}),
        encode_report(LAYOUTS["spacemouse"], buttons=0b100),
    )
    loop = Loop(clock, None, [b])
    loop.step()
    assert len(loop.events) == 7
    dev.unplug()
    loop.step()
    assert b.state is State.LOST and "unplugged" in b.detail and bus.open_handles == 0
    assert sorted((e.kind.value, e.index, e.value) for e in loop.events[7:]) == sorted(
        [("abs", i, 0.0) for i in range(6)] + [("button", 2, 0.0)]
    )
    loop.run(3.0)
    assert b.state is State.LOST and "waiting for 256f:c635" in b.detail
    dev.plug()
    assert loop.until(lambda: b.state is State.CONNECTED) <= 2.0
    assert bus.open_handles == 1 and b.reconnects == 1


def test_hidraw_prefers_the_layouts_usage_page_and_serial_filter(clock):
    layout = LAYOUTS["knobbox"]
    other = FakeHidDevice(0x2341, 0x8037, usage_page=0x0001, clock=clock, serial="A")
    mine = FakeHidDevice(0x2341, 0x8037, usage_page=0xFF00, clock=clock, serial="A")
    bus = FakeHidBus([other, mine])
    b = HidBackend(
        name="k", clock=clock, layout=layout, backend="hidraw", vid=0x2341, pid=0x8037, api=bus
    ).open()
    mine.push(encode_report(layout, deltas={6: 1}))
    assert [(e.index, e.value) for e in b.poll()] == [(6, 1.0)]
    b2 = HidBackend(
        name="k",
        clock=clock,
        layout=layout,
        backend="hidraw",
        vid=0x2341,
        pid=0x8037,
        serial="B",
        api=bus,
    ).open()
    assert b2.state is State.WAITING and "2341:8037/B" in b2.detail


def test_sim_url_with_a_script(clock, tmp_path):
    script = tmp_path / "knobs.txt"
    script.write_text("turn 1 2\npress 3\nwait 0.5\nrelease 3\nturn 7 -1\nunplug 1\nturn 2 5\n")
    b = backend_for_url(f"sim://knobbox?script={script}", "knobs", clock=clock).open()
    loop = Loop(clock, None, [b])
    loop.step()
    assert [(e.kind, e.index, e.value) for e in loop.events] == [
        (Kind.REL, 0, 2.0),
        (Kind.BUTTON, 2, 1.0),
    ]
    loop.run(0.6)
    assert b.state is State.LOST
    assert [(e.kind, e.index, e.value) for e in loop.events[2:]] == [
        (Kind.BUTTON, 2, 0.0),
        (Kind.REL, 6, -1.0),
    ]
    loop.until(lambda: any(e.index == 1 for e in loop.events), limit=2.5)
    assert b.state is State.CONNECTED and loop.events[-1].value == 5.0
    b.close()


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("[layout]\nname = 'x'\n", "report: missing"),
        (
            "[layout]\nname = 'x'\n[[report]]\nid = 1\nfields = [{kind='delt', offset=1}]\n",
            "report[0].fields[0].kind: must be 'axis', 'delta' or 'buttons', got 'delt'",
        ),
        (
            "[layout]\nname = 'x'\n[[report]]\nid = 1\nfields = [{kind='delta', offset=0}]\n",
            "report[0].fields[0].offset: 0 overlaps the report id byte",
        ),
        (
            "[layout]\nname = 'x'\n[[report]]\nid = 1\nsize = 2\nfields = [{kind='axis', offset=1, "
            "type='i16'}]\n",
            "report[0].size: 2 is shorter than its fields (3 bytes)",
        ),
        (
            "[layout]\nname = 'x'\nmatch = ['12345:1']\n[[report]]\n"
            "fields = [{kind='delta', offset=0}]\n",
            'layout.match[0]: expected "VID:PID" in hex',
        ),
        ("[layout]\nname = 3\n", "layout.name: must be a string, got 3"),
        ("[layout]\nname = 'x'\ncolour = 'red'\n", "layout.colour: unknown key"),
        ("[layout\n", "not valid TOML"),
        (
            "[layout]\nname = 'x'\n[[report]]\nid = 1\n"
            "fields = [{kind='axis', offset=1, scale=0}]\n",
            "fields[0].scale: must lie in [1e-06",
        ),
    ],
)
def test_bad_layouts_name_the_file_and_key(tmp_path, text, fragment):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(DeviceError) as info:
        load_layout(f)
    assert fragment in str(info.value) and str(f) in str(info.value)


def test_shipped_layouts_load(clock):
    assert set(LAYOUTS) >= {"knobbox", "powermate", "spacemouse"}
    assert LAYOUTS["powermate"].backend == "hid"  # hidden from hidraw by the kernel
    assert LAYOUTS["knobbox"].usage_page == 0xFF00
