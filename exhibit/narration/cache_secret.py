"""The speech cache's secret: the key its entries' HMACs are made with (exhibit.narration.cache).

A cache entry's name and its plain hash are computed from public facts (the engine, its version,
the voice, the rate and the text), so anyone who can write the cache folder could replace an
entry with any sound that carries its own matching hash. An entry is trusted only when it also
carries an HMAC-SHA256 under this key, which lives in the exhibit's state folder
($EXHIBIT_STATE_DIR: /var/lib/exhibit for the service; else $XDG_STATE_HOME/exhibit, else
~/.local/state/exhibit), readable only by the exhibit's user (mode 0600).

`exhibit install` makes it as the service's user (``python -m exhibit.narration.make_cache_key``);
where it is missing at run time (a developer's machine, the tests) the first use makes it. A key
file that is not a regular file (a link, a FIFO, a device), that others may read or write, that
belongs to another user, or that is empty, short or oversized is refused with one log line, and
the cache is then not trusted: speech is synthesised again, never read from it. The file is
opened without following a link and without blocking (O_NOFOLLOW | O_NONBLOCK), checked with
fstat and read to a bounded size, so no file put in its place can hang or crash the kiosk.
"""

from __future__ import annotations

import errno
import logging
import os
import secrets
import stat
from collections.abc import Mapping
from pathlib import Path

log = logging.getLogger(__name__)

#: The key's file name in the state folder.
KEY_FILE = "speech-cache.key"
#: Bytes of a key this module makes; a key file must hold at least this many.
KEY_BYTES = 32
#: The most a key file may hold (anything bigger is not one this module made).
MAX_KEY_BYTES = 4096

_warned: set[str] = set()


class KeyRefused(ValueError):
    """A key file that exists but must not be used (why in the message)."""


def state_dir(environ: Mapping[str, str] | None = None) -> Path:
    """$EXHIBIT_STATE_DIR, else $XDG_STATE_HOME/exhibit, else ~/.local/state/exhibit: the same
    folder as exhibit.operations.health.state_dir (a sibling package this layer may not import;
    tests/kiosk/test_speech_cache_hmac.py checks that the two agree)."""
    env = os.environ if environ is None else environ
    if env.get("EXHIBIT_STATE_DIR"):
        return Path(env["EXHIBIT_STATE_DIR"])
    if env.get("XDG_STATE_HOME"):
        return Path(env["XDG_STATE_HOME"]) / "exhibit"
    home = env.get("HOME") or str(Path.home())
    return Path(home) / ".local" / "state" / "exhibit"


def key_path(environ: Mapping[str, str] | None = None) -> Path:
    return state_dir(environ) / KEY_FILE


def read_key(path: Path) -> bytes:
    """The key in ``path``. FileNotFoundError when there is none; KeyRefused when the file must
    not be used; another OSError when it cannot be read."""
    # lstat first: a device is never opened at all (opening a serial port can reset a board)
    mode = os.lstat(path).st_mode
    if stat.S_ISLNK(mode):
        raise KeyRefused("a symbolic link, not the key file itself")
    if not stat.S_ISREG(mode):
        raise KeyRefused("not a regular file")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        if exc.errno == errno.ELOOP:  # made a link since lstat looked
            raise KeyRefused("a symbolic link, not the key file itself") from None
        raise
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise KeyRefused("not a regular file")
        if info.st_mode & 0o077:
            raise KeyRefused(
                f"mode {stat.S_IMODE(info.st_mode):04o}: others may read or change it "
                "(it must be 0600)"
            )
        if info.st_uid != os.geteuid() and os.geteuid() != 0:  # root reads the user's key
            raise KeyRefused(f"owned by uid {info.st_uid}, not this user ({os.geteuid()})")
        if not KEY_BYTES <= info.st_size <= MAX_KEY_BYTES:
            raise KeyRefused(f"{info.st_size} bytes (a key holds {KEY_BYTES} to {MAX_KEY_BYTES})")
        data = os.read(fd, MAX_KEY_BYTES + 1)
    finally:
        os.close(fd)
    if not KEY_BYTES <= len(data) <= MAX_KEY_BYTES:
        raise KeyRefused(f"{len(data)} bytes read (a key holds {KEY_BYTES} to {MAX_KEY_BYTES})")
    return data


def make_key(path: Path) -> bytes:
    """A new random key in ``path`` (mode 0600), unless one appeared there meanwhile: that one
    is read instead. The file is written whole under a temporary name and linked into place, so
    no reader ever sees half a key and an existing file is never replaced. Made by root (an
    `exhibit prepare` run by hand) in a state folder of another user, it is given to that user,
    as the service could not read a key of root's."""
    path.parent.mkdir(parents=True, exist_ok=True)
    folder = os.stat(path.parent)
    key = secrets.token_bytes(KEY_BYTES)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}")
    fd = os.open(
        temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600
    )
    try:
        try:
            os.fchmod(fd, 0o600)
            if os.geteuid() == 0 and folder.st_uid != 0:
                os.fchown(fd, folder.st_uid, folder.st_gid)
            os.write(fd, key)
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(temporary, path)
        except FileExistsError:
            return read_key(path)
    finally:
        temporary.unlink(missing_ok=True)
    return key


def load_key(path: Path | None = None) -> bytes | None:
    """The speech cache's key from ``path`` (default: :func:`key_path`), made there when missing;
    None, with one log line per file and reason, when the file is refused or cannot be read or
    made: the cache is then not trusted."""
    path = key_path() if path is None else Path(path)
    try:
        try:
            return read_key(path)
        except FileNotFoundError:
            return make_key(path)
    except (OSError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
        message = (
            f"speech cache key {path} is refused ({why}); the speech cache is not trusted "
            "and speech is synthesised again"
        )
        if message not in _warned:
            _warned.add(message)
            log.warning("%s", message)
        return None
