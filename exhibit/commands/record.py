"""`exhibit record FILE`: record what the configured devices send, for ``replay://FILE``.

Installers record a real visitor session at the exhibit; developers replay it at their desk, and
the tests replay it deterministically.
"""

from __future__ import annotations

import argparse
import time

from exhibit.commands import _arg_types as _args
from exhibit.commands._device_options import add_config_arguments, config_from_args
from exhibit.devices.hub import DeviceSet
from exhibit.devices.replay import Recorder

HELP = "record device events to a JSON-lines file (play it back with replay://FILE)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="where to write the recording (.jsonl)")
    add_config_arguments(parser)
    parser.add_argument(
        "--duration",
        type=_args.seconds(),
        default=None,
        help="stop after this many seconds (default: until Ctrl-C)",
    )


def run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    with DeviceSet(config) as devices:
        start = time.monotonic()
        rec = Recorder(args.file, config.devices, start)
        try:
            while args.duration is None or time.monotonic() - start < args.duration:
                rec.write(devices.poll())
                time.sleep(0.002)
        except KeyboardInterrupt:
            pass
        finally:
            rec.close()
    print(f"recorded {rec.count} events to {args.file}")
    return 0
