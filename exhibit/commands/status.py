"""`exhibit status [--json] [--max-age S] [--file PATH]`: is the kiosk alive, and what is it doing?

Reads the health file the running kiosk rewrites every second (exhibit.kiosk.health) and prints
a summary for staff: mode, scene, frame rate, devices, uptime and how old the file is. The exit
code is for monitoring scripts: 0 fresh, 1 stale, missing or broken (with a one-line reason; a
FIFO, device or oversized file in its place is broken, and is refused without hanging), 2 a bad
argument. Without --file it looks at $EXHIBIT_STATE_DIR (else the XDG state folder) and then at
the service's /var/lib/exhibit, so it works from a staff shell on the kiosk without sudo. Text
from the file is printed without control characters or escape sequences, so a tampered file
cannot drive the staff terminal.
"""

from __future__ import annotations

import json
import math
import re
import sys
import time
from pathlib import Path

from exhibit.errors import ExhibitError
from exhibit.kiosk.health import (HealthError, candidate_paths, format_duration, freshness,
                                  read_health)

HELP = "health summary of the running kiosk (exit 0 fresh, 1 stale, missing or broken)"
DEFAULT_MAX_AGE = 10.0
#: Terminal escape sequences, removed whole (parameters included): CSI (ESC [ or 8-bit 0x9B),
#: strings (OSC, DCS, SOS, PM, APC: ESC ] P X ^ _ up to BEL or ST) and two-byte ESC sequences.
_ESCAPES = re.compile(r"\x1b\[[0-?]*[ -/]*[@-~]?|\x9b[0-?]*[ -/]*[@-~]?"
                      r"|\x1b[]PX^_].*?(?:\x07|\x1b\\|\x9c|$)|\x1b[ -/]*[0-~]?", re.S)


def add_arguments(parser) -> None:
    parser.add_argument("--json", action="store_true",
                        help="print the health data as JSON, with path, age_s, fresh and reason")
    parser.add_argument("--max-age", type=float, default=DEFAULT_MAX_AGE, metavar="S",
                        help=f"seconds after which the file counts as stale (default "
                             f"{DEFAULT_MAX_AGE:g}; the kiosk writes it every second)")
    parser.add_argument("--file", type=Path, metavar="PATH",
                        help="read this health file instead of looking in the usual places")


def run(args) -> int:
    if not (math.isfinite(args.max_age) and args.max_age > 0):
        raise ExhibitError(f"--max-age must be a positive number of seconds, got {args.max_age:g}")
    paths = [args.file] if args.file else candidate_paths()
    path = next((p for p in paths if p.exists()), paths[0])
    now = time.time()
    try:
        data = read_health(path)
    except HealthError as exc:
        reason = str(exc)
        if exc.missing and len(paths) > 1:
            reason = (f"no health file at {' or '.join(str(p) for p in paths)}: the kiosk is not "
                      "running (systemctl status exhibit), or set EXHIBIT_STATE_DIR / --file")
        if args.json:
            _print_json({"path": str(path), "fresh": False, "reason": reason})
        print(f"exhibit status: {'MISSING' if exc.missing else 'BROKEN'}: {printable(reason)}",
              file=sys.stderr)
        return 1
    fresh, age, reason = freshness(data, args.max_age, now=now)
    if args.json:
        _print_json({**data, "path": str(path), "age_s": round(age, 3), "fresh": fresh,
                     "reason": reason})
    else:
        print(summary(data, path, age, fresh))
    if not fresh:
        print(f"exhibit status: STALE: {printable(reason)}", file=sys.stderr)
        return 1
    return 0


def summary(data: dict, path: Path, age: float, fresh: bool) -> str:
    """The staff-facing text: one header line, then one aligned line per topic."""
    def get(key, fmt="{}"):
        value = data.get(key)
        return "?" if value is None else printable(fmt.format(value))

    head = "OK" if fresh else "STALE"
    updated = format_duration(max(age, 0.0))
    lines = [f"exhibit kiosk: {head} (updated {updated} ago, pid {get('pid')})"]
    uptime = data.get("uptime_s")
    rows = [
        ("mode", get("mode")),
        ("scene", get("scene")),
        ("fps", f"{get('fps', '{:.1f}')} "
                f"(95% of frames within {get('frame_ms_p95', '{:.1f}')} ms)"),
        ("uptime", "?" if uptime is None else format_duration(float(uptime))),
    ]
    devices = data.get("devices") or []
    if devices:
        urls = [printable(d["url"]) for d in devices]
        width = max(map(len, urls))
        for i, (url, device) in enumerate(zip(urls, devices)):
            rows.append(("devices" if i == 0 else "",
                         f"{url:<{width}}  {printable(device['state'])}"))
    else:
        rows.append(("devices", "none"))
    failed = [f for f in (data.get("scenes_failed") or []) if isinstance(f, dict)]
    problems = [p for p in (data.get("problems") or []) if isinstance(p, str)]
    for i, problem in enumerate(problems[:20]):
        rows.append(("problems" if i == 0 else "", printable(problem)[:300]))
    if failed and not problems:
        rows.append(("problems", f"{len(failed)} scene(s) failed: "
                                 + printable(", ".join(str(f.get("scene")) for f in failed))))
    rows.append(("frames", f"{get('frames')} drawn, {get('frame_errors')} failed"))
    rss = data.get("rss_kb")
    rows.append(("process", f"{get('gl_errors')} GL errors, "
                            f"{'?' if rss is None else f'{rss / 1024:.0f} MB'} resident, "
                            f"{get('fds')} open files"))
    rows.append(("file", printable(path)))
    lines += [f"  {name:<8}  {value}" for name, value in rows]
    return "\n".join(lines)


def printable(text) -> str:
    """``text`` as one line safe for a terminal: escape sequences and every other control or
    invisible formatting character (C0, DEL, C1, bidi overrides) removed, and tabs and line
    breaks turned into spaces."""
    return "".join(c if c.isprintable() else " " if c.isspace() else ""
                   for c in _ESCAPES.sub("", str(text)))


def _print_json(obj: dict) -> None:
    """JSON with every non-ASCII and control character escaped (ensure_ascii), so it is valid
    and inert on a terminal; read_health has already refused NaN and infinities."""
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=True, ensure_ascii=True) + "\n")
