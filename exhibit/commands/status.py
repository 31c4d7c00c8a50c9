"""`exhibit status [--json] [--max-age S] [--file PATH]`: is the kiosk alive, and what is it doing?

Reads the health file the running kiosk rewrites every second (exhibit.kiosk.health) and prints
a summary for staff: mode, scene, frame rate, devices, uptime and how old the file is. The exit
code is for monitoring scripts: 0 fresh, 1 stale or missing (with a one-line reason), 2 a bad
argument. Without --file it looks at $EXHIBIT_STATE_DIR (else the XDG state folder) and then at
the service's /var/lib/exhibit, so it works from a staff shell on the kiosk without sudo.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from exhibit.errors import ExhibitError
from exhibit.kiosk.health import (HealthError, candidate_paths, format_duration, freshness,
                                  read_health)

HELP = "health summary of the running kiosk (exit 0 fresh, 1 stale or missing)"
DEFAULT_MAX_AGE = 10.0


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
        print(f"exhibit status: {'MISSING' if exc.missing else 'BROKEN'}: {reason}",
              file=sys.stderr)
        return 1
    fresh, age, reason = freshness(data, args.max_age, now=now)
    if args.json:
        _print_json({**data, "path": str(path), "age_s": round(age, 3), "fresh": fresh,
                     "reason": reason})
    else:
        print(summary(data, path, age, fresh))
    if not fresh:
        print(f"exhibit status: STALE: {reason}", file=sys.stderr)
        return 1
    return 0


def summary(data: dict, path: Path, age: float, fresh: bool) -> str:
    """The staff-facing text: one header line, then one aligned line per topic."""
    def get(key, fmt="{}"):
        value = data.get(key)
        return "?" if value is None else fmt.format(value)

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
        width = max(len(d["url"]) for d in devices)
        for i, device in enumerate(devices):
            rows.append(("devices" if i == 0 else "",
                         f"{device['url']:<{width}}  {device['state']}"))
    else:
        rows.append(("devices", "none"))
    rss = data.get("rss_kb")
    rows.append(("process", f"{get('gl_errors')} GL errors, "
                            f"{'?' if rss is None else f'{rss / 1024:.0f} MB'} resident, "
                            f"{get('fds')} open files"))
    rows.append(("file", str(path)))
    lines += [f"  {name:<8}  {value}" for name, value in rows]
    return "\n".join(lines)


def _print_json(obj: dict) -> None:
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=True) + "\n")
