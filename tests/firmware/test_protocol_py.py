"""exhibit.devices.protocol, the host codec, against the same test vectors as the firmware's C
code, and against that C code directly on random streams (differential testing)."""

import ast
import json
import random
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit.devices import protocol as p
from tests.hypothesis_profiles import examples

from .test_vectors_c import rx_stream


def message_from_vector(v: dict) -> p.Message:
    f = v["fields"]
    return {
        "HELLO": lambda: p.Hello((f["fw_major"], f["fw_minor"], f["fw_patch"]), f["board"],
                                 f["n_axes"], f["n_buttons"], f["frame_hz"], f["heartbeat_ms"],
                                 p.ResetCause(f["reset_cause"])),
        "HEARTBEAT": lambda: p.Heartbeat(f["uptime_ms"], f["rx_ok"], f["rx_rejected"]),
        "AXES": lambda: p.Axes(f["t_ms"], tuple(f["axis"]), f["buttons"]),
        "CALIBRATION": lambda: p.Calibration(p.CalibrationReason(f["reason"]), f["eeprom_mask"],
                                             tuple(f["zero"])),
        "HELLO_REQUEST": p.HelloRequest,
        "CALIBRATE": p.Calibrate,
        "WATCHDOG_TEST": lambda: p.WatchdogTest(f["key"].encode()),
    }[v["type"]]()


def test_constants_agree_with_the_firmware(fw, vectors):
    assert p.PROTOCOL_VERSION == vectors["protocol_version"] == fw.shim_const(b"PROTO_VERSION")
    assert p.MAX_PAYLOAD == fw.shim_const(b"PROTO_MAX_PAYLOAD")
    assert p.MAX_ENCODED == fw.shim_const(b"PROTO_MAX_ENCODED")
    assert p.AXIS_FULL_SCALE == fw.shim_const(b"PROTO_AXIS_FULL")
    for cls, name in [(p.Hello, "HELLO"), (p.Heartbeat, "HEARTBEAT"), (p.Axes, "AXES"),
                      (p.Calibration, "CALIBRATION"), (p.WatchdogTest, "WATCHDOG_TEST")]:
        assert cls.SIZE == fw.shim_const(f"PROTO_{name}_LEN".encode())
    for t in p.MsgType:
        assert fw.proto_payload_len(int(t)) == p._MESSAGES[t].SIZE
    assert fw.proto_payload_len(0x7F) == -1 and 0x7F not in p._MESSAGES


def test_crc16_vectors(vectors):
    for v in vectors["crc16"]:
        assert p.crc16(bytes.fromhex(v["data"])) == v["crc"]


def test_crc16_check_value():
    # The catalogue's check value for CRC-16/CCITT-FALSE.
    assert p.crc16(b"123456789") == 0x29B1


def crc16_by_definition(data: bytes) -> int:
    """CRC-16/CCITT-FALSE bit by bit, straight from its definition: poly 0x1021, init 0xFFFF,
    MSB first, no reflection, no final xor. Independent of binascii, which the codec uses."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


@given(st.binary(max_size=300))
def test_crc16_matches_its_definition(data):
    assert p.crc16(data) == crc16_by_definition(data)


@given(st.binary(max_size=300))
def test_crc16_matches_the_firmware(fw, data):
    assert p.crc16(data) == fw.crc16_ccitt(data, len(data))


def test_cobs_vectors(vectors):
    for v in vectors["cobs"]:
        dec, enc = bytes.fromhex(v["decoded"]), bytes.fromhex(v["encoded"])
        assert p.cobs_encode(dec) == enc
        assert p.cobs_decode(enc) == dec


@given(st.binary(max_size=700))
def test_cobs_round_trip_without_zeros(data):
    enc = p.cobs_encode(data)
    assert 0 not in enc
    assert len(enc) <= len(data) + len(data) // 254 + 1
    assert p.cobs_decode(enc) == data


def test_frames(vectors):
    for v in vectors["frames"]:
        msg = message_from_vector(v)
        assert msg.pack().hex() == v["payload"], v["name"]
        assert p.encode_frame(msg, v["seq"]).hex() == v["wire"], v["name"]
        frame = p.decode_frame(bytes.fromhex(v["wire"])[:-1])
        assert (frame.type.name, frame.seq, frame.message) == (v["type"], v["seq"], msg)
        json.dumps(frame.to_dict())  # JSON-ready for `exhibit decode`


def test_rejects(vectors):
    for v in vectors["rejects"]:
        with pytest.raises(p.ProtocolError) as err:
            p.decode_frame(bytes.fromhex(v["chunk"]))
        assert err.value.reason.value == v["reason"], v["name"]


def decode_all(data: bytes, splits=None):
    d = p.StreamDecoder()
    items = []
    if splits is None:
        items = d.feed(data)
    else:
        pos = 0
        for s in sorted(splits) + [len(data)]:
            items += d.feed(data[pos:s])
            pos = s
    names = [i.type.name if isinstance(i, p.Frame) else i.reason.value for i in items]
    return names, (d.frames_ok, d.rejected, d.bytes_skipped), d


def test_streams(vectors):
    for v in vectors["streams"]:
        data = bytes.fromhex(v["bytes"])
        names, stats, d = decode_all(data)
        assert names == v["items"], v["name"]
        assert stats == (v["frames_ok"], v["rejected"], v["bytes_skipped"]), v["name"]
        assert d.summary() == dict(zip(("frames_ok", "rejected", "bytes_skipped"), stats))
        # one byte at a time: the same
        assert decode_all(data, range(1, len(data)))[:2] == (names, stats)


@given(st.data())
def test_streams_split_anywhere(vectors, data):
    v = data.draw(st.sampled_from(vectors["streams"]))
    raw = bytes.fromhex(v["bytes"])
    splits = data.draw(st.lists(st.integers(0, len(raw)), max_size=12))
    names, stats, _ = decode_all(raw, splits)
    assert names == v["items"]
    assert stats == (v["frames_ok"], v["rejected"], v["bytes_skipped"])


def test_every_single_bit_flip_is_rejected(vectors):
    for v in vectors["frames"]:
        wire = bytes.fromhex(v["wire"])
        for pos in range(len(wire) - 1):
            for bit in range(8):
                bad = bytearray(wire)
                bad[pos] ^= 1 << bit
                _, stats, _ = decode_all(b"\x00" + bytes(bad))
                assert stats[0] == 0, (v["name"], pos, bit)


frame_messages = st.one_of(
    st.builds(p.Heartbeat, st.integers(0, 2**32 - 1), st.integers(0, 65535), st.integers(0, 65535)),
    st.builds(p.Axes, st.integers(0, 65535), st.tuples(*[st.integers(-32767, 32767)] * 6),
              st.integers(0, 15)),
    st.builds(p.Hello, st.tuples(*[st.integers(0, 255)] * 3), st.integers(0, 255), st.just(6),
              st.just(4), st.integers(1, 255), st.integers(0, 65535),
              st.integers(0, 15).map(p.ResetCause)),
    st.builds(p.HelloRequest),
)


@given(st.lists(st.tuples(frame_messages, st.integers(0, 255), st.binary(max_size=60)), max_size=8))
def test_every_frame_around_garbage_is_recovered(parts):
    """Garbage (ended by a delimiter, as a resynchronising sender would) between valid frames:
    every frame comes back, nothing corrupt is accepted, the skipped bytes are exactly the garbage."""
    data = b""
    garbage_bytes = 0
    for msg, seq, junk in parts:
        junk = junk.replace(b"\x00", b"")
        data += junk + (b"\x00" if junk else b"") + p.encode_frame(msg, seq)
        garbage_bytes += len(junk)
    d = p.StreamDecoder()
    frames = [i for i in d.feed(data) if isinstance(i, p.Frame)]
    assert [(f.message, f.seq) for f in frames] == [(m, s) for m, s, _ in parts]
    assert d.bytes_skipped == garbage_bytes
    assert d.pending == 0


@settings(max_examples=examples(200))
@given(st.binary(max_size=400))
def test_python_and_firmware_decoders_agree_on_any_bytes(fw, data):
    names, stats, d = decode_all(data)
    assert (names, stats) == rx_stream(fw, data)
    assert len(d._buf) <= p.MAX_ENCODED


@pytest.mark.slow
def test_python_and_firmware_decoders_agree_on_a_million_random_bytes(fw, vectors):
    rng = random.Random(1234)
    frames = [bytes.fromhex(v["wire"]) for v in vectors["frames"]]
    data = bytearray()
    while len(data) < 1_000_000:
        data += rng.randbytes(rng.randrange(0, 80)) if rng.random() < 0.5 else rng.choice(frames)
        if rng.random() < 0.05:
            data += b"\x00"
    names, stats, d = decode_all(bytes(data), range(0, len(data), 4096))
    assert (names, stats) == rx_stream(fw, bytes(data))
    assert stats[0] > 1000 and len(d._buf) <= p.MAX_ENCODED


def test_overlong_input_keeps_memory_bounded():
    d = p.StreamDecoder()
    for _ in range(100):
        assert d.feed(b"\x41" * 1000) == []
        assert len(d._buf) <= p.MAX_ENCODED
    (item,) = d.feed(b"\x00")
    assert item.reason is p.Reject.TOO_LONG and item.size == 100_000
    assert d.summary() == {"frames_ok": 0, "rejected": 1, "bytes_skipped": 100_000}


def test_encode_frame_checks_payload_size():
    with pytest.raises(ValueError):
        p.encode_frame(p.WatchdogTest(b"WDT"), 0)


def test_axes_normalized():
    a = p.Axes(0, (32767, -32767, 0, 16384, 1, -1), 0)
    assert a.normalized[:3] == (1.0, -1.0, 0.0)
    assert a.normalized[3] == pytest.approx(0.5, abs=1e-4)


def hb(seq, msg=p.Heartbeat()):
    return p.Frame(msg.TYPE, seq & 0xFF, msg)


def track(seqs, tracker=None):
    """(tracker, what update returned for each) after feeding heartbeats numbered ``seqs``."""
    t = tracker or p.SequenceTracker()
    return t, [t.update(hb(s)) for s in seqs]


def test_sequence_tracker_counts_gaps_wrap_and_restarts():
    t = p.SequenceTracker()
    assert t.update(hb(0, p.Hello())) == 0
    assert track([1, 2, 5, 6], t)[1] == [0, 0, 2, 0]
    assert track([150, 254, 255, 0, 1], t)[1] == [143, 103, 0, 0, 0]  # wraps 255 -> 0
    assert t.update(hb(0, p.Hello())) == 0  # the board restarted: not a loss
    assert (t.lost, t.restarts, t.reordered, t.duplicates) == (248, 1, 0, 0)
    assert t.update(hb(1)) == 0


@pytest.mark.parametrize("seqs, lost, reordered, duplicates", [
    ([5, 5], 0, 0, 1),  # was 255 lost
    ([5, 6, 6, 6, 7], 0, 0, 2),
    ([5, 7, 6, 8], 0, 1, 0),  # was 256 lost
    ([254, 0, 255, 1], 0, 1, 0),  # swapped across the wrap
    ([5, 9, 8, 6, 7, 10], 0, 3, 0),
    ([5, 7, 6, 6, 7], 0, 1, 2),
    ([5, 9], 3, 0, 0),  # a real gap
    ([5, 9, 7], 2, 1, 0),  # one of the three came late
    ([5, 9, 5], 3, 0, 1),
    ([100, 100 - 64], 0, 1, 0),  # 64 back: late (from before the tracker started)
    ([100, 100 - 65], 190, 0, 0),  # 65 back: a gap that wrapped around
    ([100, 100 + 191], 190, 0, 0),  # the longest gap counted as one: 190 frames
    ([100, 100 + 192], 0, 1, 0),  # one more reads as 64 back
])
def test_sequence_tracker_tells_late_and_repeated_frames_from_gaps(seqs, lost, reordered,
                                                                   duplicates):
    t, _ = track(seqs)
    assert (t.lost, t.reordered, t.duplicates) == (lost, reordered, duplicates)


def test_a_late_frame_takes_its_loss_back():
    t, gaps = track([5, 7])
    assert gaps == [0, 1] and t.lost == 1
    assert t.update(hb(6)) == 0 and (t.lost, t.reordered) == (0, 1)
    assert t.update(hb(8)) == 0 and t.lost == 0


def test_a_frame_missing_longer_than_the_window_stays_lost():
    t, _ = track([0, *range(2, 67)])
    assert t.lost == 1
    t.update(hb(1))  # 65 back: read as a wrapped gap, the documented ambiguity
    assert t.lost == 1 + 190 and t.reordered == 0


def test_resync_forgets_what_was_missing():
    t, _ = track([5, 9])
    t.expected = None  # what the controller does on reopening the port
    t, _ = track([40, 7, 40], t)  # 7 was once missing, but that was before the resync
    assert (t.lost, t.reordered, t.duplicates) == (3, 1, 1)


@st.composite
def link(draw):
    """Heartbeat numbers as a lossy, reordering, repeating link delivers them, unwrapped.

    Kept runs of 1-20 frames alternate with dropped runs of 0-50 (so no gap reaches 256 - 64);
    frames are shuffled within blocks of 16 numbers and some repeated later in their block (so
    none arrives more than 16 behind the newest); the first frame comes first and is not lost.
    """
    runs = draw(st.lists(st.tuples(st.integers(1, 20), st.integers(0, 50)), min_size=1,
                         max_size=40))
    kept, n = [], 0
    for keep, drop in runs:
        kept += range(n, n + keep)
        n += keep + drop
    blocks: dict[int, list[int]] = {}
    for s in kept[1:]:
        blocks.setdefault(s // 16, []).append(s)
    delivered = [0]
    for block in blocks.values():
        order = list(draw(st.permutations(block)))
        for _ in range(draw(st.integers(0, 3))):
            i = draw(st.integers(0, len(order) - 1))
            order.insert(draw(st.integers(i + 1, len(order))), order[i])
        delivered += order
    return draw(st.integers(0, 255)), delivered


LINK_EXAMPLES = []


@settings(max_examples=examples(300), deadline=None)
@given(link())
def test_sequence_tracker_counts_exactly_the_frames_never_delivered(stream):
    """Whatever the order and repeats, lost = the numbers never delivered, and every late or
    repeated frame is counted once as reordered or duplicate."""
    start, delivered = stream
    LINK_EXAMPLES.append(len(delivered))
    t, _ = track([start + s for s in delivered])
    seen, newest, reordered = set(), -1, 0
    for s in delivered:
        reordered += s not in seen and s < newest
        seen.add(s)
        newest = max(newest, s)
    assert t.lost == newest + 1 - len(seen)
    assert t.duplicates == len(delivered) - len(seen)
    assert t.reordered == reordered


def test_report_link_examples(capsys):
    with capsys.disabled():
        print(f"\nsequence tracker: {len(LINK_EXAMPLES)} hypothesis streams, "
              f"{sum(LINK_EXAMPLES)} frames")


def test_codec_module_does_no_io():
    """The codec stays pure: the serial backend, decode and monitor tools build on it."""
    tree = ast.parse(Path(p.__file__).read_text())
    imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    pure = {"__future__", "binascii", "enum", "struct", "dataclasses", "typing"}
    assert imported <= pure, imported


def test_protocol_md_examples_match_the_vectors(vectors):
    """The worked examples and the HID descriptor printed in PROTOCOL.md are the vectors' bytes."""
    import re

    doc = (Path(p.__file__).resolve().parents[2] / "firmware" / "PROTOCOL.md").read_text()
    wires = [bytes.fromhex(m) for m in re.findall(r"^wire:\s+([0-9a-f ]+)$", doc, re.M)]
    assert wires == [p.encode_frame(p.HelloRequest(), 0),
                     bytes.fromhex(vectors["frames"][0]["wire"])]
    block = doc.split("## Report descriptor", 1)[1].split("```")[1]
    desc = b"".join(bytes.fromhex(re.match(r"\s*((?:[0-9A-F]{2} )+)", line).group(1))
                    for line in block.strip().splitlines())
    assert desc.hex() == vectors["hid"]["report_descriptor"]
    assert f"## Report descriptor ({len(desc)} bytes)" in doc
