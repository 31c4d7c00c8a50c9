"""`exhibit bench startup`: process start to the kiosk's first frame, timed by the kiosk's own
READY=1 (sent after the first frame) on a private NOTIFY_SOCKET. One cold run fills a fresh mesh
cache; the warm runs are what a restart by the watchdog costs. Baselines in the same run: a bare
interpreter, and the interpreter importing the kiosk's modules."""

from __future__ import annotations

import json
import os
import platform
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from exhibit.errors import ExhibitError

HELP = "time from process start to the kiosk's first frame (warm mesh cache), with baselines"


def add_arguments(parser) -> None:
    parser.add_argument("--config", help="kiosk config (default: the shipped one)")
    parser.add_argument("--repeat", type=int, default=5, help="warm runs; the median counts")
    parser.add_argument("--json", action="store_true", help="print JSON")


def _time_command(args: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(args, check=True, capture_output=True)
    return time.perf_counter() - start


def _time_to_ready(config: str | None, env: dict, folder: Path, timeout: float = 600) -> float:
    address = str(folder / f"notify-{time.monotonic_ns()}.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind(address)
    server.settimeout(0.5)
    command = [sys.executable, "-m", "exhibit", "run", "--windowed", "--duration", "600"]
    if config:
        command += ["--config", config]
    start = time.perf_counter()
    child = subprocess.Popen(command, env=dict(env, NOTIFY_SOCKET=address),
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        while time.perf_counter() - start < timeout:
            try:
                message = server.recv(4096).decode()
            except socket.timeout:
                if child.poll() is not None:
                    raise ExhibitError("the kiosk exited before its first frame: "
                                       + (child.stderr.read().strip().splitlines() or ["?"])[-1])
                continue
            if "READY=1" in message:
                return time.perf_counter() - start
        raise ExhibitError(f"no first frame within {timeout:.0f} s")
    finally:
        child.terminate()
        try:
            child.wait(timeout=30)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
        child.stderr.close()
        server.close()


def run(args) -> int:
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ExhibitError("the kiosk needs a display; on a headless machine run "
                           "`xvfb-run -a exhibit bench startup`")
    if args.repeat < 1:
        raise ExhibitError("--repeat must be at least 1")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        env = dict(os.environ, EXHIBIT_CACHE_DIR=str(folder / "cache"),
                   EXHIBIT_STATE_DIR=str(folder / "state"))
        env.pop("WATCHDOG_USEC", None)
        print("cold start (building the mesh cache)...", file=sys.stderr)
        cold = _time_to_ready(args.config, env, folder)
        warm = [_time_to_ready(args.config, env, folder) for _ in range(args.repeat)]
    interpreter = statistics.median(_time_command([sys.executable, "-c", "pass"])
                                    for _ in range(3))
    imports = statistics.median(
        _time_command([sys.executable, "-c", "import exhibit.kiosk.app, exhibit.render.window, "
                       "exhibit.commands.run"]) for _ in range(3))
    report = {"machine": f"{platform.machine()}, {os.cpu_count()} cores, "
                         f"Python {platform.python_version()}",
              "cold_s": round(cold, 3), "warm_s": round(statistics.median(warm), 3),
              "warm_runs_s": [round(w, 3) for w in warm],
              "baseline": {"interpreter_s": round(interpreter, 3), "imports_s": round(imports, 3)}}
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"start to first frame on {report['machine']}:")
    print(f"  cold (empty mesh cache): {report['cold_s']:.2f} s")
    print(f"  warm (median of {args.repeat}): {report['warm_s']:.2f} s  "
          f"(runs: {', '.join(f'{w:.2f}' for w in report['warm_runs_s'])})")
    print(f"  baselines: bare interpreter {interpreter:.2f} s, interpreter + kiosk imports "
          f"{imports:.2f} s")
    return 0
