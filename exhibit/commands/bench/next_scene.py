"""`exhibit bench next-scene [--busy 0 2] [--repeat N] [--json]`: from a visitor pressing "next
scene" to the first frame of that scene, when it is not prepared yet. The real kiosk
(exhibit.kiosk.app.Kiosk) with the shipped config on the headless renderer (EGL; llvmpipe where
there is no GPU), its real worker process (exhibit.preparing.process_preparer.ProcessPreparer)
and the wall clock; the frame loop runs flat out as under vsync (the headless target has no vsync to
wait for), with the governor choosing the quality. The keyboard's n goes down after the first
frames, while the worker is still preparing the first scene's other mesh levels from an empty
mesh cache, so the scene asked for (the next of content.scenes) is still to be built.

Variants, in turn in every round (a noisy machine slows all alike): ``after``, the kiosk as it
is (the picture held with a notice, redrawn every HOLD_FRAME_S; the scene prepared in an
un-niced worker of its own), and ``before``, the baseline of issue 31: the notice screen at the
full frame rate and the scene waiting its turn in the niced worker. Each with 0 and with
``--busy`` extra processes spinning (``python -c 'while 1: pass'``), the load of a machine that
does other work."""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, cast

from exhibit.errors import ExhibitError

if TYPE_CHECKING:
    from exhibit.kiosk.app import Kiosk
    from exhibit.render.offscreen import Headless

HELP = "seconds from 'next scene' to that scene's first frame while it is being prepared"
#: Frames drawn before the key goes down (the worker starts after the first).
FRAMES_BEFORE = 3
#: No scene arriving within this long ends a run (reported as a timeout).
TIMEOUT_S = 300.0
VARIANTS = ("before", "after")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeat", type=int, default=2, help="rounds (default: %(default)s)")
    parser.add_argument(
        "--busy",
        type=int,
        nargs="+",
        default=[0, 2],
        help="extra busy processes, one setting per run (default: %(default)s)",
    )
    parser.add_argument(
        "--size", default="1280x720", metavar="WxH", help="frame size (default: %(default)s)"
    )
    parser.add_argument(
        "--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS, help="what to run"
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def _before_kiosk():
    """The kiosk as it was before issue 31's item 5: the notice screen while a visitor waits,
    drawn at the full frame rate."""
    from exhibit.kiosk.app import Kiosk
    from exhibit.kiosk.language import PREPARING

    class Before(Kiosk):
        def _hold(self, frame, title: str, now: float) -> None:
            self._waiting = (frame.scene, now)
            self.content.wanted((frame.scene, frame.params))
            self.window.notice(
                [self.translate(PREPARING).replace("{title}", title)], self.drift(now)
            )
            self._shown = self._fade_start = None

        @property
        def waiting(self) -> bool:
            return False  # no holding back: the loop runs at its full rate

    return Before


class Visitor:
    """run()'s ``until``: presses n after FRAMES_BEFORE frames, then watches for the first
    frame drawn of the scene it asked for."""

    def __init__(self, kiosk: Kiosk) -> None:
        self.kiosk = kiosk
        self.pressed: float | None = None
        self.arrived: float | None = None
        self.wanted: tuple | None = None
        self.waited_frames = 0
        self.ready_at_press = False

    def __call__(self) -> bool:
        from exhibit.render.target import HeadlessTarget, Key

        k = self.kiosk
        assert k.state is not None
        if self.pressed is None:
            if k.frames >= FRAMES_BEFORE:
                window = cast(HeadlessTarget, k.window)  # one_run's kiosk draws into one
                window.post(Key("n", True))
                window.post(Key("n", False))
                self.pressed = time.perf_counter()
            return False
        frame = k.state.frame
        if self.wanted is None:
            if frame.mode != "visitor":
                return time.perf_counter() - self.pressed > TIMEOUT_S
            self.wanted = (frame.scene, frame.params)
            self.ready_at_press = k.content.levels(self.wanted) is not None
        levels = k.content.levels(self.wanted) or {}
        drawn = getattr(k.window, "drawn", None)
        if (
            (frame.scene, frame.params) == self.wanted
            and drawn is not None
            and any(drawn[0] is gpu for gpu in levels.values())
        ):
            self.arrived = time.perf_counter()
            return True
        self.waited_frames += 1
        return time.perf_counter() - self.pressed > TIMEOUT_S


def one_run(variant: str, busy: int, size: tuple[int, int], headless: Headless) -> dict:
    """One kiosk from an empty mesh cache, ``busy`` spinning processes beside it."""
    from exhibit.kiosk.app import Kiosk
    from exhibit.kiosk.config import load_kiosk_config
    from exhibit.preparing.process_preparer import ProcessPreparer
    from exhibit.review.setup import keyboard_only
    from exhibit.render.target import HeadlessTarget

    spinners = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(busy)]
    folder = Path(tempfile.mkdtemp(prefix="exhibit-bench-next-"))
    old_cache = os.environ.get("EXHIBIT_CACHE_DIR")
    os.environ["EXHIBIT_CACHE_DIR"] = str(folder / "cache")  # the worker inherits it
    kiosk = None
    try:
        config = load_kiosk_config()
        config = dataclasses.replace(
            config,
            size=size,
            fullscreen=False,
            devices_config=keyboard_only(config.devices_config, folder / "devices.toml"),
        )
        window = HeadlessTarget(headless, size)
        cls = _before_kiosk() if variant == "before" else Kiosk
        preparer = functools.partial(ProcessPreparer, urgent=variant == "after")
        kiosk = cls(config, window, preparer=preparer)
        visitor = Visitor(kiosk)
        started = time.perf_counter()
        kiosk.run(until=visitor)
        wait = (
            None
            if visitor.arrived is None or visitor.pressed is None
            else visitor.arrived - visitor.pressed
        )
        return {
            "variant": variant,
            "busy": busy,
            "scene": visitor.wanted[0] if visitor.wanted else None,
            "ready_at_press": visitor.ready_at_press,
            "next_to_frame_s": None if wait is None else round(wait, 2),
            "frames_while_waiting": visitor.waited_frames,
            "run_s": round(time.perf_counter() - started, 1),
        }
    finally:
        if kiosk is not None:
            kiosk.release()
        for spinner in spinners:
            spinner.kill()
            spinner.wait()
        if old_cache is None:
            os.environ.pop("EXHIBIT_CACHE_DIR", None)
        else:
            os.environ["EXHIBIT_CACHE_DIR"] = old_cache
        subprocess.run(["rm", "-rf", str(folder)], check=False)


def run(args: argparse.Namespace) -> int:
    from exhibit.commands.render import parse_size
    from exhibit.render import Headless

    if args.repeat < 1 or any(b < 0 or b > 64 for b in args.busy):
        raise ExhibitError("--repeat: at least 1; --busy: 0..64 processes")
    size = parse_size(args.size)
    headless = Headless()
    runs = []
    try:
        for _ in range(args.repeat):
            for busy in args.busy:
                for variant in args.variants:
                    runs.append(one_run(variant, busy, size, headless))
                    if not args.json:
                        print(json.dumps(runs[-1]), file=sys.stderr)
    finally:
        headless.release()
    summary = []
    for busy in args.busy:
        for variant in args.variants:
            waits = [
                r["next_to_frame_s"]
                for r in runs
                if r["busy"] == busy and r["variant"] == variant and r["next_to_frame_s"]
            ]
            summary.append(
                {
                    "variant": variant,
                    "busy": busy,
                    "median_s": round(statistics.median(waits), 2) if waits else None,
                    "runs_s": waits,
                }
            )
    report = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, {headless.ctx.info.get('GL_RENDERER', '?')}",
        "size": list(size),
        "summary": summary,
        "runs": runs,
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"'next scene' to its first frame, {size[0]}x{size[1]}, on {report['machine']}")
    for row in summary:
        runs_s = ", ".join(f"{w:.1f}" for w in row["runs_s"])
        median = "-" if row["median_s"] is None else f"{row['median_s']:.1f} s"
        print(f"{row['variant']:>7}  busy {row['busy']}: median {median} ({runs_s})")
    return 0
