"""A disposable Debian machine for the museum-day test: this machine's own root file system
under a copy-on-write overlay, in mount and network namespaces of its own, with no network at
all (not even loopback). Whatever the test installs there (the exhibit user, /opt/exhibit,
/etc/systemd/system, /var/lib/exhibit) lands in the overlay's upper folder and is gone with it;
this machine is never changed.

What it is not: systemd is not PID 1 there. `systemctl`, `udevadm`, `modprobe` and `sysctl` are
stand-ins (FAKES) that log their calls to LOG_DIR for the test, which plays systemd's part (it
starts and restarts the units as they say); a kill can be planted in one of them (KILL_AT) to
stop a technician's update at that step.

Needs root, util-linux (unshare, nsenter) and overlayfs; the test skips (fails under CI=true)
without them.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

#: Where the stand-ins log inside the machine.
LOG_DIR = "/var/log/exhibit-day"
#: A file naming the stand-in call (its first argument, e.g. "try-restart") at which the
#: running `exhibit update` or `exhibit rollback` is killed with SIGKILL, once.
KILL_AT = f"{LOG_DIR}/kill-at"
_FAKE = """#!/bin/sh
# A stand-in for {name} in the museum-day test's machine (tests/deploy/machine.py): systemd is
# not PID 1 there. It logs the call; the test plays systemd's part.
if [ -f {kill_at} ] && [ "$(cat {kill_at})" = "$1" ]; then
  rm -f {kill_at}
  echo "killed at: {name} $*" >> {log}/kills.log
  pkill -KILL -f 'bin/exhibit (update|rollback)'
  exit 137
fi
echo "{name} $*" >> {log}/{name}.log
exit 0
"""
FAKES = ("systemctl", "udevadm", "modprobe", "sysctl")
#: A clean root environment for commands run in the machine, as after `sudo -i`.
ROOT_ENV = {
    "PATH": "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin",
    "HOME": "/root",
    "LANG": "C.UTF-8",
}

_BOOT = """set -e
base="$1"
m="$base/merged"
mount -t overlay overlay -o "lowerdir=/,upperdir=$base/upper,workdir=$base/work" "$m"
mount --rbind /dev "$m/dev"
mount -t proc proc "$m/proc"
mount --rbind /sys "$m/sys"
mount -t tmpfs -o mode=1777,nosuid,nodev tmpfs "$m/tmp"
mount -t tmpfs -o mode=0755,nosuid,nodev tmpfs "$m/run"
mkdir -p "$m/var/lib/exhibit" "$m/.machine-old-root"
# The state disk: small, so that the test can fill it.
mount -t tmpfs -o "size=$2,mode=0755" tmpfs "$m/var/lib/exhibit"
cd "$m"
pivot_root . .machine-old-root
umount -l /.machine-old-root
rmdir /.machine-old-root
cd /
echo ready > /run/machine-ready
exec sleep infinity
"""


def why_not() -> str:
    """Why no machine can be made here, or ""."""
    if os.geteuid() != 0:
        return "needs root (mount and network namespaces, an overlay of /)"
    for program in ("unshare", "nsenter", "pivot_root", "pkill", "setpriv", "findmnt"):
        if shutil.which(program) is None:
            return f"{program} is missing (Debian: util-linux, procps)"
    return ""


class Machine:
    """The machine, while its namespaces' holder (``pid``) lives."""

    def __init__(self, base: Path, holder: subprocess.Popen):
        self.base, self.holder = base, holder

    @property
    def pid(self) -> int:
        return self.holder.pid

    def path(self, inside: str) -> Path:
        """A path of the machine as seen from here (through the holder's root)."""
        return Path(f"/proc/{self.pid}/root") / inside.lstrip("/")

    def argv(self, command: list[str], env: dict[str, str] | None = None) -> list[str]:
        """``command`` run inside the machine as root, with a clean environment."""
        words = [f"{k}={v}" for k, v in {**ROOT_ENV, **(env or {})}.items()]
        return ["nsenter", "-t", str(self.pid), "-m", "-n", "-r", "-w", "--", "env", "-i"] + [
            *words,
            *command,
        ]

    def run(
        self, command: list[str], timeout: float = 600, env: dict[str, str] | None = None
    ) -> subprocess.CompletedProcess:
        return subprocess.run(
            self.argv(command, env),
            capture_output=True,
            text=True,
            errors="replace",
            timeout=timeout,
            stdin=subprocess.DEVNULL,
        )

    def shell(
        self, script: str, cwd: str = "/", timeout: float = 600
    ) -> subprocess.CompletedProcess:
        return self.run(["/bin/sh", "-c", f"cd {cwd} && {script}"], timeout=timeout)

    def install_fakes(self) -> None:
        (self.path(LOG_DIR)).mkdir(parents=True, exist_ok=True)
        for name in FAKES:
            fake = self.path(f"/usr/local/sbin/{name}")
            fake.parent.mkdir(parents=True, exist_ok=True)
            fake.write_text(_FAKE.format(name=name, kill_at=KILL_AT, log=LOG_DIR))
            fake.chmod(0o755)

    def calls(self, name: str) -> list[str]:
        """The calls of the stand-in ``name`` so far, one line each."""
        try:
            return self.path(f"{LOG_DIR}/{name}.log").read_text().splitlines()
        except FileNotFoundError:
            return []

    def plant_kill(self, first_argument: str) -> None:
        self.path(KILL_AT).write_text(first_argument)

    def kills(self) -> list[str]:
        try:
            return self.path(f"{LOG_DIR}/kills.log").read_text().splitlines()
        except FileNotFoundError:
            return []


@contextlib.contextmanager
def machine(state_disk: str = "8m") -> Iterator[Machine]:
    """A machine (see the module), removed afterwards with everything in it. ``state_disk``:
    the size of the tmpfs at /var/lib/exhibit."""
    # Not under /tmp (the machine mounts its own there), nor inside anything it hides.
    base = Path(tempfile.mkdtemp(prefix="exhibit-day-", dir="/var/lib"))
    for name in ("upper", "work", "merged"):
        (base / name).mkdir()
    holder = subprocess.Popen(
        ["unshare", "--mount", "--net", "--propagation", "private", "--", "/bin/sh", "-c"]
        + [_BOOT, "machine-boot", str(base), state_disk],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    box = Machine(base, holder)
    try:
        deadline = time.monotonic() + 60
        while not box.path("/run/machine-ready").exists():
            if holder.poll() is not None:
                out = holder.stdout.read().decode(errors="replace") if holder.stdout else ""
                raise RuntimeError(f"the machine did not start: {out.strip()[-2000:]}")
            if time.monotonic() > deadline:
                raise RuntimeError("the machine did not start within 60 s")
            time.sleep(0.05)
        yield box
    finally:
        # Everything started inside was started by the test (as the units): the caller stops
        # it. The namespaces go with their last process.
        with contextlib.suppress(ProcessLookupError):
            os.killpg(holder.pid, signal.SIGKILL)
        holder.wait(30)
        if holder.stdout is not None:
            holder.stdout.close()
        shutil.rmtree(base, ignore_errors=True)
