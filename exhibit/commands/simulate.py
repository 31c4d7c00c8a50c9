"""`exhibit simulate controller [--firmware ELF] [--script FILE] [--link PATH]`: a simulated
6-axis controller on a pty.

Prints the pseudo-terminal to open (first line of standard output, alone, for scripts) and runs
until Ctrl-C or --duration. It speaks the real protocol (firmware/PROTOCOL.md), so anything that
reads the board reads it: ``exhibit monitor --device controller=serial://PTY``, the kiosk, pyserial.
Without --firmware it is the protocol-level simulator (Python, instant); with it, the controller
firmware itself runs in simavr (exhibit/devices/simavr.py), so the exhibit meets the real ADC
scaling, timing, EEPROM and watchdog. Scripts are described in exhibit/devices/sim.py and
docs/DEVICES.md; with --firmware a deflection is a voltage on the pot (-1 = 0 V, 0 = 2.5 V, 1 =
5 V).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from exhibit.commands import _arg_types as _args
from exhibit.devices import protocol as p
from exhibit.devices.sim import SimController, parse_script
from exhibit.schema import read_text
from exhibit.errors import ExhibitError

if TYPE_CHECKING:
    from exhibit.devices.simavr import FirmwareController

HELP = "run a simulated controller on a pseudo-terminal (prints the tty path)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("device", choices=["controller"], help="what to simulate")
    parser.add_argument("--script", type=Path, help="a script of stick moves, buttons and faults")
    parser.add_argument(
        "--link",
        type=_link_arg,
        help="also make this symlink to the pty, a stable name that survives "
        "the script's unplug/replug (like /dev/serial/by-id/...)",
    )
    parser.add_argument(
        "--duration",
        type=_args.seconds(),
        default=None,
        help="stop after this many seconds (default: until Ctrl-C)",
    )
    parser.add_argument(
        "--firmware",
        type=Path,
        default=None,
        help="run this controller firmware (.elf, e.g. firmware/build/controller/"
        "controller.elf) in simavr instead of the protocol-level simulator",
    )
    parser.add_argument(
        "--harness",
        type=Path,
        default=None,
        help="the simavr harness (default: sim/harness beside the firmware's "
        "build, or firmware/build/sim/harness; make -C firmware sim)",
    )
    parser.add_argument(
        "--eeprom",
        type=Path,
        default=None,
        help="with --firmware: keep the EEPROM (the stored calibration) in this "
        "file across runs (default: erased at start)",
    )
    parser.add_argument(
        "--protocol-version",
        type=_args.integer(0, 255),
        default=p.PROTOCOL_VERSION,
        help="speak another protocol version (to check a host's refusal)",
    )


def _link_arg(text: str) -> Path:
    if text == "":  # Path("") would be "."
        raise argparse.ArgumentTypeError(
            "'': give the name of the symlink to make, e.g. /tmp/exhibit-controller"
        )
    return Path(text)


def check_link(link: Path | None) -> None:
    """ExhibitError unless ``link`` can be the stable symlink: a name in an existing folder, and
    nothing there but an old symlink (a file, folder, FIFO or device is never replaced by it)."""
    if link is None:
        return
    text = str(link)
    if text in ("", ".", "..") or text.endswith("/") or link.name in ("", ".", ".."):
        raise ExhibitError(
            f"--link {text!r}: give the name of the symlink to make, e.g. /tmp/exhibit-controller"
        )
    folder = link.parent
    if not folder.is_dir():
        what = "does not exist" if not folder.exists() else "is not a folder"
        raise ExhibitError(f"--link {link}: folder {folder} {what}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ExhibitError(f"--link {link}: folder {folder} is not writable")
    if link.is_symlink() or not os.path.lexists(link):
        return
    raise ExhibitError(
        f"--link {link}: something other than a symlink is there; refusing to replace it"
    )


def run(args: argparse.Namespace) -> int:
    check_link(args.link)
    script = None
    if args.script is not None:
        text = read_text(args.script)  # ConfigError names the file: FIFO, size, encoding
        script = parse_script(text, str(args.script))
    if not 0 <= args.protocol_version <= 255:
        raise ExhibitError("--protocol-version must be 0..255")
    if args.firmware is None:
        if args.harness is not None or args.eeprom is not None:
            raise ExhibitError("--harness and --eeprom go with --firmware")
        sim: SimController | FirmwareController = SimController(
            args.link, script=script, version=args.protocol_version
        )
    else:
        if args.protocol_version != p.PROTOCOL_VERSION:
            raise ExhibitError(
                "--protocol-version: the firmware speaks the version it was built "
                "with; leave out --firmware to simulate another"
            )
        from exhibit.devices.simavr import FirmwareController

        sim = FirmwareController(
            args.firmware, args.link, harness=args.harness, eeprom=args.eeprom, script=script
        )
    sim.start()
    try:
        print(sim.tty, flush=True)
        print(
            f"simulated controller on {sim.tty} (stable name {sim.link}); Ctrl-C stops it",
            file=sys.stderr,
            flush=True,
        )
        start = time.monotonic()
        while args.duration is None or time.monotonic() - start < args.duration:
            time.sleep(0.05)
            error = getattr(sim, "error", None)  # a firmware run's failure
            if error is not None:
                raise error
    except KeyboardInterrupt:
        pass
    finally:
        sim.stop()
    return 0
