"""The file-system and identity part of a unit's sandbox, applied without systemd: the command
line that runs a program as systemd would run the unit's ExecStart= (as far as a root test can
without systemd as PID 1), read from the unit itself so the test and the unit cannot drift.

From the unit, in a private mount namespace (`unshare --mount`, as root):
- ProtectSystem=strict: every mount read-only but /proc, /sys and /dev (their own settings);
- the unit's writable folders (StateDirectory=, CacheDirectory=, RuntimeDirectory= or
  ReadWritePaths=), moved to the test's folders by the caller, bound read-write again;
- PrivateTmp=yes: an empty /tmp and /var/tmp of its own;
- ProtectHome=yes: /home, /root and /run/user empty and closed;
then, leaving root (setpriv): User=, Group=, SupplementaryGroups= (those the machine has; the
ones it lacks are named in the note), no inheritable capabilities, UMask=, WorkingDirectory=.

Not applied here (they need systemd): ProtectProc=, ProtectKernel*=, ProtectClock=,
DevicePolicy=, IPAddressDeny= (RestrictAddressFamilies= does it for IP, in sandbox_exec.py).
"""

from __future__ import annotations

import grp
import os
import shlex
from pathlib import Path

from tests.deploy.unitfile import yes

#: What systemd leaves to its own settings when it makes the system read-only.
KEPT_WRITABLE = ("/proc", "/sys", "/dev")
#: ProtectHome=yes: hidden (empty, mode 000).
HOMES = ("/home", "/root", "/run/user")
#: PrivateTmp=yes: private and empty.
TMPS = ("/tmp", "/var/tmp")


def groups_of(service: dict[str, list[str]]) -> tuple[list[int], list[str]]:
    """The gids of the unit's SupplementaryGroups= this machine has, and the names it lacks."""
    names = " ".join(service.get("SupplementaryGroups", [])).split()
    found, missing = [], []
    for name in names:
        try:
            found.append(grp.getgrnam(name).gr_gid)
        except KeyError:
            missing.append(name)
    return found, missing


def confined(
    service: dict[str, list[str]],
    uid: int,
    gid: int,
    writable: list[Path],
    workdir: Path,
    extra_gids: list[int] = (),
) -> tuple[list[str], str]:
    """argv prefix (run it as root) that confines the rest of the command line as the unit
    would, and a note of what the machine could not give. ``writable``: the unit's writable
    folders, already moved under the test's own folder (which must not be under /tmp, /home or
    /root: PrivateTmp= and ProtectHome= hide those)."""
    for folder in writable:
        for hidden in (*TMPS, *HOMES):
            if folder == Path(hidden) or Path(hidden) in folder.parents:
                raise ValueError(f"{folder}: hidden by the sandbox itself ({hidden})")
    script = ["set -e"]
    if service.get("ProtectSystem", ["no"])[-1] == "strict":
        keep = " ".join(KEPT_WRITABLE)
        script.append(
            "findmnt -rno TARGET | while read -r target; do "
            f'case "$target" in {"|".join(f"{k}|{k}/*" for k in keep.split())}) continue ;; esac; '
            'mount -o bind,remount,ro "$target" 2>/dev/null || true; done'
        )
    for folder in writable:
        quoted = shlex.quote(str(folder))
        script.append(f"mount --bind {quoted} {quoted}")
        script.append(f"mount -o bind,remount,rw {quoted}")
    if yes(service, "PrivateTmp"):
        script += [f"mount -t tmpfs -o mode=1777,nosuid,nodev tmpfs {t}" for t in TMPS]
    if service.get("ProtectHome", ["no"])[-1] in ("yes", "true"):
        script += [
            f"if [ -d {h} ]; then mount -t tmpfs -o mode=000,ro tmpfs {h}; fi" for h in HOMES
        ]
    gids, missing = groups_of(service)
    gids = sorted(set(gids) | set(extra_gids))
    umask = service.get("UMask", ["0022"])[-1]
    script.append(f"umask {umask}")
    script.append(f"cd {shlex.quote(str(workdir))}")
    setpriv = [
        "setpriv",
        f"--reuid={uid}",
        f"--regid={gid}",
        "--groups=" + ",".join(map(str, gids)) if gids else "--clear-groups",
        "--inh-caps=-all",
        "--",
    ]
    script.append('exec "$@"')
    argv = ["unshare", "--mount", "--propagation", "private", "--", "/bin/sh", "-c"]
    argv += ["\n".join(script), "unit-sandbox", *setpriv]
    note = f"SupplementaryGroups= this machine lacks: {' '.join(missing)}" if missing else ""
    return argv, note


def can_confine() -> str:
    """Why confined() cannot work here, or "" when it can (root, unshare and setpriv)."""
    if os.geteuid() != 0:
        return "needs root for a mount namespace"
    for program in ("unshare", "setpriv", "findmnt"):
        if not any(Path(d, program).exists() for d in os.environ.get("PATH", "").split(":")):
            return f"{program} is missing (Debian: util-linux)"
    return ""
