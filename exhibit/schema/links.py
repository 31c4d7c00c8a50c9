"""Changing what a name points at, with no moment where it points at nothing: the one symbolic
link swap (:func:`replace_link`, for a release and a simulated device's stable name), the exchange
of two names (:func:`exchange`), and the lock that keeps two such changes from interleaving
(:func:`hold_lock`). Apart from :mod:`exhibit.schema.files` because these change names rather
than read or write a file's bytes; they share its refusals (:class:`UnsafePath`)."""

from __future__ import annotations

import errno
import os
import re
import secrets
import stat
from pathlib import Path

from exhibit.schema.files import UnsafePath, kind_of
import contextlib

# ---------------------------------------------------------------------- symbolic links

#: What the temporary link of :func:`replace_link` ends in (next to the link it replaces).
SWITCH = "exhibit-switch"


def _switch_names(link: Path) -> re.Pattern[str]:
    """The temporary names :func:`replace_link` uses next to ``link`` (and the fixed one it
    used before it had random ones)."""
    return re.compile(rf"\.{re.escape(link.name[:40])}\.(?:[0-9a-f]{{12}}\.)?{SWITCH}")


def replace_link(link: str | os.PathLike, target: str) -> None:
    """Point the symbolic link ``link`` at ``target`` in one rename: a reader sees the old link
    or the new one, never none. The one way exhibit swaps a link (a release, a simulated
    device's stable name). The new link is made under a fresh random name beside it
    (``.NAME.RANDOM.exhibit-switch``, never one left over by a killed run) and renamed over
    ``link``. UnsafePath when something other than a symbolic link is at ``link`` (a folder,
    a file, a FIFO: not ours to replace); OSError for the rest, leaving no temporary link."""
    link = Path(link)
    try:
        info = os.lstat(link)
    except FileNotFoundError:
        pass
    else:
        if not stat.S_ISLNK(info.st_mode):
            raise UnsafePath(
                f"{link} is {kind_of(info.st_mode)}, not a symbolic link: refusing to replace it"
            )
    for _ in range(100):
        tmp = link.with_name(f".{link.name[:40]}.{secrets.token_hex(6)}.{SWITCH}")
        try:
            os.symlink(target, tmp)
            break
        except FileExistsError:
            continue
    else:
        raise FileExistsError(f"no free temporary name next to {link}")
    try:
        os.replace(tmp, link)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def clean_switch_leftovers(link: str | os.PathLike) -> list[str]:
    """Remove what a killed :func:`replace_link` may have left beside ``link``: its temporary
    symbolic links, and an empty folder at one of its names (nothing is lost). Call it only
    while no other switch of ``link`` can run (under its lock). Returns one line for each
    thing found there that is neither (a file, a folder with something in it), left as it is."""
    link = Path(link)
    names = _switch_names(link)
    try:
        entries = os.listdir(link.parent)
    except OSError:
        return []
    kept = []
    for name in sorted(entries):
        if not names.fullmatch(name):
            continue
        path = link.parent / name
        try:
            info = os.lstat(path)
            if stat.S_ISLNK(info.st_mode):
                os.unlink(path)
                continue
            if stat.S_ISDIR(info.st_mode):
                os.rmdir(path)
                continue
            why = f"is {kind_of(info.st_mode)}"
        except FileNotFoundError:
            continue
        except OSError as exc:
            why = f"cannot be removed ({exc.strerror or exc})"
        kept.append(f"{path} {why}: not made by exhibit, left as it is")
    return kept


# ---------------------------------------------------------------------- one at a time


class Busy(OSError):
    """:func:`hold_lock` found the lock taken; ``holder`` is what its holder wrote there."""

    def __init__(self, path: str, holder: str):
        super().__init__(f"{path} is held by {holder or 'another process'}")
        self.path, self.holder = path, holder


def hold_lock(path: str | os.PathLike, holder: str) -> int:
    """Take the lock file ``path`` (fcntl.flock, exclusive, without waiting) and write
    ``holder`` into it (who and what, for the one refused next); returns its descriptor, which
    holds the lock until closed or the process ends (a kill -9 included: nothing stale is left
    to clean). Busy, naming the holder, when another process has it; UnsafePath when something
    other than a regular file is at ``path`` (a symbolic link, a folder, a FIFO)."""
    import fcntl

    shown = os.fspath(path)
    flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    try:
        fd = os.open(path, flags, 0o600)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise UnsafePath(f"{shown} is a symbolic link, not a lock file") from None
        if exc.errno == errno.EISDIR:
            raise UnsafePath(f"{shown} is a folder, not a lock file") from None
        raise
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise UnsafePath(f"{shown} is {kind_of(info.st_mode)}, not a lock file")
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            text = os.pread(fd, 512, 0).decode("utf-8", "replace").strip()
            raise Busy(shown, " ".join(text.split())) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, holder.encode("utf-8", "replace")[:512], 0)
    except BaseException:
        os.close(fd)
        raise
    return fd


def exchange(a: str | os.PathLike, b: str | os.PathLike) -> None:
    """Swap the two names ``a`` and ``b`` in one step (Linux renameat2 RENAME_EXCHANGE; a
    folder and a symbolic link alike), so no reader ever finds either missing. OSError as the
    system gives it; errno.ENOSYS where the C library lacks renameat2, EINVAL where the file
    system cannot exchange (the caller then renames in two steps)."""
    import ctypes

    try:
        call = ctypes.CDLL(None, use_errno=True).renameat2
    except AttributeError:
        raise OSError(errno.ENOSYS, "renameat2 is not available") from None
    at_fdcwd, rename_exchange = -100, 2
    if call(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) != 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code), os.fspath(a), None, os.fspath(b))
