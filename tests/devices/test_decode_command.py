"""`exhibit decode`: captured bytes to JSON lines, checked against the shared vectors."""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.devices import protocol as p

VECTORS = json.loads(
    (Path(__file__).resolve().parents[2] / "firmware" / "vectors" / "protocol.json").read_text()
)


def decode(tmp_path, capsys, data: bytes, *extra):
    f = tmp_path / "capture.bin"
    f.write_bytes(data)
    assert main(["decode", "--protocol", "controller", str(f), *extra]) == 0
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


@pytest.mark.parametrize("stream", VECTORS["streams"], ids=lambda s: s["name"])
def test_vector_streams(tmp_path, capsys, stream):
    lines = decode(tmp_path, capsys, bytes.fromhex(stream["bytes"]))
    assert lines[-1] == {
        "summary": {k: stream[k] for k in ("frames_ok", "rejected", "bytes_skipped")}
    }
    items = [line.get("type") or line.get("rejected") for line in lines[:-1]]
    assert items == stream["items"]


def test_frames_carry_their_fields(tmp_path, capsys):
    data = p.encode_frame(p.Axes(1234, (1, -2, 3, -4, 5, -32767), 0b1010), 77)
    data += p.encode_frame(p.Hello((1, 2, 3), reset_cause=p.ResetCause.WATCHDOG), 0)
    lines = decode(tmp_path, capsys, data)
    assert lines[0] == {
        "type": "AXES",
        "seq": 77,
        "t_ms": 1234,
        "axes": [1, -2, 3, -4, 5, -32767],
        "buttons": 10,
    }
    assert lines[1]["type"] == "HELLO" and lines[1]["reset_cause"] == ["WATCHDOG"]
    assert lines[2] == {"summary": {"frames_ok": 2, "rejected": 0, "bytes_skipped": 0}}


def test_large_random_capture_in_blocks_matches_one_shot_decoding(tmp_path, capsys):
    rng = random.Random(3)
    data = bytearray()
    for i in range(3000):
        data += rng.randbytes(rng.randrange(0, 30)) if rng.random() < 0.3 else b""
        data += p.encode_frame(p.Axes(i, (i,) * 6, 0), i)
    lines = decode(tmp_path, capsys, bytes(data), "--frames-only")
    ref = p.StreamDecoder()
    frames = [i for i in ref.feed(bytes(data)) if isinstance(i, p.Frame)]
    assert lines[-1]["summary"] == ref.summary() and ref.rejected > 100
    assert [line["t_ms"] for line in lines[:-1]] == [f.message.t_ms for f in frames]


def test_stdin(cli):
    import subprocess
    import sys

    data = p.encode_frame(p.Heartbeat(5, 1, 2), 3) + b"\x02\x05\x00"
    r = subprocess.run(
        [sys.executable, "-m", "exhibit", "decode", "-"], input=data, capture_output=True
    )
    assert r.returncode == 0, r.stderr
    out = [json.loads(x) for x in r.stdout.decode().splitlines()]
    assert out[0]["type"] == "HEARTBEAT" and out[1]["rejected"] == "short"
    assert out[-1] == {"summary": {"frames_ok": 1, "rejected": 1, "bytes_skipped": 2}}


def test_missing_file_is_one_line(cli, tmp_path):
    r = cli("decode", str(tmp_path / "nope.bin"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert (
        r.stderr.strip() == f"exhibit decode: error: cannot read {tmp_path / 'nope.bin'}: "
        "No such file or directory"
    )
