"""An external step with a time limit: `exhibit update` and `exhibit rollback` run another
release's `exhibit check-config`, `prepare`, `install` and the restart this way, so a hung step
is stopped (its whole process group: runuser, env, exhibit and whatever they started) instead of
making an update wait forever, and whatever bytes it prints are read as text."""

from __future__ import annotations

import os
import signal
import subprocess
import contextlib


def run_bounded(command: list[str], timeout: float | None = None) -> subprocess.CompletedProcess:
    """``command``'s exit code and output, decoded as UTF-8 with anything else replaced (a
    release may print any bytes). After ``timeout`` seconds its whole process group (runuser,
    env, exhibit and whatever they started) gets SIGTERM, then SIGKILL, and
    subprocess.TimeoutExpired is raised."""
    with subprocess.Popen(
        command,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    ) as process:
        try:
            out, err = process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            out, err = stop_group(process)
            raise subprocess.TimeoutExpired(command, timeout or 0, out, err) from None
    return subprocess.CompletedProcess(command, process.returncode, decode(out), decode(err))


def stop_group(process: subprocess.Popen) -> tuple[bytes, bytes]:
    """SIGTERM to the process group, SIGKILL after 10 s; what it printed."""
    for sig, grace in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, sig)
        try:
            out, err = process.communicate(timeout=grace)
            return out or b"", err or b""
        except subprocess.TimeoutExpired:
            continue
    return b"", b""  # something left the group and holds the pipes: give up on its output


def decode(data: bytes | str | None) -> str:
    if isinstance(data, bytes):
        return data.decode("utf-8", errors="replace")
    return data or ""
