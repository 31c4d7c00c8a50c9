"""Processes seen from a test: whether one is still alive (a zombie waiting for its reaper counts
as gone), the pids fake tools write to a file, and waiting, boundedly, for one to go."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def pids(path: Path, want: int = 1, within: float = 20.0) -> list[int]:
    """The pids the fake tools wrote to ``path``, once there are ``want`` of them."""
    end = time.monotonic() + within
    while time.monotonic() < end:
        if path.exists():
            found = [int(w) for w in path.read_text().split()]
            if len(found) >= want:
                return found
        time.sleep(0.02)
    raise AssertionError(f"no fake tool wrote its pid to {path} within {within} s")


def gone(pid: int, within: float = 10.0) -> bool:
    end = time.monotonic() + within
    while time.monotonic() < end:
        if not alive(pid):
            return True
        time.sleep(0.02)
    return False


def outlived(caller: subprocess.Popen, record: Path, sig: int, within: float = 60.0) -> int | None:
    """Stop ``caller`` with ``sig`` once its fake tool has written its pid to ``record``: the
    tool's pid if it is still alive after that, else None. The caller is killed whatever
    happens, so a failing test leaves nothing running."""
    try:
        (pid,) = pids(record, within=within)
        caller.send_signal(sig)
        caller.wait(timeout=30)
        return None if gone(pid) else pid
    finally:
        if caller.poll() is None:
            caller.kill()
            caller.wait()
