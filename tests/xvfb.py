"""A private Xvfb server for window tests, and the skip-or-fail rule for missing tools."""

from __future__ import annotations

import contextlib
import os
import select
import shutil
import subprocess
import time

import pytest


def unavailable(reason: str):
    """Skip, except under CI=true, where every test must really run."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: these tests must run)")
    pytest.skip(reason)


@contextlib.contextmanager
def xvfb(size: str = "640x480x24"):
    """Start Xvfb on a display number it picks itself (-displayfd: no race between test
    processes running side by side); yields the DISPLAY value once the server is ready."""
    if shutil.which("Xvfb") is None:
        unavailable("Xvfb is not installed (Debian: apt-get install xvfb)")
    read_end, write_end = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_end), "-screen", "0", size, "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        pass_fds=(write_end,),
    )
    os.close(write_end)
    number = b""
    deadline = time.monotonic() + 10
    with os.fdopen(read_end, "rb", buffering=0) as said:
        while not number.endswith(b"\n") and time.monotonic() < deadline:
            ready, _, _ = select.select([said], [], [], 0.1)
            if ready:
                chunk = said.read(16)
                if not chunk:
                    break
                number += chunk
    if not number.strip().isdigit():
        server.kill()
        server.wait()
        unavailable("Xvfb did not start (no display number on -displayfd)")
    try:
        yield f":{int(number)}"
    finally:
        server.terminate()
        server.wait(timeout=10)
