"""`exhibit status [--json] [--max-age S] [--max-lost S] [--file PATH] [--prometheus FILE]`: is
the kiosk alive, and what is it doing?

Reads the health file the running kiosk rewrites every second (exhibit.operations.health) and prints
a summary for staff: mode, scene, frame rate, devices (with how long a missing one has been
missing), uptime and how old the file is. The exit code is for monitoring scripts:

- 0: fresh, and every configured device connected or missing for at most --max-lost seconds;
- 1: stale, missing or broken (with a one-line reason; a FIFO, device or oversized file in its
  place is broken, and is refused without hanging);
- 2: a bad argument;
- 3: fresh, but a configured device has been missing for longer than --max-lost (default 60 s):
  ``lost`` (it was connected, then went away) or ``waiting`` (never connected since the kiosk
  started), named with how long on stderr. A file from an older kiosk, without the durations,
  never gives 3;
- with --prometheus FILE: 0 once the metrics file is written, whatever it says (the metrics are
  the product, and alerts come from them), 4 if it could not be written; 2 when FILE cannot be
  a metrics file at all: an empty or folder-like name ("", ".", "/"), or a folder, FIFO, device
  (/dev/null, /dev/full) or symlink in its place, which is never replaced.

Without --file it looks at $EXHIBIT_STATE_DIR (else the XDG state folder) and then at the
service's /var/lib/exhibit, so it works from a staff shell on the kiosk without sudo. Text from
the file is printed without control characters or escape sequences, so a tampered file cannot
drive the staff terminal.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

from exhibit.commands import _arg_types as _args
from exhibit.errors import ExhibitError
from exhibit.operations.health import (
    MISSING_STATES,
    DeviceHealth,
    Health,
    HealthError,
    candidate_paths,
    format_duration,
    freshness,
    missing_devices,
    read_health,
)
from exhibit.schema.files import UnsafePath, check_target, split_target

HELP = (
    "health summary of the running kiosk (exit 0 fresh, 1 stale, missing or broken, 3 a "
    "device missing for longer than --max-lost; --prometheus FILE: 0 once written)"
)
DEFAULT_MAX_AGE = 10.0
#: Seconds a configured device may be missing before status exits 3: a replug or a board's
#: reset takes a few seconds; a minute is a device someone has to look at.
DEFAULT_MAX_LOST = 60.0
EXIT_STALE = 1
EXIT_DEVICE_MISSING = 3
EXIT_METRICS_UNWRITTEN = 4
#: Terminal escape sequences, removed whole (parameters included): CSI (ESC [ or 8-bit 0x9B),
#: strings (OSC, DCS, SOS, PM, APC: ESC ] P X ^ _ up to BEL or ST) and two-byte ESC sequences.
_ESCAPES = re.compile(
    r"\x1b\[[0-?]*[ -/]*[@-~]?|\x9b[0-?]*[ -/]*[@-~]?"
    r"|\x1b[]PX^_].*?(?:\x07|\x1b\\|\x9c|$)|\x1b[ -/]*[0-~]?",
    re.S,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the health data as JSON, with path, age_s, fresh, reason and devices_missing",
    )
    parser.add_argument(
        "--max-age",
        type=_args.seconds(),
        default=DEFAULT_MAX_AGE,
        metavar="S",
        help=f"seconds after which the file counts as stale (default "
        f"{DEFAULT_MAX_AGE:g}; the kiosk writes it every second)",
    )
    parser.add_argument(
        "--max-lost",
        type=_args.number(0, 1e7),
        default=DEFAULT_MAX_LOST,
        metavar="S",
        help=f"exit 3 when a configured device has been missing (lost, or "
        f"waiting: never connected since the start) for longer than S "
        f"seconds (default {DEFAULT_MAX_LOST:g})",
    )
    parser.add_argument(
        "--file",
        type=Path,
        metavar="PATH",
        help="read this health file instead of looking in the usual places",
    )
    parser.add_argument(
        "--prometheus",
        type=_metrics_file,
        metavar="FILE",
        help="write the health as Prometheus metrics to FILE (atomically; for "
        "node_exporter's textfile collector) instead of the summary; exit 0 "
        "once written, whatever the health, 4 if it cannot be written",
    )


def _metrics_file(text: str) -> Path:
    """--prometheus FILE: a file name, never "", "." or "dir/" (Path("") would be ".")."""
    try:
        split_target(text)
    except UnsafePath as exc:
        raise argparse.ArgumentTypeError(
            f"{printable(exc)}: give the metrics file to write, "
            "e.g. /var/lib/prometheus/node-exporter/exhibit.prom"
        ) from None
    return Path(text)


def run(args: argparse.Namespace) -> int:
    if args.prometheus is not None:
        try:
            check_target(args.prometheus)  # a FIFO, device or folder there: misuse, before reading
        except UnsafePath as exc:
            raise ExhibitError(f"--prometheus: {printable(exc)}") from None
    paths = [args.file] if args.file else candidate_paths()
    path = next((p for p in paths if p.exists()), paths[0])
    now = time.time()
    quiet = args.prometheus is not None  # a timer every 15 s: the file speaks, not the journal
    try:
        data = read_health(path)
    except HealthError as exc:
        why = str(exc)
        if exc.missing and len(paths) > 1:
            why = (
                f"no health file at {' or '.join(str(p) for p in paths)}: the kiosk is not "
                "running (systemctl status exhibit), or set EXHIBIT_STATE_DIR / --file"
            )
        if args.json:
            _print_json({"path": str(path), "fresh": False, "reason": why})
        if args.prometheus is not None:
            return _write_metrics(args.prometheus, None, "missing" if exc.missing else "broken")
        print(
            f"exhibit status: {'MISSING' if exc.missing else 'BROKEN'}: {printable(why)}",
            file=sys.stderr,
        )
        return EXIT_STALE
    fresh, age, reason = freshness(data, args.max_age, now=now)
    missing = missing_devices(data, args.max_lost, age) if fresh else []
    if args.json:
        _print_json(
            {
                **data.as_dict(),
                "path": str(path),
                "age_s": round(age, 3),
                "fresh": fresh,
                "reason": reason,
                "devices_missing": missing,
            }
        )
    elif not quiet:
        print(summary(data, path, age, fresh, missing))
    if args.prometheus is not None:
        return _write_metrics(args.prometheus, data, "ok" if fresh else "stale", age)
    if not fresh:
        print(f"exhibit status: STALE: {printable(reason)}", file=sys.stderr)
        return EXIT_STALE
    if missing:
        print(
            "exhibit status: DEVICE MISSING: "
            + "; ".join(printable(_missing_text(m, args.max_lost)) for m in missing),
            file=sys.stderr,
        )
        return EXIT_DEVICE_MISSING
    return 0


def _missing_text(m: dict, max_lost: float) -> str:
    how = "waiting (never connected since the start)" if m["state"] == "waiting" else m["state"]
    return (
        f"{m['device']} ({m['url']}) {how} for {format_duration(m['missing_s'])} "
        f"(more than {max_lost:g} s)"
    )


def _write_metrics(target: Path, data: Health | None, status: str, age: float | None = None) -> int:
    from exhibit.operations.prometheus import write_metrics

    try:
        write_metrics(target, data, status, age)
    except UnsafePath as exc:  # swapped in since run() checked it
        print(f"exhibit status: cannot write the metrics file: {printable(exc)}", file=sys.stderr)
        return EXIT_METRICS_UNWRITTEN
    except OSError as exc:
        why = exc.strerror or str(exc)
        hint = (
            ": is node_exporter (prometheus-node-exporter) installed?"
            if isinstance(exc, FileNotFoundError)
            else ""
        )
        print(
            f"exhibit status: cannot write the metrics file {printable(target)}: "
            f"{printable(why)}{hint}",
            file=sys.stderr,
        )
        return EXIT_METRICS_UNWRITTEN
    return 0


def summary(
    data: Health, path: Path, age: float, fresh: bool, missing: list[dict] | None = None
) -> str:
    """The staff-facing text: one header line, then one aligned line per topic."""

    def get(key, fmt="{}"):
        value = getattr(data, key)
        return "?" if value is None else printable(fmt.format(value))

    head = "STALE" if not fresh else "DEVICE MISSING" if missing else "OK"
    updated = format_duration(max(age, 0.0))
    lines = [f"exhibit kiosk: {head} (updated {updated} ago, pid {get('pid')})"]
    uptime = data.uptime_s
    rows = [
        ("mode", get("mode")),
        ("scene", get("scene")),
        (
            "fps",
            f"{get('fps', '{:.1f}')} (95% of frames within {get('frame_ms_p95', '{:.1f}')} ms)",
        ),
        ("uptime", "?" if uptime is None else format_duration(float(uptime))),
    ]
    if data.quality is not None:
        rows.append(("quality", quality_line(data)))
    if isinstance(data.frame_passes, dict):
        rows.append(("passes", passes_line(data.frame_passes)))
    narration = data.narration
    if isinstance(narration, dict):
        rows.append(("narration", narration_line(narration)))
    devices = data.devices or []
    if devices:
        urls = [printable(d.url) for d in devices]
        width = max(map(len, urls))
        for i, (url, device) in enumerate(zip(urls, devices)):
            rows.append(
                (
                    "devices" if i == 0 else "",
                    f"{url:<{width}}  {printable(device.state)}{_how_long(device, age)}",
                )
            )
    else:
        rows.append(("devices", "none"))
    failed = [f for f in (data.scenes_failed or []) if isinstance(f, dict)]
    problems = [p for p in (data.problems or []) if isinstance(p, str)]
    for i, problem in enumerate(problems[:20]):
        rows.append(("problems" if i == 0 else "", printable(problem)[:300]))
    if failed and not problems:
        rows.append(
            (
                "problems",
                f"{len(failed)} scene(s) failed: "
                + printable(", ".join(str(f.get("scene")) for f in failed)),
            )
        )
    rows.append(("frames", f"{get('frames')} drawn, {get('frame_errors')} failed"))
    rss = data.rss_kb
    rows.append(
        (
            "process",
            f"{get('gl_errors')} GL errors, "
            f"{'?' if rss is None else f'{rss / 1024:.0f} MB'} resident, "
            f"{get('fds')} open files",
        )
    )
    rows.append(("file", printable(path)))
    lines += [f"  {name:<8}  {value}" for name, value in rows]
    return "\n".join(lines)


def _how_long(device: DeviceHealth, age: float) -> str:
    """ " for 3 min 5 s (never connected)" for a missing device whose kiosk knows how long."""
    missing = device.missing_s
    if device.state not in MISSING_STATES or missing is None:
        return ""
    text = f" for {format_duration(float(missing) + max(age, 0.0))}"
    return text + " (never connected)" if device.state == "waiting" else text


def quality_line(data: Health) -> str:
    """The frame governor's level, e.g. ``scale-50 (level 6 of 6, auto; fxaa, mesh x0.5, lean,
    scale 0.5), frames 19.1 ms for a 16.7 ms target``; whatever is missing or odd shows as ?."""
    detail = data.quality_detail
    detail = detail if isinstance(detail, dict) else {}

    def num(value, fmt):
        return (
            fmt.format(value)
            if isinstance(value, (int, float)) and not isinstance(value, bool)
            else "?"
        )

    mesh = detail.get("mesh")
    factor = {0: "1", 1: "0.75", 2: "0.5"}.get(mesh, "?") if isinstance(mesh, int) else "?"
    how = "pinned" if detail.get("pinned") is True else "auto"
    parts = [
        printable(detail.get("antialiasing", "?")),
        f"mesh x{factor}",
        printable(detail.get("effects", "?")),
        f"scale {num(detail.get('render_scale'), '{:g}')}",
    ]
    return (
        f"{printable(data.quality)} (level {num(detail.get('level'), '{}')} of "
        f"{num(detail.get('levels'), '{}')}, {how}; {', '.join(parts)}), frames "
        f"{num(data.frame_ms, '{:.1f}')} ms for a {num(data.target_ms, '{:.1f}')}"
        " ms target"
    )


def printable(text: object) -> str:
    """``text`` as one line safe for a terminal: escape sequences and every other control or
    invisible formatting character (C0, DEL, C1, bidi overrides) removed, and tabs and line
    breaks turned into spaces."""
    return "".join(
        c if c.isprintable() else " " if c.isspace() else "" for c in _ESCAPES.sub("", str(text))
    )


def _print_json(obj: dict) -> None:
    """JSON with every non-ASCII and control character escaped (ensure_ascii), so it is valid
    and inert on a terminal; read_health has already refused NaN and infinities."""
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=True, ensure_ascii=True) + "\n")


#: At most this many passes on the status line (a damaged file may list thousands).
MAX_PASSES = 16


def passes_line(passes: dict) -> str:
    """ "direct, 4 s ago: background 3.1, surfaces 5.2, ..., other 0.3 ms; frame 17.5 ms" from
    the health file's frame_passes (any value may be missing or odd: shown as ?)."""

    def ms(value: object) -> str:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        return f"{value:.1f}" if ok else "?"

    times = passes.get("passes_ms")
    times = times if isinstance(times, dict) else {}
    parts = [f"{printable(name)[:40]} {ms(value)}" for name, value in times.items()][:MAX_PASSES]
    parts.append(f"other {ms(passes.get('other_ms'))}")
    age = passes.get("age_s")
    when = f"{ms(age)} s ago" if isinstance(age, (int, float)) else "? s ago"
    return (
        f"{printable(passes.get('level', '?'))[:40]}, {when}: {', '.join(parts)} ms; "
        f"frame {ms(passes.get('total_ms'))} ms"
    )


def narration_line(narration: dict) -> str:
    """ "on, speaking …; sound: ok (default)" from the health file's narration (any of its
    values may be missing or of the wrong type: an older or damaged file)."""
    on = "on" if narration.get("on") is True else "off"
    if narration.get("attract") is True:
        on += " (attract mode speaks)"
    speaking = narration.get("speaking")
    if isinstance(speaking, str):
        on += f", speaking {printable(speaking)}"
    player = narration.get("player")
    player = player if isinstance(player, dict) else {}
    state = printable(str(player.get("state", "?")))
    device = player.get("device")
    where = printable(str(device)) if isinstance(device, str) and device else "default output"
    line = f"{on}; sound: {state} ({where})"
    error = player.get("error")
    if isinstance(error, str) and error:
        line += f": {printable(error)[:200]}"
    failed = narration.get("failed")
    if isinstance(failed, list) and failed:
        line += f"; {len(failed)} segment(s) cannot be spoken"
    return line
