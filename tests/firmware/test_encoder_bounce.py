"""The knob box's quadrature decoder (firmware/common/quad.c) against a bouncing encoder
(tests/firmware/encoder_model.py): contact bounce up to 2 ms on every edge, speeds up to 10
detents/s, uneven quadrature, turns both ways, half-turns that come back; sampled at the knob
box's 2 kHz. No detent may be lost or added, and they must come in the order turned.

Run twice: compiled for the host (ctypes), and compiled by avr-gcc and run on a simulated
ATmega328P in simavr, the samples arriving over its UART (so the AVR's 8-bit arithmetic is what
is tested; the knob box's pin scan itself is the Arduino core's digital reads of one port).
"""

from __future__ import annotations

import ctypes
import random
import subprocess
import time
from pathlib import Path

import pytest
import serial

from exhibit.devices.simavr import Harness

from .conftest import COMMON, require, u8
from .encoder_model import Encoder

C_SOURCE = Path(__file__).resolve().parent / "c" / "quad_avr.c"


def decode_host(fw, samples, steps=4):
    n = len(samples)
    det = (ctypes.c_int8 * n)()
    count, errors = ctypes.c_uint8(), ctypes.c_uint16()
    fw.shim_quad_run(0, steps, 0, u8(samples), n, det, ctypes.byref(count), ctypes.byref(errors))
    return [d for d in det if d], count.value, errors.value


@pytest.mark.parametrize("seed", range(12))
def test_host_decoder_loses_and_adds_no_detent_under_bounce(fw, seed):
    enc = Encoder(random.Random(seed), bounce_s=0.002, max_speed=10.0).visitor(60)
    samples = enc.samples()
    detents, count, errors = decode_host(fw, samples)
    assert len(enc.expected) > 50  # a real session, not an empty one
    assert detents == enc.expected
    assert count == sum(enc.expected) % 256 and errors == 0


def test_fast_turning_at_10_detents_per_second_with_the_longest_bounce(fw):
    rng = random.Random(99)
    enc = Encoder(rng, bounce_s=0.002, max_speed=10.0)
    for _ in range(40):
        enc.turn(rng.choice((1, -1)) * 20, 10.0)
        enc.pause(0.025)
    detents, _, errors = decode_host(fw, enc.samples())
    assert detents == enc.expected and len(detents) == 800 and errors == 0


def test_the_model_can_break_a_decoder(fw):
    """Outside the specification (bounce longer than a quarter cycle: the two contacts chatter at
    once) detents do get lost or reversed: the checks above are not vacuous."""
    bad = 0
    for seed in range(6):
        enc = Encoder(random.Random(seed), bounce_s=0.030, max_speed=20.0).visitor(40)
        detents, _, errors = decode_host(fw, enc.samples())
        bad += detents != enc.expected or errors > 0
    assert bad >= 3


@pytest.fixture(scope="module")
def quad_elf(tmp_path_factory, avr_build):
    require("the AVR build of the decoder", ["avr-gcc"], "gcc-avr avr-libc")
    out = tmp_path_factory.mktemp("quadavr") / "quad_avr.elf"
    result = subprocess.run(["avr-gcc", "-mmcu=atmega328p", "-DF_CPU=16000000UL", "-std=gnu99",
                             "-Os", "-Wall", "-Wextra", "-Werror", f"-I{COMMON}", str(C_SOURCE),
                             str(COMMON / "quad.c"), "-o", str(out)],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return out


def read_report(port, got: bytearray, limit=60.0) -> tuple[list[int], bytes]:
    """Reads until the AVR's report has come: the '+'/'-' echoes, then 8 bytes whose up and
    down counts say how many echoes came before them."""
    deadline = time.monotonic() + limit
    while True:
        if len(got) >= 8 and got[-1] == 0x0A:
            report = bytes(got[-8:])
            up, down = int.from_bytes(report[3:5], "little"), int.from_bytes(report[5:7], "little")
            echo = got[:-8]
            if len(echo) == up + down and all(c in b"+-" for c in echo):
                return [1 if c == ord("+") else -1 for c in echo], report
        assert time.monotonic() < deadline, f"no report from the AVR: {bytes(got[-20:])}"
        got += port.read(256)


@pytest.mark.slow
def test_avr_decoder_in_simavr_loses_and_adds_no_detent_under_bounce(fw, quad_elf, harness,
                                                                      tmp_path):
    sim = Harness(quad_elf, harness=harness, speed=0, log=tmp_path / "harness.log")
    port = serial.Serial(sim.pty, 115200, timeout=0.05)
    try:
        sim.run()
        for seed in range(3):
            enc = Encoder(random.Random(100 + seed), bounce_s=0.002, max_speed=10.0).visitor(40)
            samples = enc.samples()
            port.write(bytes([0x80 | 4 << 2 | 0]))
            got = bytearray()
            for i in range(0, len(samples), 256):
                port.write(bytes(samples[i:i + 256]))
                got += port.read(port.in_waiting)
            port.write(b"\xff")
            detents, report = read_report(port, got)
            count, errors = report[0], int.from_bytes(report[1:3], "little")
            assert detents == enc.expected, seed
            assert count == sum(enc.expected) % 256 and errors == 0
            assert decode_host(fw, samples)[0] == detents  # the AVR and host builds agree
    finally:
        port.close()
        sim.close()
