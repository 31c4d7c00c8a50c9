"""`exhibit stats [--db PATH] [--since DATE] [--json] [--plot FILE.png]`: what visitors do.

Reads the kiosk's session log (exhibit.operations.sessions) and reports, for a curator: sessions per
day and per hour of the day (the kiosk's local time when each session started, wherever the
report is made), the median session length (takeover to idle return, and to the last real
input), and the most-used scenes, inputs and languages (each counted once per session).
``--plot`` draws sessions per day and by hour as bar charts in a PNG, with matplotlib, which is
imported only then, so every other command stays quick to start.

Without --db it reads ``[sessions] path`` of the kiosk config, else sessions.db in the state
folder, then the service's /var/lib/exhibit. The database is opened read-only: a running kiosk
goes on writing. A date that is not a date, a path that is no sessions database (a FIFO, a
folder, another file) is one line on stderr and exit 2, never a traceback. Rows that no kiosk
writes (a start outside 2000..2200, a duration over a week or not finite, JSON lists too long or
nested: exhibit.operations.sessions.read_sessions) are left out of every figure and counted in the
report: "skipped N rows: why (count)", and "skipped" and "skipped_reasons" in --json.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import statistics
import sys
from collections import Counter
from pathlib import Path

from exhibit.errors import ExhibitError
from exhibit.operations.health import format_duration
from exhibit.operations.sessions import Session, candidate_paths, read_sessions

HELP = (
    "what visitors do: sessions per day and hour, median length, most-used scenes and "
    "inputs, from the kiosk's session log (--plot FILE.png for a curator's report)"
)
#: Scenes and inputs listed in the text report (JSON has them all).
TOP = 10
#: Days in a row filled in with zeros (closed days show as gaps); a longer span (a clock set
#: to 1970 before NTP) lists only the days with sessions.
MAX_FILLED_DAYS = 3660
EPOCH = dt.date(1970, 1, 1)


def date_arg(text: str) -> dt.date:
    try:
        return dt.date.fromisoformat(text.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a date (YYYY-MM-DD)") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--db",
        type=Path,
        metavar="PATH",
        help="the sessions database (default: [sessions] path of the kiosk "
        "config, else sessions.db in the state folder)",
    )
    parser.add_argument(
        "--config",
        metavar="FILE",
        help="kiosk site config naming the database (default: $EXHIBIT_CONFIG, "
        "else /etc/exhibit/kiosk.toml if it exists)",
    )
    parser.add_argument(
        "--since",
        type=date_arg,
        metavar="DATE",
        help="only sessions from this day on (YYYY-MM-DD, the kiosk's local date)",
    )
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument(
        "--plot",
        type=Path,
        metavar="FILE.png",
        help="also draw sessions per day and by hour of the day into a PNG",
    )


def run(args: argparse.Namespace) -> int:
    if args.plot is not None:
        if args.plot.suffix.lower() != ".png":
            raise ExhibitError(f"--plot: {args.plot} must end in .png")
        if not args.plot.parent.is_dir():
            raise ExhibitError(f"--plot: folder {args.plot.parent} does not exist")
    path = args.db if args.db is not None else _default_db(args.config)
    since = None if args.since is None else (args.since - EPOCH).days * 86400.0
    skipped: Counter = Counter()
    report = summarize(read_sessions(path, since, skipped))
    report = {
        "db": str(path),
        "since": None if args.since is None else args.since.isoformat(),
        **report,
        "skipped": sum(skipped.values()),
        "skipped_reasons": [{"reason": r["name"], "rows": r["sessions"]} for r in _ranked(skipped)],
    }
    if args.plot is not None:  # first: a reader that stops early (| head) still gets it
        plot(report, args.plot)
    if args.json:
        sys.stdout.write(json.dumps(report, indent=2, ensure_ascii=True, allow_nan=False) + "\n")
    else:
        print(text(report) + ("" if args.plot is None else f"\nplot: {args.plot}"))
    return 0


def skipped_line(report: dict) -> str | None:
    """ "skipped N rows: why (count); ..." for rows of the database that were not counted."""
    n = report.get("skipped", 0)
    if not n:
        return None
    why = "; ".join(f"{_printable(r['reason'])} ({r['rows']})" for r in report["skipped_reasons"])
    return f"skipped {n} row{'s' if n != 1 else ''}: {why}"


def _default_db(config_path: str | None) -> Path:
    from exhibit.kiosk.config import load_kiosk_config

    config = load_kiosk_config(config_path, check_linked=False).sessions
    if config.path is not None:
        return config.path
    paths = candidate_paths()
    return next((p for p in paths if p.exists()), paths[0])


# ---------------------------------------------------------------------- the arithmetic


def local_day(session: Session) -> dt.date:
    return EPOCH + dt.timedelta(days=int(session.local_start // 86400))


def local_hour(session: Session) -> int:
    return int(session.local_start // 3600) % 24


def _median(values: list[float]) -> float | None:
    return round(statistics.median(values), 3) if values else None


def _ranked(counter: Counter) -> list[dict]:
    return [
        {"name": name, "sessions": n}
        for name, n in sorted(counter.items(), key=lambda kv: (-kv[1], kv[0]))
    ]


def summarize(sessions: list[Session]) -> dict:
    """The report: per_day [{date, sessions}] from the first day to the last (days without a
    session included, as zeros), per_hour (24 counts, local hour of the start), the medians in
    seconds (None without sessions), and scenes, inputs and languages ranked by how many
    sessions used them."""
    days = Counter(local_day(s) for s in sessions)
    if days and (max(days) - min(days)).days < MAX_FILLED_DAYS:
        first = min(days)
        span = [first + dt.timedelta(days=i) for i in range((max(days) - first).days + 1)]
    else:
        span = sorted(days)
    hours = [0] * 24
    for s in sessions:
        hours[local_hour(s)] += 1
    return {
        "sessions": len(sessions),
        "first": span[0].isoformat() if span else None,
        "last": span[-1].isoformat() if span else None,
        "median_s": _median([s.duration_s for s in sessions]),
        "median_active_s": _median([s.active_s for s in sessions]),
        "per_day": [{"date": d.isoformat(), "sessions": days.get(d, 0)} for d in span],
        "per_hour": hours,
        "scenes": _ranked(Counter(name for s in sessions for name in set(s.scenes))),
        "inputs": _ranked(Counter(name for s in sessions for name in set(s.inputs))),
        "languages": _ranked(Counter(s.language for s in sessions)),
    }


# ---------------------------------------------------------------------- the outputs


def _printable(text: str) -> str:
    return "".join(c if c.isprintable() else "?" for c in str(text))


def text(report: dict) -> str:
    n = report["sessions"]
    lines = [
        f"{n} visitor session{'s' if n != 1 else ''}"
        + (f", {report['first']} .. {report['last']}" if n else "")
        + f" ({_printable(report['db'])})"
    ]
    skipped = skipped_line(report)
    if skipped:
        lines.append(skipped)
    if not n:
        return "\n".join(lines)
    lines.append(
        f"median length {format_duration(report['median_s'])} (takeover to idle "
        f"return); {format_duration(report['median_active_s'])} to the last input"
    )
    width = max(len(str(d["sessions"])) for d in report["per_day"])
    peak = max(d["sessions"] for d in report["per_day"]) or 1
    days = report["per_day"][-31:]
    lines.append("sessions per day" + (" (the last 31)" if len(report["per_day"]) > 31 else ""))
    lines += [
        f"  {d['date']}  {d['sessions']:>{width}}  {'#' * round(40 * d['sessions'] / peak)}"
        for d in days
    ]
    lines.append("sessions by hour of the day (local)")
    peak = max(report["per_hour"]) or 1
    lines += [
        f"  {h:02d}:00  {c:>{width}}  {'#' * round(40 * c / peak)}"
        for h, c in enumerate(report["per_hour"])
        if c
    ]
    for key, title in (("scenes", "scenes"), ("inputs", "inputs"), ("languages", "languages")):
        items = report[key][:TOP]
        if items:
            lines.append(f"{title} (sessions that used each)")
            lines += [f"  {i['sessions']:>{width}}  {_printable(i['name'])}" for i in items]
    return "\n".join(lines)


def plot(report: dict, path: Path) -> None:
    """Sessions per day and by hour as bars, in a PNG for a curator's report."""
    import matplotlib

    matplotlib.use("Agg")  # no display: a file only
    from matplotlib.dates import AutoDateLocator, ConciseDateFormatter
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 7), layout="constrained")
    by_day, by_hour = fig.subplots(2, 1)
    days = [dt.date.fromisoformat(d["date"]) for d in report["per_day"]]
    by_day.bar(days, [d["sessions"] for d in report["per_day"]], width=0.8, color="#3b6ea5")
    by_day.set_title("Visitor sessions per day")
    by_day.set_ylabel("sessions")
    by_day.yaxis.get_major_locator().set_params(integer=True)
    if not days:
        by_day.text(0.5, 0.5, "no sessions", ha="center", va="center", transform=by_day.transAxes)
    elif len(days) <= 14:  # a tick per day, named
        by_day.set_xticks(days, [d.strftime("%a %d %b") for d in days])
        by_day.set_xlim(days[0] - dt.timedelta(days=1), days[-1] + dt.timedelta(days=1))
    else:
        locator = AutoDateLocator()
        by_day.xaxis.set_major_locator(locator)
        by_day.xaxis.set_major_formatter(ConciseDateFormatter(locator))
    by_hour.bar(range(24), report["per_hour"], width=0.8, color="#a5683b")
    by_hour.set_title("Sessions by hour of the day (the kiosk's local time)")
    by_hour.set_xlabel("hour the session started")
    by_hour.set_ylabel("sessions")
    by_hour.set_xticks(range(0, 24, 2))
    by_hour.set_xlim(-0.6, 23.6)
    by_hour.yaxis.get_major_locator().set_params(integer=True)
    median = report["median_s"]
    n = report["sessions"]
    fig.suptitle(
        f"{n} visitor session{'s' if n != 1 else ''}"
        + (
            f", {report['first']} to {report['last']}, median length {format_duration(median)}"
            if median is not None
            else ""
        )
        + (f" ({report['skipped']} rows skipped)" if report.get("skipped") else "")
    )
    try:
        fig.savefig(path, format="png", dpi=100)
    except OSError as exc:
        raise ExhibitError(f"--plot: cannot write {path}: {exc.strerror or exc}") from None
