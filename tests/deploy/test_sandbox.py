"""The units' seccomp settings against the exhibit's own renderer and narration player, without
systemd: the system call filter both units carry leaves the picture unchanged and lets narration
sound, and MemoryDenyWriteExecute=, which neither carries, kills Mesa's llvmpipe at its first draw
call (why it is left out). Also checks that sandbox_exec.py, which the cage test relies on, really
filters."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.deploy.unitfile import allowed_syscalls, sandbox_options, syscall_group, units

REPO = Path(__file__).resolve().parents[2]
SANDBOX = Path(__file__).with_name("sandbox_exec.py")


def unavailable(reason: str):
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: these tests must run)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def app_filter(tmp_path_factory):
    """The allow-list of exhibit.service as systemd builds it, written one call a line."""
    try:
        calls = allowed_syscalls(units(REPO / "systemd/exhibit.service")["Service"])
    except FileNotFoundError:
        unavailable("systemd-analyze is not installed (Debian: apt-get install systemd)")
    path = tmp_path_factory.mktemp("filter") / "app.syscalls"
    path.write_text("\n".join(sorted(calls)) + "\n")
    return path


def sandboxed(*options: str, command: list[str], **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SANDBOX), *options, "--", *command],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=REPO,
        **kw,
    )


def render(out: Path, *options: str) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "exhibit", "render", "--figure", "8", "--out", str(out)]
    if not options:
        return subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=REPO)
    return sandboxed(*options, command=command)


def test_the_filter_is_what_the_unit_says():
    service = units(REPO / "systemd/exhibit.service")["Service"]
    try:
        calls = allowed_syscalls(service)
    except FileNotFoundError:
        unavailable("systemd-analyze is not installed (Debian: apt-get install systemd)")
    assert {"read", "ioctl", "mmap", "openat", "execve", "sendmsg", "memfd_create"} <= calls
    assert not syscall_group("@privileged") & calls
    # Of @resources only the one narration needs (its real-time policies refused by
    # RestrictRealtime=, test_restrict_realtime_refuses_real_time_policies_only).
    assert syscall_group("@resources") & calls == {"sched_setscheduler"}
    assert not {"mount", "reboot", "init_module", "ptrace", "swapon"} & calls


def test_sandbox_exec_refuses_what_the_filter_leaves_out(app_filter):
    probe = (
        "import os, socket, errno\n"
        "socket.socket(socket.AF_UNIX).close()\n"
        "for call in (lambda: socket.socket(socket.AF_INET), lambda: os.setpriority("
        "os.PRIO_PROCESS, 0, 1), lambda: os.sched_setaffinity(0, {0})):\n"
        "    try:\n"
        "        call()\n"
        "    except OSError as exc:\n"
        "        print(errno.errorcode[exc.errno])\n"
        "    else:\n"
        "        print('allowed')\n"
    )
    result = sandboxed(
        "--syscalls",
        str(app_filter),
        "--errno",
        "EPERM",
        "--families",
        "AF_UNIX,AF_NETLINK",
        command=[sys.executable, "-c", probe],
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["EAFNOSUPPORT", "EPERM", "EPERM"]
    unfiltered = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert "EAFNOSUPPORT" not in unfiltered.stdout


def test_the_picture_is_the_same_under_the_units_system_call_filter(app_filter, tmp_path):
    """llvmpipe's refused calls (thread priorities and placement) cost nothing visible."""
    plain, filtered = tmp_path / "plain.png", tmp_path / "filtered.png"
    result = render(plain)
    if result.returncode != 0:
        unavailable(f"no headless OpenGL: {result.stderr.strip()[-300:]}")
    result = render(
        filtered,
        "--syscalls",
        str(app_filter),
        "--errno",
        "EPERM",
        "--families",
        "AF_UNIX,AF_NETLINK",
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert filtered.read_bytes() == plain.read_bytes()


def test_memory_deny_write_execute_kills_llvmpipe(tmp_path):
    """Why neither unit sets MemoryDenyWriteExecute=yes: Mesa's llvmpipe (the renderer on a
    machine without a GPU driver, and what CI has) compiles shaders to machine code and makes it
    executable, which that setting forbids; the process dies at its first draw call."""
    result = render(tmp_path / "plain.png")
    if result.returncode != 0:
        unavailable(f"no headless OpenGL: {result.stderr.strip()[-300:]}")
    if (
        "llvmpipe"
        not in subprocess.run(
            [
                sys.executable,
                "-c",
                "from exhibit.render import Headless; h = Headless(); "
                "print(h.ctx.info['GL_RENDERER'])",
            ],
            capture_output=True,
            text=True,
            cwd=REPO,
        ).stdout
    ):
        pytest.skip("the renderer here is not llvmpipe")
    result = render(tmp_path / "mdwe.png", "--mdwe")
    assert result.returncode == -signal.SIGSEGV, (result.returncode, result.stderr[-1000:])
    assert not (tmp_path / "mdwe.png").exists()


#: Plays 0.3 s of sound on miniaudio's null device (which takes samples in real time, as a card
#: would) and prints the player's status as JSON.
PLAY = """
import json, time
from exhibit.narration import Player, silence
with Player(backend="null") as player:
    player.play(silence(0.3))
    deadline = time.monotonic() + 60
    while player.status()["played_s"] < 0.3 and time.monotonic() < deadline:
        time.sleep(0.02)
    print(json.dumps(player.status()))
"""


def test_narration_sounds_under_the_apps_sandbox(tmp_path):
    """The app unit's seccomp settings as the unit file states them (its system call filter,
    address families, RestrictRealtime=): the narration player opens the null device and the
    device's own thread takes the whole sound. Under `~@resources` alone miniaudio's audio thread
    could not start (sched_setscheduler refused: "failed to init device, -3")."""
    service = units(REPO / "systemd/exhibit.service")["Service"]
    try:
        options = sandbox_options(service, tmp_path, "app")
    except FileNotFoundError:
        unavailable("systemd-analyze is not installed (Debian: apt-get install systemd)")
    assert "--no-realtime" in options
    result = sandboxed(*options, command=[sys.executable, "-c", PLAY])
    assert result.returncode == 0, result.stderr[-2000:]
    status = json.loads(result.stdout.strip().splitlines()[-1])
    assert status["state"] == "ok", status
    assert status["sounds_begun"] == 1 and status["played_s"] >= 0.3, status


def test_restrict_realtime_refuses_real_time_policies_only(tmp_path):
    """What the unit's RestrictRealtime=yes keeps refusing now that sched_setscheduler is
    allowed: SCHED_FIFO and SCHED_RR (even for root, as here); normal policies pass."""
    service = units(REPO / "systemd/exhibit.service")["Service"]
    try:
        options = sandbox_options(service, tmp_path, "app")
    except FileNotFoundError:
        unavailable("systemd-analyze is not installed (Debian: apt-get install systemd)")
    probe = (
        "import os\n"
        "for name in ('SCHED_OTHER', 'SCHED_BATCH', 'SCHED_IDLE', 'SCHED_FIFO', 'SCHED_RR'):\n"
        "    policy = getattr(os, name)\n"
        "    level = os.sched_get_priority_min(policy)\n"
        "    try:\n"
        "        os.sched_setscheduler(0, policy, os.sched_param(level))\n"
        "        print(name, 'allowed')\n"
        "    except OSError as exc:\n"
        "        print(name, exc.errno)\n"
    )
    result = sandboxed(*options, command=[sys.executable, "-c", probe])
    assert result.returncode == 0, result.stderr[-2000:]
    answers = dict(line.split() for line in result.stdout.splitlines())
    assert answers == {
        "SCHED_OTHER": "allowed",
        "SCHED_BATCH": "allowed",
        "SCHED_IDLE": "allowed",
        "SCHED_FIFO": str(errno.EPERM),
        "SCHED_RR": str(errno.EPERM),
    }
