"""`exhibit decode --protocol controller [FILE|-]`: captured controller bytes as JSON lines.

One line per frame or rejected chunk, in order, then
``{"summary": {"frames_ok": N, "rejected": N, "bytes_skipped": N}}``. For installers checking a
board (``cat /dev/ttyUSB0 > capture.bin``) and for fuzzing the decoder from the shell. The input
is read in blocks, so a capture of any size decodes in constant memory.
"""

from __future__ import annotations

import argparse
import json
import sys

from exhibit.devices import protocol as p
from exhibit.errors import ExhibitError

HELP = "decode captured controller bytes to JSON lines (one per frame, then a summary)"
BLOCK = 1 << 16


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--protocol",
        choices=["controller"],
        default="controller",
        help="the wire protocol (firmware/PROTOCOL.md); only 'controller' so far",
    )
    parser.add_argument(
        "file", nargs="?", default="-", help="captured bytes; '-' or nothing reads standard input"
    )
    parser.add_argument(
        "--frames-only",
        action="store_true",
        help="leave out the lines of rejected chunks (the summary still counts them)",
    )


def run(args: argparse.Namespace) -> int:
    decoder = p.StreamDecoder()
    out = sys.stdout
    try:
        stream = sys.stdin.buffer if args.file == "-" else open(args.file, "rb")  # noqa: SIM115 - closed by the with below
    except OSError as exc:
        raise ExhibitError(f"cannot read {args.file}: {exc.strerror or exc}") from None
    with stream:
        while True:
            try:
                block = stream.read(BLOCK)
            except OSError as exc:
                raise ExhibitError(f"cannot read {args.file}: {exc.strerror or exc}") from None
            if not block:
                break
            lines = [
                json.dumps(item.to_dict())
                for item in decoder.feed(block)
                if not (args.frames_only and isinstance(item, p.Rejected))
            ]
            if lines:
                out.write("\n".join(lines) + "\n")
    # Bytes after the last delimiter are a frame still arriving when the capture stopped: not
    # counted, exactly as the firmware's receiver would not have counted them yet.
    out.write(json.dumps({"summary": decoder.summary()}) + "\n")
    return 0
