"""Whether the kiosk's state folder can take what the kiosk writes there, and which code runs.

The kiosk writes its health file, the visitor-session log (SQLite) and, through journald, its
log. A full disk (ENOSPC, EDQUOT), a file system remounted read-only after an error (EROFS:
ext4's errors=remount-ro) or a folder whose owner or mode changed (EACCES, EPERM) stops those
writes while the kiosk goes on drawing. So the kiosk looks at its state folder with each report
(:func:`check_folder`: statvfs's free blocks, free inodes and read-only flag, and whether it may
write there) and records the errno of each write that failed (:func:`errno_name`,
:func:`sqlite_errno`); the health file carries both as "storage", and `exhibit status` reports a
problem there with its own exit code rather than calling a drawing kiosk dead.

A reader (`exhibit status`) looks at the folder too, for when the kiosk could not even update
its health file: free space from statvfs, and whether the file system itself is read-only from
/proc/self/mountinfo's super options (statvfs's flag would also be set by the read-only view a
sandbox gives the reader: exhibit-metrics.service has ProtectSystem=strict).

:func:`build_info`: the version (exhibit.__version__) and the release the running code comes
from: the folder in PREFIX-releases/ that /opt/exhibit links to (docs/DEPLOYMENT.md, "8.
Updating"), resolved when the process starts, so a kiosk not yet restarted after an update names
the release it really runs; outside a release, the folder of the checkout.
"""

from __future__ import annotations

import errno
import functools
import os
import sqlite3
from pathlib import Path

import exhibit

__all__ = [
    "MIN_FREE_BYTES",
    "PROBLEMS",
    "build_info",
    "check_folder",
    "errno_name",
    "problem_of",
    "sqlite_errno",
    "filesystem_read_only",
    "problem_in",
    "format_bytes",
]

#: Less free space than this for the kiosk's user is a full state folder: SQLite needs room for
#: its journal, and a session log that cannot grow has stopped.
MIN_FREE_BYTES = 1 << 20
#: The problems a state folder can have, by the errno of a write it refused.
PROBLEMS = {
    errno.ENOSPC: "full",
    errno.EDQUOT: "full",
    errno.EROFS: "read-only",
    errno.EACCES: "not writable",
    errno.EPERM: "not writable",
}
#: sqlite3's primary result codes (sqlite3.Error.sqlite_errorcode & 0xFF) as the errno they mean.
_SQLITE = {13: errno.ENOSPC, 8: errno.EROFS, 3: errno.EACCES}  # FULL, READONLY, PERM


def errno_name(code: int | None) -> str | None:
    """ "ENOSPC" for errno.ENOSPC; None for None or a code without a name."""
    return errno.errorcode.get(code) if code is not None else None


def problem_of(name: str | None) -> str | None:
    """The state folder's problem an errno name means ("ENOSPC" -> "full"), else None."""
    code = getattr(errno, name, None) if name else None
    return PROBLEMS.get(code) if isinstance(code, int) else None


def sqlite_errno(exc: BaseException) -> int | None:
    """The errno behind a failed SQLite or file operation: an OSError's own, SQLITE_FULL as
    ENOSPC, SQLITE_READONLY as EROFS (the folder's check tells a read-only mount from a
    read-only file), SQLITE_PERM as EACCES; None for anything else (a corrupt file)."""
    if isinstance(exc, OSError):
        return exc.errno
    if isinstance(exc, sqlite3.Error):
        code = getattr(exc, "sqlite_errorcode", None)
        if isinstance(code, int):
            return _SQLITE.get(code & 0xFF)
    return None


def check_folder(folder: str | os.PathLike, writer: bool = True) -> dict:
    """The state folder now: {"folder", "free_bytes", "free_inodes", "problem"}, "problem" one
    of "full", "read-only", "not writable" or None (None too, with "error", when the folder
    cannot be looked at). ``writer``: checked as the process that writes there (the kiosk:
    statvfs's read-only flag, and access(W_OK)); else as a reader elsewhere (`exhibit status`,
    maybe in a read-only sandbox: only the file system's own read-only state counts)."""
    path = os.fspath(folder)
    out: dict = {"folder": path, "free_bytes": None, "free_inodes": None, "problem": None}
    try:
        info = os.statvfs(path)
    except OSError as exc:
        out["error"] = errno_name(exc.errno) or str(exc)
        return out
    out["free_bytes"] = info.f_bavail * info.f_frsize
    # 0 files in total: a file system without an inode count (btrfs, some FUSE), not full.
    out["free_inodes"] = info.f_favail if info.f_files else None
    if bool(info.f_flag & os.ST_RDONLY) if writer else filesystem_read_only(path) is True:
        out["problem"] = "read-only"
    elif out["free_bytes"] < MIN_FREE_BYTES or out["free_inodes"] == 0:
        out["problem"] = "full"
    elif writer and not os.access(path, os.W_OK):
        out["problem"] = "not writable"
    return out


def filesystem_read_only(path: str | os.PathLike, mountinfo: str | None = None) -> bool | None:
    """Whether the file system holding ``path`` is itself read-only (its super options in
    /proc/self/mountinfo, or ``mountinfo``'s text), whatever the mount this process sees it
    through; None when that cannot be told."""
    try:
        target = os.path.realpath(path)
        text = mountinfo if mountinfo is not None else Path("/proc/self/mountinfo").read_text()
    except OSError:
        return None
    best, found = -1, None
    for line in text.splitlines():
        fields = line.split(" - ")
        left = fields[0].split()
        if len(fields) != 2 or len(left) < 5:
            continue
        point = _unescape(left[4])
        inside = target == point or target.startswith(point.rstrip("/") + "/")
        if inside and len(point) > best:
            right = fields[1].split()
            if len(right) >= 3:
                best, found = len(point), "ro" in right[2].split(",")
    return found


def _unescape(text: str) -> str:
    """mountinfo's octal escapes (\\040 for a space) undone."""
    if "\\" not in text:
        return text
    return text.encode().decode("unicode_escape").encode("latin-1").decode("utf-8", "replace")


@functools.cache
def build_info() -> dict[str, str]:
    """{"version", "release"} of the running code (the module's docstring): the release is the
    name of the folder in a ``*-releases`` folder that the code lies in once links are resolved
    (/opt/exhibit -> exhibit-releases/0.2.0-20250601T120000Z), else the checkout's (or the
    virtual environment's owner's) folder as a path. Cached: what was loaded at the start."""
    here = Path(os.path.realpath(exhibit.__file__)).parent
    for part in here.parents:
        if part.parent.name.endswith("-releases") and part.parent != part:
            return {"version": exhibit.__version__, "release": part.name}
    root = here.parent
    for part in here.parents:
        if part.name == ".venv":  # installed into a virtual environment: the folder holding it
            root = part.parent
            break
    return {"version": exhibit.__version__, "release": str(root)}


def problem_in(info: dict) -> tuple[str, str] | None:
    """(problem, reason) from a health file's "storage" (made by :func:`check_folder`, with
    "errors"): the problem seen in the folder, else the one the errno of a failed write means;
    None when there is none. The reason names the folder, the free space and the writes."""
    errors = info.get("errors")
    errors = {str(k): str(v) for k, v in errors.items()} if isinstance(errors, dict) else {}
    failed = {what: problem_of(name) for what, name in errors.items()}
    problem = info.get("problem")
    if not isinstance(problem, str) or problem not in PROBLEMS.values():
        problem = next((p for p in failed.values() if p is not None), None)
    if problem is None:
        return None
    folder = info.get("folder")
    text = f"the state folder {folder if isinstance(folder, str) else ''} is {problem}"
    free = info.get("free_bytes")
    if problem == "full" and isinstance(free, int) and not isinstance(free, bool):
        text += f" ({format_bytes(free)} free)"
    writes = [f"{what} ({name})" for what, name in errors.items() if failed[what] is not None]
    if writes:
        text += "; failed writes: " + ", ".join(writes)
    return problem, text.replace("folder  is", "folder is")


def format_bytes(count: float) -> str:
    """12 B, 3.4 KiB, 5.0 MiB, 2.1 GiB."""
    value, unit = float(count), "B"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(value) < 1024 or unit == "TiB":
            break
        value /= 1024
    return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
