"""`exhibit bench startup`: process start to the kiosk's first frame, timed by the kiosk's own
READY=1 (sent after the first frame) on a private NOTIFY_SOCKET, and to its log line saying every
scene is prepared (exhibit.preparing.preparing: the rest arrive while the first plays). One cold run
fills a fresh mesh cache; the warm runs are what a restart by the watchdog costs. Baselines in
the same run: a bare interpreter, and the interpreter importing the kiosk's modules; the goals
(docs/PERFORMANCE.md) are ratios to them."""

from __future__ import annotations

import argparse
import json
import os
import platform
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from exhibit.errors import ExhibitError

HELP = "time from process start to the kiosk's first frame (warm mesh cache), with baselines"
#: The kiosk's log line when its last scene is prepared (exhibit.kiosk.content.Content.collect).
PREPARED = "every scene is prepared"
#: Goals of issue 23: warm start / imports baseline, and cold start / warm start.
WARM_GOAL, COLD_GOAL = 2.5, 2.5


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="kiosk config (default: the shipped one)")
    parser.add_argument(
        "--repeat",
        type=int,
        default=3,
        help="rounds (baselines, a cold and a warm start each); medians count",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def _time_command(args: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(args, check=True, capture_output=True)
    return time.perf_counter() - start


def _time_to_ready(
    config: str | None, env: dict, folder: Path, timeout: float = 600
) -> tuple[float, float | None]:
    """Seconds from start to READY=1 and to the log line PREPARED (None if it never came)."""
    address = str(folder / f"notify-{time.monotonic_ns()}.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind(address)
    server.settimeout(0.5)
    command = [sys.executable, "-m", "exhibit", "run", "--windowed", "--duration", "600"]
    if config:
        command += ["--config", config]
    start = time.perf_counter()
    child = subprocess.Popen(
        command,
        env=dict(env, NOTIFY_SOCKET=address),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    stderr = child.stderr
    assert stderr is not None  # stderr=PIPE
    lines: list[str] = []
    prepared = threading.Event()
    when: list[float] = []

    def read() -> None:
        for line in stderr:
            lines.append(line)
            if PREPARED in line and not prepared.is_set():
                when.append(time.perf_counter() - start)
                prepared.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        ready = None
        while ready is None and time.perf_counter() - start < timeout:
            try:
                message = server.recv(4096).decode()
            except TimeoutError:
                if child.poll() is not None:
                    reader.join(timeout=5)
                    raise ExhibitError(
                        "the kiosk exited before its first frame: "
                        + ([s.strip() for s in lines if s.strip()] or ["?"])[-1]
                    ) from None
                continue
            if "READY=1" in message:
                ready = time.perf_counter() - start
        if ready is None:
            raise ExhibitError(f"no first frame within {timeout:.0f} s")
        prepared.wait(timeout=max(0.0, timeout - (time.perf_counter() - start)))
        return ready, (when[0] if when else None)
    finally:
        child.terminate()
        try:
            child.wait(timeout=30)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
        reader.join(timeout=5)
        stderr.close()
        server.close()


def run(args: argparse.Namespace) -> int:
    if not 1 <= args.repeat <= 100:
        raise ExhibitError(
            f"--repeat {args.repeat}: give 1 to 100 rounds (each is a cold and "
            "a warm start, seconds to a minute)"
        )
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ExhibitError(
            "the kiosk needs a display; on a headless machine run "
            "`xvfb-run -a exhibit bench startup`"
        )
    imports_command = [
        sys.executable,
        "-c",
        "import exhibit.kiosk.app, exhibit.render.window, exhibit.commands.run",
    ]
    interpreter: list[float] = []
    imports: list[float] = []
    cold: list[float] = []
    warm: list[float] = []
    cold_prepared: list[float | None] = []
    warm_prepared: list[float | None] = []
    # Rounds of every variant in turn, so a busy moment of the machine hits them all alike: the
    # ratios hold on a noisy machine where the absolute times do not.
    for round_ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            env = dict(
                os.environ,
                EXHIBIT_CACHE_DIR=str(folder / "cache"),
                EXHIBIT_STATE_DIR=str(folder / "state"),
            )
            env.pop("WATCHDOG_USEC", None)
            print(
                f"round {round_ + 1}/{args.repeat}: baselines, cold start (an empty mesh "
                "cache), warm start...",
                file=sys.stderr,
            )
            interpreter.append(_time_command([sys.executable, "-c", "pass"]))
            imports.append(_time_command(imports_command))
            ready, prepared = _time_to_ready(args.config, env, folder)
            cold.append(ready)
            cold_prepared.append(prepared)
            ready, prepared = _time_to_ready(args.config, env, folder)
            warm.append(ready)
            warm_prepared.append(prepared)
    median = statistics.median
    # rounded as reported, so the ratios printed are those of the times printed
    interpreter_s, imports_s = round(median(interpreter), 3), round(median(imports), 3)
    machine = f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
    cold_s, warm_s = round(median(cold), 3), round(median(warm), 3)
    cold_runs, warm_runs = [round(c, 3) for c in cold], [round(w, 3) for w in warm]
    prepared_s = {"cold": _median(cold_prepared), "warm": _median(warm_prepared)}
    ratios = {
        "warm_to_imports": round(warm_s / imports_s, 2),
        "cold_to_warm": round(cold_s / warm_s, 2),
    }
    goals_met = ratios["warm_to_imports"] <= WARM_GOAL and ratios["cold_to_warm"] <= COLD_GOAL
    if args.json:
        report = {
            "machine": machine,
            "cold_s": cold_s,
            "warm_s": warm_s,
            "cold_runs_s": cold_runs,
            "warm_runs_s": warm_runs,
            "prepared_s": prepared_s,
            "baseline": {
                "interpreter_s": round(interpreter_s, 3),
                "imports_s": round(imports_s, 3),
            },
            "ratios": ratios,
            "goals_met": goals_met,
        }
        print(json.dumps(report, indent=2))
        return 0
    print(f"start to first frame on {machine}:")
    print(
        f"  cold (empty mesh cache, median of {args.repeat}): {cold_s:.2f} s  "
        f"(runs: {', '.join(f'{c:.2f}' for c in cold_runs)})"
    )
    print(
        f"  warm (median of {args.repeat}): {warm_s:.2f} s  "
        f"(runs: {', '.join(f'{w:.2f}' for w in warm_runs)})"
    )
    print(
        f"  every scene prepared: {_seconds(prepared_s['cold'])} (cold), "
        f"{_seconds(prepared_s['warm'])} (warm)"
    )
    print(
        f"  baselines: bare interpreter {interpreter_s:.2f} s, interpreter + kiosk imports "
        f"{imports_s:.2f} s"
    )
    print(
        f"  warm / imports {ratios['warm_to_imports']:.2f} (goal <= {WARM_GOAL}), "
        f"cold / warm {ratios['cold_to_warm']:.2f} (goal <= {COLD_GOAL}): "
        + ("met" if goals_met else "NOT met")
    )
    return 0


def _median(seconds: list[float | None]) -> float | None:
    """The median of the runs, None when one never said every scene was prepared."""
    known = [s for s in seconds if s is not None]
    if not seconds or len(known) < len(seconds):
        return None
    return round(statistics.median(known), 3)


def _seconds(seconds: float | None) -> str:
    return "never" if seconds is None else f"{seconds:.2f} s"
