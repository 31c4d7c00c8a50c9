"""The health file's bytes: written in place into blocks it already has, so a full disk does not
stop it, with a checksum so that a reader who catches a write half done notices and reads again.

Each second the kiosk writes one JSON object whose last key is ``"crc32"``: the CRC-32 (8 hex
digits) of the text before ``,"crc32":``. The text is padded with spaces to the file's size and
ends with a line feed, so the file stays JSON for jq and for a reader that ignores the
checksum. The file is made once, by an atomic replace (exhibit.schema.files.write_atomic), at
a size with room to spare (:func:`file_size`: at least MIN_FILE_BYTES, twice the text), with
every block written, not sparse; after that each write overwrites it in place with one
pwrite() of the whole size: no new block, no new inode, nothing that a full disk or a full
inode table refuses. Only when the text outgrows the file, or the file cannot be opened for
writing in place (another owner, a hard link, an older kiosk's small file, something that is not
a regular file), is it replaced atomically again, at a new size. (On a copy-on-write file system
such as btrfs an overwrite still needs new blocks; Debian's default ext4 does not.)

A write in place is not atomic: a reader may get the start of the new text with the end of the
old one. :func:`verify` finds that (the JSON does not parse, or the checksum differs) and the
reader reads again (exhibit.operations.health.read_health). A file without the key (an older
kiosk's, or one a person wrote) is read as before.
"""

from __future__ import annotations

import json
import os
import re
import stat
import zlib
from collections.abc import Callable

from exhibit.schema import files

__all__ = ["CHECK_KEY", "MIN_FILE_BYTES", "Torn", "encode", "file_size", "verify", "write"]

CHECK_KEY = "crc32"
#: The smallest health file made (a kiosk writes 1 to 3 KiB; problems lists may grow).
MIN_FILE_BYTES = 16384
_TAIL = re.compile(rb',"' + CHECK_KEY.encode() + rb'":"([0-9a-f]{8})"\}\s*\Z')


class Torn(ValueError):
    """The text read does not match its checksum: a write was in progress, or the file is
    damaged."""


def encode(data: dict) -> bytes:
    """``data`` as one line of JSON (no NaN: the caller made numbers finite) ending with its
    checksum key; ``data`` must not hold the key itself."""
    body = json.dumps(data, allow_nan=False, separators=(",", ":"))
    if not body.startswith("{") or body == "{}":
        raise ValueError("the health file is a JSON object with at least one key")
    head = body[:-1].encode("utf-8")
    return head + b',"%s":"%08x"}' % (CHECK_KEY.encode(), zlib.crc32(head))


def verify(raw: bytes) -> None:
    """Torn when ``raw`` ends with a checksum key that does not match the text before it."""
    match = _TAIL.search(raw)
    if match is None:
        return  # no checksum: an older kiosk's file, or a person's
    head = raw[: match.start()]
    if f"{zlib.crc32(head):08x}" != match.group(1).decode():
        raise Torn("its checksum does not match its text")


def file_size(length: int) -> int:
    """The size of a file made for a text of ``length`` bytes: room for it to double."""
    size = MIN_FILE_BYTES
    while size < 2 * (length + 1):
        size *= 2
    return size


def write(path: str | os.PathLike, text: bytes, shorter: Callable[[], bytes] | None = None) -> None:
    """Write ``text`` (from :func:`encode`) as the health file at ``path``: in place when the
    file there can take it, else by replacing it with a new one of :func:`file_size`. When
    that replacement fails (a full disk) and ``shorter()`` gives a text that fits the file in
    place, that is written instead. Raises OSError (UnsafePath for a folder, FIFO or device
    there), as exhibit.schema.files.write_atomic does."""
    if _in_place(path, text):
        return
    try:
        files.write_atomic(path, _padded(text, file_size(len(text))), sync=False, make_folder=True)
    except files.UnsafePath:
        raise
    except OSError:
        if shorter is None or not _in_place(path, shorter()):
            raise


def _padded(text: bytes, size: int) -> bytes:
    return text + b" " * (size - len(text) - 1) + b"\n"


def _in_place(path: str | os.PathLike, text: bytes) -> bool:
    """Overwrite the file at ``path`` with ``text``, padded to its size; False (nothing
    written) when there is no such file of ours to overwrite, or it is too small."""
    flags = os.O_WRONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    try:
        fd = os.open(path, flags)
    except OSError:
        return False  # none yet, a link, another owner's, a read-only disk: replace it
    try:
        info = os.fstat(fd)
        if (
            not stat.S_ISREG(info.st_mode)
            or info.st_nlink != 1  # a hard link: another name would change with it
            or info.st_size > 1 << 20
            or info.st_size < len(text) + 1
            or info.st_uid != os.geteuid()
        ):
            return False
        data = _padded(text, info.st_size)
        done = os.pwrite(fd, data, 0)
        while done < len(data):  # a regular file takes it whole; a signal may cut it short
            done += os.pwrite(fd, data[done:], done)
        return True
    finally:
        os.close(fd)
