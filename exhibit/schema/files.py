"""Reading the files people write, without trusting them.

A config path can name a FIFO (reading blocks forever), /dev/zero (never ends), a 4 GB log or a
file in another encoding. Each is refused with a reason instead: the file is opened without
blocking, must be a regular file (a symlink to one is fine: deployments link configs), is read
up to a size cap, and must be UTF-8 TOML.
"""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path

from exhibit.errors import ConfigError

#: The most a config, timeline, layout or scene file may hold.
MAX_CONFIG_BYTES = 1 << 20


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "a special file"


def read_bytes(path: str | Path, limit: int = MAX_CONFIG_BYTES) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes; ConfigError names the file."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise ConfigError(f"{path}: cannot read: {_kind(info.st_mode)}, not a file")
        if info.st_size > limit:
            raise ConfigError(f"{path}: cannot read: {info.st_size} bytes is over the "
                              f"{limit}-byte limit")
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 16, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:  # grew while being read
            raise ConfigError(f"{path}: cannot read: over the {limit}-byte limit")
        return b"".join(chunks)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


def read_text(path: str | Path, limit: int = MAX_CONFIG_BYTES) -> str:
    data = read_bytes(path, limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start})") from None


def read_toml(path: str | Path, limit: int = MAX_CONFIG_BYTES) -> dict:
    """The parsed TOML document; any failure is a ConfigError naming the file."""
    text = read_text(path, limit)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    except (RecursionError, ValueError, OverflowError, MemoryError) as exc:
        # arrays nested thousands deep, numbers beyond any use
        raise ConfigError(f"{path}: not valid TOML: {type(exc).__name__}") from None


def check_file_ref(path: Path, want_dir: bool = False, limit: int = MAX_CONFIG_BYTES) -> str | None:
    """Why ``path`` cannot be used as a referenced file (or folder), or None when it can."""
    try:
        info = path.stat()
    except OSError as exc:
        what = "folder" if want_dir else "file"
        if isinstance(exc, FileNotFoundError):
            return f"{what} {path} does not exist"
        return f"{what} {path}: {exc.strerror or exc}"
    if want_dir:
        return None if stat.S_ISDIR(info.st_mode) else f"{path} is {_kind(info.st_mode)}, " \
                                                       "not a folder"
    if not stat.S_ISREG(info.st_mode):
        return f"{path} is {_kind(info.st_mode)}, not a file"
    if info.st_size > limit:
        return f"{path} is {info.st_size} bytes, over the {limit}-byte limit"
    return None
