"""Helpers for the deployment tests: read unit files as `exhibit install` writes them, and turn a
unit's SystemCallFilter= into the list of system calls systemd would allow."""

from __future__ import annotations

import functools
import shlex
import shutil
import subprocess
from pathlib import Path


def units(path: Path) -> dict[str, dict[str, list[str]]]:
    """A unit file as section -> key -> values (keys may repeat), with continuation lines."""
    sections: dict[str, dict[str, list[str]]] = {}
    current = None
    pending = ""
    for raw in path.read_text().splitlines():
        line = pending + raw.strip()
        pending = ""
        if not line or line.startswith(("#", ";")):
            continue
        if line.endswith("\\"):
            pending = line[:-1] + " "
            continue
        if line.startswith("["):
            current = sections.setdefault(line.strip("[]"), {})
            continue
        key, _, value = line.partition("=")
        current.setdefault(key.strip(), []).append(value.strip())
    return sections


def environment(service: dict[str, list[str]]) -> dict[str, str]:
    """The variables of every Environment= line (values without spaces, as ours are)."""
    return dict(
        pair.split("=", 1) for line in service.get("Environment", []) for pair in shlex.split(line)
    )


def yes(service: dict[str, list[str]], key: str) -> bool:
    return service.get(key, ["no"])[-1] in ("yes", "true", "1", "on")


@functools.cache
def syscall_group(name: str) -> frozenset[str]:
    """The system calls in a systemd group such as @system-service, nested groups expanded, as
    this machine's systemd knows them (`systemd-analyze syscall-filter`)."""
    if shutil.which("systemd-analyze") is None:
        raise FileNotFoundError("systemd-analyze")
    out = subprocess.run(
        ["systemd-analyze", "syscall-filter", "--no-pager", name],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    calls: set[str] = set()
    for line in out.splitlines()[1:]:
        item = line.strip()
        if not item or item.startswith("#"):
            continue
        calls |= syscall_group(item) if item.startswith("@") else {item}
    return frozenset(calls)


def _items(value: str) -> set[str]:
    calls: set[str] = set()
    for item in value.split():
        item = item.split(":")[0]  # "name:EPERM" gives an errno per call; the name is what counts
        calls |= syscall_group(item) if item.startswith("@") else {item}
    return calls


def allowed_syscalls(service: dict[str, list[str]]) -> set[str] | None:
    """The allow-list systemd builds from SystemCallFilter= (None when the unit has none):
    the first line lists what is allowed (and @default, which systemd always adds); each later
    line adds calls, or with ~ takes them away; an empty assignment starts over."""
    allowed: set[str] | None = None
    for value in service.get("SystemCallFilter", []):
        if not value:
            allowed = None
            continue
        deny = value.startswith("~")
        if allowed is None:
            if deny:
                raise ValueError("a deny-list filter cannot be emulated by this helper")
            allowed = set(syscall_group("@default"))
        if deny:
            allowed -= _items(value[1:])
        else:
            allowed |= _items(value)
    return allowed


def sandbox_options(service: dict[str, list[str]], folder: Path, name: str) -> list[str]:
    """sandbox_exec.py's options for a unit's seccomp settings, read from the unit itself so a
    test and the unit cannot drift: SystemCallFilter= (its list written to ``folder``/NAME.syscalls)
    with SystemCallErrorNumber=, RestrictAddressFamilies=, MemoryDenyWriteExecute= and
    RestrictRealtime=."""
    options: list[str] = []
    calls = allowed_syscalls(service)
    if calls is not None:
        listing = folder / f"{name}.syscalls"
        listing.write_text("\n".join(sorted(calls)) + "\n")
        listing.chmod(0o644)
        errno_name = service.get("SystemCallErrorNumber", ["kill"])[-1]
        options += ["--syscalls", str(listing), "--errno", errno_name]
    families = service.get("RestrictAddressFamilies", [""])[-1].split()
    if families:
        options += ["--families", ",".join(families)]
    if yes(service, "MemoryDenyWriteExecute"):
        options += ["--mdwe"]
    if yes(service, "RestrictRealtime"):
        options += ["--no-realtime"]
    return options
