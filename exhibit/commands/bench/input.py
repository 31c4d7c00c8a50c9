"""`exhibit bench input`: how fast input reaches the picture.

- **latency**: from an AXES frame's bytes written to the controller's pty to the ViewState that
  reflects them, through the real path (pyserial read, StreamDecoder, SerialController events,
  Mapper.apply), polled as fast as a render loop could; p50 and p99. The baseline in the same
  run is the kernel's own floor: the same bytes written to a pty and read back raw.
- **throughput**: StreamDecoder frames per second on one core, fed in 4 KiB blocks, against the
  controller's 100 frames per second.

Goals (issue 5): p99 <= 2 ms; decoding >= 100x the controller's frame rate.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import select
import statistics
import time
import tty

from exhibit.devices import protocol as p
from exhibit.devices.base import Kind, State
from exhibit.devices.controller import SerialController
from exhibit.devices.mapping import Binding, Mapper, MappingConfig
from exhibit.errors import ExhibitError
from exhibit.geometry.view import ViewState

HELP = "input latency (pty bytes -> ViewState) and controller decoder throughput"
CONTROLLER_HZ = 100


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--frames", type=int, default=2000, help="latency samples (default 2000)")
    parser.add_argument(
        "--decode-frames",
        type=int,
        default=200_000,
        help="frames for the throughput run (default 200000)",
    )
    parser.add_argument("--json", action="store_true")


def _pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))]


def kernel_floor(n: int) -> list[float]:
    master, slave = os.openpty()
    tty.setraw(slave)
    frame = p.encode_frame(p.Axes(0, (1,) * 6, 0), 0)
    out = []
    try:
        for _ in range(n):
            t0 = time.perf_counter()
            os.write(master, frame)
            got = 0
            while got < len(frame):
                select.select([slave], [], [], 1.0)
                got += len(os.read(slave, 4096))
            out.append(time.perf_counter() - t0)
    finally:
        os.close(master)
        os.close(slave)
    return out


def pipeline_latency(n: int) -> list[float]:
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    backend = SerialController(name="controller", path=path).open()
    mapper = Mapper(MappingConfig((Binding("controller", Kind.ABS, 0, "theta1", rate=90.0),)))
    view = ViewState()
    out = []
    try:
        os.write(master, p.encode_frame(p.Hello((1, 0, 0)), 0))
        deadline = time.monotonic() + 5
        while backend.state is not State.CONNECTED:
            backend.poll()
            os.read(master, 4096) if select.select([master], [], [], 0)[0] else None
            if time.monotonic() > deadline:
                raise ExhibitError("bench: the controller backend did not connect to its pty")
        for i in range(n):
            raw = (i % 2 * 2 - 1) * (1000 + i % 1000)  # a new value every frame
            frame = p.encode_frame(p.Axes(i * 10 & 0xFFFF, (raw,) + (0,) * 5, 0), (i + 1) & 0xFF)
            t0 = time.perf_counter()
            os.write(master, frame)
            while True:
                events = backend.poll()
                view = mapper.apply(view, events, time.monotonic())
                if any(e.kind is Kind.ABS and e.index == 0 for e in events):
                    break
                if time.perf_counter() - t0 > 1.0:
                    raise ExhibitError("bench: a frame did not arrive within 1 s")
            out.append(time.perf_counter() - t0)
            if i % 100 == 0 and select.select([master], [], [], 0)[0]:
                os.read(master, 4096)  # the backend's HELLO_REQUESTs, unanswered
    finally:
        backend.close()
        os.close(master)
        os.close(slave)
    return out


def decoder_throughput(n: int) -> float:
    blob = b"".join(
        p.encode_frame(p.Axes(i & 0xFFFF, (i & 0x7FFF,) * 6, i & 0xF), i & 0xFF) for i in range(n)
    )
    dec = p.StreamDecoder()
    t0 = time.perf_counter()
    for i in range(0, len(blob), 4096):
        dec.feed(blob[i : i + 4096])
    dt = time.perf_counter() - t0
    if dec.frames_ok != n:
        raise ExhibitError(f"bench: decoded {dec.frames_ok} of {n} frames")
    return n / dt


def run(args: argparse.Namespace) -> int:
    if args.frames < 10 or args.decode_frames < 1000:
        raise ExhibitError("--frames must be >= 10 and --decode-frames >= 1000")
    floor = kernel_floor(args.frames)
    lat = pipeline_latency(args.frames)
    fps = decoder_throughput(args.decode_frames)
    ms = lambda xs, q: round(_pct(xs, q) * 1000, 3)  # noqa: E731
    lt = {
        "p50": ms(lat, 0.5),
        "p99": ms(lat, 0.99),
        "max": ms(lat, 1.0),
        "mean": round(statistics.fmean(lat) * 1000, 3),
    }
    fl = {"p50": ms(floor, 0.5), "p99": ms(floor, 0.99)}
    rate = round(fps / CONTROLLER_HZ)
    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cpus, "
        f"Python {platform.python_version()}",
        "latency_ms": lt,
        "kernel_pty_floor_ms": fl,
        "decoder_frames_per_s": round(fps),
        "decoder_vs_controller_rate": rate,
        "goals": {"latency_p99_ms": 2.0, "decoder_vs_controller_rate": 100},
        "goals_met": lt["p99"] <= 2.0 and rate >= 100,
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print(
        f"input latency, pty bytes -> ViewState ({args.frames} frames): p50 {lt['p50']} ms, "
        f"p99 {lt['p99']} ms, max {lt['max']} ms   (goal p99 <= 2 ms)"
    )
    print(f"  kernel floor, pty write -> read:          p50 {fl['p50']} ms, p99 {fl['p99']} ms")
    print(
        f"decoder: {result['decoder_frames_per_s']} frames/s on one core = "
        f"{result['decoder_vs_controller_rate']}x the controller's {CONTROLLER_HZ} Hz "
        "(goal >= 100x)"
    )
    print("goals met" if result["goals_met"] else "GOALS NOT MET")
    return 0
