"""The kiosk's loop over time: frames paced (by vsync, else a sleep to fps_limit; a picture held
for a visitor who waits is redrawn every HOLD_FRAME_S only while they do not turn it, leaving
the CPU to the preparing),
the systemd watchdog pinged after every frame, drawn or failed (the loop is alive either way: a
hung one is what the watchdog is for), the reports about once a second, READY to systemd after
the first frame drawn, and the end: the maintenance keys, a duration, a
frame count or ``until()`` (staff, tests, benchmarks), or FAILING_EXIT_S with every frame
failing. Then the process exits FAILING_EXIT for systemd to restart it: a fresh process (a new
GL context, attract mode from the start) is the one remedy left, and a minute or more between
restarts is no crash loop."""

from __future__ import annotations

import gc
import logging
import time
from collections.abc import Callable
from typing import Protocol

from exhibit.kiosk.config import KioskConfig
from exhibit.kiosk.frame_errors import FrameErrors
from exhibit.kiosk.window_input import WindowInput
from exhibit.operations.notify import Notifier

log = logging.getLogger("exhibit.kiosk")

#: A run of failed frames this long, with none drawn, ends the process so systemd restarts it.
FAILING_EXIT_S = 60.0
FAILING_EXIT = 70  # EX_SOFTWARE
#: While a visitor waits for a scene still being prepared and does not turn the picture held on
#: screen, it is redrawn this often: on software GL a frame takes the CPU the preparing
#: needs.
HOLD_FRAME_S = 0.2


class Looped(Protocol):
    """What the loop runs (exhibit.kiosk.app.Kiosk): ``tick(start)`` is one frame, returning
    whether it was drawn (one that raised is in ``errors``); ``report(now)`` writes the STATUS
    line and the health file."""

    clock: Callable[[], float]
    frames: int
    errors: FrameErrors
    notifier: Notifier | None
    input: WindowInput

    def tick(self, start: float) -> bool: ...
    def report(self, now: float) -> None: ...
    @property
    def holding_back(self) -> bool: ...


def run_frames(
    kiosk: Looped,
    started: float,
    config: KioskConfig,
    duration: float | None = None,
    max_frames: int | None = None,
    until: Callable[[], bool] | None = None,
) -> int:
    """Frames until the end (the module's docstring); returns 0, or FAILING_EXIT."""
    frames = 0
    min_frame = 1.0 / config.fps_limit
    last_report = started
    while not kiosk.input.quit:
        start = kiosk.clock()
        drawn = kiosk.tick(start)
        if kiosk.notifier is not None:
            kiosk.notifier.watchdog()
        if start - last_report >= 1.0:
            last_report = start
            try:
                kiosk.report(start)
            except Exception as exc:  # noqa: BLE001 - a report's bug must not end the exhibit
                kiosk.errors.failed(exc, start)
        if drawn and kiosk.frames == 1:
            # Start-up is over: everything built so far (configs, scenes, meshes, programs)
            # lives as long as the process. Collect once and move it out of the collector's
            # sight, so a full collection later walks only the few objects frames make, not
            # start-up's hundreds of thousands (a pause of tens of ms in the middle of a
            # visitor's session otherwise).
            gc.collect()
            gc.freeze()
            if kiosk.notifier is not None:
                kiosk.notifier.ready()
        failing = kiosk.errors.failing_since  # set whenever a frame was not drawn
        if not drawn and failing is not None and start - failing >= FAILING_EXIT_S:
            log.critical(
                "no frame drawn for %.0f s (%d failed): exiting, for systemd to restart the kiosk",
                start - failing,
                kiosk.errors.total,
            )
            return FAILING_EXIT
        frames += 1
        if duration is not None and start - started >= duration:
            break
        if max_frames is not None and frames >= max_frames:
            break
        if until is not None and until():
            break
        # a failed frame did not wait for vsync: no busy loop; a held picture that stands still
        # leaves the CPU to the scene a visitor waits for
        held = kiosk.holding_back
        spare = (HOLD_FRAME_S if held else min_frame) - (kiosk.clock() - start)
        if spare > 0 and (not config.vsync or not drawn or held):
            time.sleep(spare)
    return 0
