"""The firmware's C protocol code (firmware/common, built for the host) against the shared test
vectors in firmware/vectors/protocol.json, byte for byte."""

import binascii
import ctypes

import pytest


REJECT_NAMES = ["ok", "cobs", "short", "crc", "version", "type", "length", "too_long"]
TYPES = {"HELLO": 0x01, "HEARTBEAT": 0x02, "AXES": 0x03, "CALIBRATION": 0x04,
         "HELLO_REQUEST": 0x10, "CALIBRATE": 0x11, "WATCHDOG_TEST": 0x12}


def flat_fields(fields: dict) -> list[int]:
    """Vector fields are listed in C struct order; arrays expand in place."""
    out = []
    for v in fields.values():
        out.extend(v if isinstance(v, list) else [v])
    return out


def test_vector_file_matches_c_constants(fw, vectors):
    assert vectors["protocol_version"] == fw.shim_const(b"PROTO_VERSION")
    for name, ctype in TYPES.items():
        frame = next(f for f in vectors["frames"] if f["type"] == name)
        assert fw.proto_payload_len(ctype) == len(bytes.fromhex(frame["payload"])), name


def test_crc16(fw, vectors):
    for v in vectors["crc16"]:
        data = bytes.fromhex(v["data"])
        assert fw.crc16_ccitt(data, len(data)) == v["crc"]
        # and the vector itself against Python's independent CRC-CCITT implementation
        assert binascii.crc_hqx(data, 0xFFFF) == v["crc"]


def test_crc16_matches_reference_on_every_single_byte(fw):
    for b in range(256):
        assert fw.crc16_update(0xFFFF, b) == binascii.crc_hqx(bytes([b]), 0xFFFF)


def test_cobs_encode_and_decode(fw, vectors):
    for v in vectors["cobs"]:
        dec, enc = bytes.fromhex(v["decoded"]), bytes.fromhex(v["encoded"])
        out = (ctypes.c_uint8 * (len(dec) + len(dec) // 254 + 1))()
        n = fw.cobs_encode(dec, len(dec), out)
        assert bytes(out[:n]) == enc
        back = (ctypes.c_uint8 * max(len(dec), 1))()
        assert fw.cobs_decode(enc, len(enc), back, len(dec)) == len(dec)
        assert bytes(back[: len(dec)]) == dec


def test_cobs_decode_rejects_malformed(fw):
    out = (ctypes.c_uint8 * 64)()
    for bad in (b"\x05\x01\x02", b"\x03\x01\x00\x02", b"\x00", b"\x02\x01\x00"):
        assert fw.cobs_decode(bad, len(bad), out, 64) == -1, bad.hex()
    # valid, but the output does not fit
    assert fw.cobs_decode(b"\x04\x01\x02\x03", 4, out, 2) == -1


@pytest.mark.parametrize("index", range(12))
def test_frame_bytes(fw, vectors, index):
    v = vectors["frames"][index]
    ctype = TYPES[v["type"]]
    payload = bytes.fromhex(v["payload"])
    if v["type"] in ("HELLO", "HEARTBEAT", "AXES", "CALIBRATION"):
        # the firmware's packer, from the vector's field values
        f = flat_fields(v["fields"])
        buf = (ctypes.c_uint8 * 32)()
        n = fw.shim_pack(ctype, (ctypes.c_long * len(f))(*f), buf)
        assert bytes(buf[:n]) == payload, v["name"]
    wire = (ctypes.c_uint8 * 64)()
    n = fw.proto_frame(ctype, v["seq"], payload, len(payload), wire)
    assert bytes(wire[:n]).hex() == v["wire"], v["name"]
    # and back through the firmware's parser
    msg = (ctypes.c_uint8 * 40)()
    chunk = bytes.fromhex(v["wire"])[:-1]
    assert fw.shim_parse(chunk, len(chunk), msg) == 0
    assert (msg[0], msg[1], bytes(msg[3 : 3 + msg[2]])) == (ctype, v["seq"], payload)


def test_frame_index_covers_vector_file(vectors):
    assert len(vectors["frames"]) == 12  # test_frame_bytes is parametrized over this many


def test_frame_refuses_oversized_payload(fw):
    big = bytes(33)
    assert fw.proto_frame(0x01, 0, big, len(big), (ctypes.c_uint8 * 80)()) == 0


def test_rejects(fw, vectors):
    msg = (ctypes.c_uint8 * 40)()
    for v in vectors["rejects"]:
        chunk = bytes.fromhex(v["chunk"])
        assert REJECT_NAMES[fw.shim_parse(chunk, len(chunk), msg)] == v["reason"], v["name"]


def rx_stream(fw, data: bytes):
    out = (ctypes.c_uint8 * (4 * len(data) + 64))()
    stats = (ctypes.c_uint32 * 3)()
    n = fw.shim_rx_stream(data, len(data), out, len(out), stats)
    assert n >= 0
    items, i = [], 0
    names = {v: k for k, v in TYPES.items()}
    while i < n:
        code, typ, seq, length = out[i : i + 4]
        items.append(names[typ] if code == 0 else REJECT_NAMES[code])
        i += 4 + (length if code == 0 else 0)
    return items, tuple(stats)


def test_streams(fw, vectors):
    for v in vectors["streams"]:
        items, stats = rx_stream(fw, bytes.fromhex(v["bytes"]))
        assert items == v["items"], v["name"]
        assert stats == (v["frames_ok"], v["rejected"], v["bytes_skipped"]), v["name"]


def test_stream_after_garbage_of_any_length(fw, vectors):
    """Whatever garbage precedes it (up to a delimiter), the rest of the stream decodes the same and
    the garbage is counted once, byte for byte."""
    v = vectors["streams"][1]
    data = bytes.fromhex(v["bytes"])
    for cut in range(1, 45):
        items, stats = rx_stream(fw, bytes([0x5A]) * cut + b"\x00" + data)
        assert items[0] in ("cobs", "short", "too_long") and items[1:] == v["items"], cut
        assert stats == (v["frames_ok"], v["rejected"] + 1, v["bytes_skipped"] + cut), cut


def test_every_single_bit_flip_is_rejected(fw, vectors):
    """CRC-16 with COBS framing: no frame with one flipped bit is accepted as a frame (it may
    split into pieces; none of them may pass)."""
    for v in vectors["frames"]:
        wire = bytes.fromhex(v["wire"])
        for pos in range(len(wire) - 1):
            for bit in range(8):
                bad = bytearray(wire)
                bad[pos] ^= 1 << bit
                items, stats = rx_stream(fw, b"\x00" + bytes(bad))
                assert stats[0] == 0, (v["name"], pos, bit, items)


def test_overlong_chunk_is_bounded_and_counted(fw):
    max_encoded = fw.shim_const(b"PROTO_MAX_ENCODED")
    items, stats = rx_stream(fw, bytes([0x27]) * max_encoded + b"\x00")
    assert items == ["cobs"]  # still parsed: code 0x27 runs past the end
    for n in (max_encoded + 1, max_encoded + 2, 5000):
        items, stats = rx_stream(fw, bytes([0x27]) * n + b"\x00")
        assert items == ["too_long"] and stats == (0, 1, n)
