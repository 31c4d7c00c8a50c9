"""`exhibit status [--json] [--max-age S] [--max-lost S] [--file PATH] [--prometheus FILE]`: is
the kiosk alive, and what is it doing?

Reads the health file the running kiosk rewrites every second (exhibit.operations.health) and prints
a summary for staff: mode, scene, frame rate, the version and release that run, devices (with how
long a missing one has been missing), problems, the state folder's free space, uptime, and the
file read with its owner and age. The exit code is for monitoring scripts (the issues judged by
exhibit.operations.assessment; with several, the first in this order: 1, 5, 3, 6), each issue
on stderr in one line:

- 0: fresh, drawing, and nothing below;
- 1: stale, missing or broken (a FIFO, device or oversized file in its place is broken, and is
  refused without hanging), or fresh but no frame drawn for --max-age (NOT DRAWING);
- 2: a bad argument;
- 3: a configured device has been missing for longer than --max-lost (default 60 s): ``lost``
  (it was connected, then went away) or ``waiting`` (never connected since the kiosk started),
  named with how long. A file from an older kiosk, without the durations, never gives 3;
- 5: the kiosk's state folder is full, read-only or not writable (STATE FOLDER FULL, ...): the
  kiosk says so, or a write there failed with ENOSPC, EROFS or EACCES; or its health file is
  old but its process runs and the folder is full or read-only as seen from here;
- 6: WARN: the kiosk names problems: scenes skipped (a scene that fails to prepare or draw), an
  attract timeline left out, frames failing;
- with --prometheus FILE: 0 once the metrics file is written, whatever it says (the metrics are
  the product, and alerts come from them), 4 if it could not be written; 2 when FILE cannot be
  a metrics file at all: an empty or folder-like name ("", ".", "/"), or a folder, FIFO, device
  (/dev/null, /dev/full) or symlink in its place, which is never replaced.

Without --file it reads the first that exists of $EXHIBIT_STATE_DIR's file, else the service's
/var/lib/exhibit and then the user's own state folder (exhibit.operations.health.candidate_paths),
so it works from a staff shell or root's on the kiosk without sudo and never prefers a file left
in root's home. Text from the file is printed without control characters or escape sequences,
so a tampered file cannot drive the staff terminal.

Why one module of this size: the summary is one screen for staff, and each of its lines
(quality, passes, narration, storage, release) reads a part of the file that an older or damaged
kiosk may have left odd, so each has its own careful formatter beside the others.
"""

from __future__ import annotations

import argparse
import json
import pwd
import re
import sys
import time
from pathlib import Path

from exhibit.commands import _arg_types as _args
from exhibit.commands._update_journal import owed_steps
from exhibit.commands.install import DEFAULT_PREFIX
from exhibit.errors import ExhibitError
from exhibit.operations.assessment import (
    EXIT_METRICS_UNWRITTEN,
    EXIT_STALE,
    EXIT_WARN,
    Assessment,
    Issue,
    assess,
    folder_issue,
)
from exhibit.operations.health import (
    MISSING_STATES,
    DeviceHealth,
    Health,
    HealthError,
    candidate_paths,
    format_duration,
    read_health,
)
from exhibit.operations.storage import format_bytes
from exhibit.schema.files import UnsafePath, check_target, split_target

HELP = (
    "health summary of the running kiosk (exit 0 OK, 1 stale, missing, broken or not drawing, "
    "3 a device missing for longer than --max-lost, 5 its state folder full or unwritable, "
    "6 scenes skipped, an update left unfinished or other problems; --prometheus FILE: 0 once "
    "written)"
)
DEFAULT_MAX_AGE = 10.0
#: The head of the line for an update or rollback that stopped half-way (exit 6, as a warning:
#: the kiosk may draw well, but it runs a release that was not installed or restarted into).
UNFINISHED = "UPDATE UNFINISHED"
#: Seconds a configured device may be missing before status exits 3: a replug or a board's
#: reset takes a few seconds; a minute is a device someone has to look at.
DEFAULT_MAX_LOST = 60.0
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
        "--prefix",
        type=Path,
        default=Path(DEFAULT_PREFIX),
        metavar="DIR",
        help=f"the install prefix whose interrupted update or rollback to report "
        f"(default {DEFAULT_PREFIX})",
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
    others = [p for p in paths if p != path and p.exists()]
    now = time.time()
    quiet = args.prometheus is not None  # a timer every 15 s: the file speaks, not the journal
    owed = [] if quiet else owed_steps(args.prefix)
    try:
        data = read_health(path)
    except HealthError as exc:
        return _unread(args, exc, path, paths, now, owed)
    verdict = assess(data, path, args.max_age, args.max_lost, now)
    if owed:  # after the kiosk's own issues: they say more about what a visitor sees
        verdict.issues.append(Issue(EXIT_WARN, UNFINISHED, "; ".join(owed)))
    file = file_info(path, now)
    if args.json:
        _print_json(
            {
                **data.as_dict(),
                "path": str(path),
                **file,
                "age_s": round(verdict.age, 3),
                "fresh": verdict.fresh,
                "up": verdict.up,
                "health": verdict.status,
                "reason": verdict.reason,
                "issues": [
                    {"exit": i.code, "head": i.head, "text": i.text} for i in verdict.issues
                ],
                "exit": verdict.exit_code,
                "devices_missing": verdict.missing,
                "update_owed": owed,
            }
        )
    elif not quiet:
        print(summary(data, path, verdict, file, others))
    if args.prometheus is not None:
        return _write_metrics(args.prometheus, data, verdict)
    for issue in verdict.issues:
        print(f"exhibit status: {issue.head}: {printable(issue.text)}", file=sys.stderr)
    return verdict.exit_code


def _unread(
    args: argparse.Namespace,
    exc: HealthError,
    path: Path,
    paths: list[Path],
    now: float,
    owed: list[str],
) -> int:
    """No health file, or one that cannot be read: exit 1, naming the file (its owner and age
    when there is one) and, when it is full or read-only, the folder."""
    why = str(exc)
    if exc.missing and len(paths) > 1:
        why = (
            f"no health file at {' or '.join(str(p) for p in paths)}: the kiosk is not "
            "running (systemctl status exhibit), or set EXHIBIT_STATE_DIR / --file"
        )
    elif not exc.missing:
        file = file_info(path, now)
        if file.get("owner") is not None:
            why += f" (owner {file['owner']}, modified {format_duration(file['file_age_s'])} ago)"
    seen, trouble = folder_issue(path.parent)
    if trouble is not None:
        why += f"; {trouble}"
    status = "missing" if exc.missing else "broken"
    if args.json:
        _print_json(
            {
                "path": str(path),
                "fresh": False,
                "up": False,
                "health": status,
                "reason": why,
                "exit": EXIT_STALE,
                "update_owed": owed,
            }
        )
    if args.prometheus is not None:
        return _write_metrics(args.prometheus, None, Assessment(status, 0.0, folder=seen))
    print(f"exhibit status: {status.upper()}: {printable(why)}", file=sys.stderr)
    if owed:  # a kiosk that is not running may be what the stopped update left
        print(f"exhibit status: {UNFINISHED}: {printable('; '.join(owed))}", file=sys.stderr)
    return EXIT_STALE


def file_info(path: Path, now: float) -> dict:
    """{"owner", "file_age_s"} of the file read: its owner's name (else uid), and the seconds
    since it was last modified; both None when it cannot be looked at."""
    try:
        info = path.stat()
    except OSError:
        return {"owner": None, "file_age_s": None}
    try:
        owner = pwd.getpwuid(info.st_uid).pw_name
    except KeyError:
        owner = str(info.st_uid)
    return {"owner": owner, "file_age_s": round(max(0.0, now - info.st_mtime), 3)}


def _write_metrics(target: Path, data: Health | None, verdict: Assessment) -> int:
    from exhibit.operations.prometheus import write_metrics

    try:
        write_metrics(
            target, data, verdict.status, None if data is None else verdict.age, verdict.folder
        )
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


def preparing_rows(data: Health) -> list[tuple[str, str]]:
    """The scene being prepared, and how long a visitor has waited for it, if one does."""
    if data.preparing is None:
        return []
    waited = data.waiting_s
    line = printable(data.preparing)
    return [
        ("preparing", line if waited is None else f"{line} (a visitor has waited {waited:.0f} s)")
    ]


def summary(
    data: Health,
    path: Path,
    verdict: Assessment,
    file: dict | None = None,
    others: list[Path] | None = None,
) -> str:
    """The staff-facing text: one header line, then one aligned line per topic."""

    def get(key, fmt="{}"):
        value = getattr(data, key)
        return "?" if value is None else printable(fmt.format(value))

    age = verdict.age
    updated = format_duration(max(age, 0.0))
    lines = [f"exhibit kiosk: {verdict.head} (updated {updated} ago, pid {get('pid')})"]
    uptime = data.uptime_s
    rows = [
        ("mode", get("mode")),
        ("scene", get("scene")),
        *preparing_rows(data),
        (
            "fps",
            f"{get('fps', '{:.1f}')} (95% of frames within {get('frame_ms_p95', '{:.1f}')} ms)",
        ),
        ("uptime", "?" if uptime is None else format_duration(float(uptime))),
        *release_rows(data),
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
    last = data.last_frame
    drawn = f"{get('frames')} drawn, {get('frame_errors')} failed"
    if isinstance(last, (int, float)) and data.has("last_frame"):
        drawn += f", the last {format_duration(max(0.0, data.time - last) + max(age, 0.0))} ago"
    rows.append(("frames", drawn))
    rss = data.rss_kb
    rows.append(
        (
            "process",
            f"{get('gl_errors')} GL errors, "
            f"{'?' if rss is None else f'{rss / 1024:.0f} MB'} resident, "
            f"{get('fds')} open files",
        )
    )
    if isinstance(data.storage, dict):
        rows.append(("storage", storage_line(data.storage, verdict)))
    rows.append(("file", file_line(path, file)))
    for other in others or []:
        rows.append(("", f"also {printable(other)} (read it with --file)"))
    lines += [f"  {name:<8}  {value}" for name, value in rows]
    return "\n".join(lines)


def release_rows(data: Health) -> list[tuple[str, str]]:
    """The "version" row: the running version and release (exhibit.operations.storage). An
    update that stopped half-way is an issue of its own (UNFINISHED, in run())."""
    if data.version is None and data.release is None:
        return []
    return [("version", f"{get_text(data.version)} (release {get_text(data.release)})")]


def get_text(value: object) -> str:
    return "?" if value is None else printable(value)[:200]


def storage_line(info: dict, verdict: Assessment) -> str:
    """ "/var/lib/exhibit: 12.3 GiB free" or "... FULL (0 B free); failed writes: sessions
    (ENOSPC)" from the health file's storage."""
    free = info.get("free_bytes")
    room = (
        f"{format_bytes(free)} free"
        if isinstance(free, int) and not isinstance(free, bool)
        else "free space ?"
    )
    text = f"{get_text(info.get('folder'))}: {room}"
    if verdict.folder_problem is not None:
        text += f", {verdict.folder_problem.upper()}"
    errors = info.get("errors")
    if isinstance(errors, dict) and errors:
        text += "; failed writes: " + ", ".join(
            f"{printable(k)[:40]} ({printable(v)[:40]})" for k, v in list(errors.items())[:8]
        )
    return text


def file_line(path: Path, file: dict | None) -> str:
    """ "/var/lib/exhibit/health.json (owner exhibit, modified 0.6 s ago)"."""
    text = printable(path)
    if file and file.get("owner") is not None:
        text += (
            f" (owner {printable(file['owner'])}, modified "
            f"{format_duration(file['file_age_s'])} ago)"
        )
    return text


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
