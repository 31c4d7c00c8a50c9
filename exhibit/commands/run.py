"""`exhibit run`: the exhibit itself — fullscreen, devices, attract mode, systemd watchdog."""

from __future__ import annotations

import argparse
import faulthandler
import logging
import math
import os
import signal
from pathlib import Path
from typing import TYPE_CHECKING

from exhibit.errors import ExhibitError
from exhibit.operations import journal
from exhibit.kiosk.config import load_kiosk_config

if TYPE_CHECKING:
    from exhibit.kiosk.app import Kiosk

HELP = "run the exhibit (fullscreen kiosk with devices and attract mode)"
log = logging.getLogger("exhibit.kiosk")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--config",
        help="site config over the shipped defaults (default: "
        "$EXHIBIT_CONFIG, else /etc/exhibit/kiosk.toml if it "
        "exists)",
    )
    parser.add_argument("--windowed", action="store_true", help="a window instead of fullscreen")
    parser.add_argument("--duration", metavar="S", help="stop after S seconds (tests, staff)")
    parser.add_argument("--screenshot", metavar="FILE.png", help="save the last frame on exit")


def run(args: argparse.Namespace) -> int:
    duration = None
    if args.duration is not None:
        try:
            duration = float(args.duration)
        except ValueError:
            raise ExhibitError(
                f"--duration must be a number of seconds, got {args.duration!r}"
            ) from None
        if not (math.isfinite(duration) and duration > 0):
            raise ExhibitError("--duration must be a positive number of seconds")
    screenshot = Path(args.screenshot) if args.screenshot else None
    if screenshot is not None and not screenshot.parent.is_dir():
        raise ExhibitError(f"--screenshot: folder {screenshot.parent} does not exist")
    # ConfigError: every problem, exit 2. A broken scene file the config does not need stops
    # nothing: the kiosk runs with the others and names it in the log and the health file.
    config = load_kiosk_config(args.config, broken_scenes_ok=True)
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    journal.install()  # under systemd: native journal records with the scene and mode as fields
    # When the watchdog kills a hung loop (SIGABRT), every thread's stack goes to the journal.
    faulthandler.enable()
    # On a Wayland compositor (cage) draw as a native client: pyGLFW's default build is X11's,
    # which there goes through Xwayland (black frames on cage). Read when glfw is imported.
    if os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("PYGLFW_LIBRARY_VARIANT", "wayland")

    from exhibit.kiosk.app import Kiosk, open_window
    from exhibit.operations.health import default_path
    from exhibit.operations.notify import Notifier
    from exhibit.preparing.process_preparer import ProcessPreparer
    from exhibit.operations.sessions import open_session_log

    window = open_window(config, args.windowed)
    try:
        kiosk = Kiosk(
            config,
            window,
            notifier=Notifier.from_env(),
            health_path=default_path(),
            sessions=open_session_log(config.sessions),
            preparer=ProcessPreparer,
        )
        asked = _stop_on_sigterm(kiosk)
        code = kiosk.run(duration=duration, screenshot=screenshot)
        if asked:
            log.info("stopped on %s: the visitor's session, narration and devices closed", asked[0])
        return code
    finally:
        window.close()


def _stop_on_sigterm(kiosk: Kiosk) -> list[str]:
    """systemd stops (and restarts, for an update) the kiosk with SIGTERM: end the frame loop
    as the maintenance keys do, so a visitor's session is written, narration and devices are
    closed and STOPPING=1 is sent, instead of dying at once with them (Python's default). The
    handler only sets the loop's flag (nothing that takes a lock); the list it returns names
    the signal once one came."""
    asked: list[str] = []

    def stop(signum: int, _frame: object) -> None:
        asked.append(signal.Signals(signum).name)
        kiosk.input.quit = True

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGHUP, stop)
    return asked
