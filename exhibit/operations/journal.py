"""Log records to the systemd journal with structured fields, in its native protocol.

Python's logging to stderr reaches the journal as plain lines. To make `journalctl -u exhibit
EXHIBIT_SCENE=hopf` or `EXHIBIT_MODE=visitor PRIORITY=3` work, :class:`JournalHandler` sends each
record as one datagram to journald's socket (/run/systemd/journal/socket) in the journal's
native protocol (systemd's docs: "Native Journal Protocol"): ``KEY=value`` lines, and for a value
holding a line feed (a traceback) the binary-safe form ``KEY\\n`` + its length as 64-bit little
endian + the value + ``\\n``. A record too large for one datagram goes in a sealed memfd passed
along (SCM_RIGHTS), as sd_journal_send does. No dependency: python-systemd has no wheel on PyPI.

Fields: MESSAGE (the formatted record, traceback included), PRIORITY (syslog's 2..7),
SYSLOG_IDENTIFIER, LOGGER, CODE_FILE, CODE_LINE, CODE_FUNC, THREAD_NAME; then every field of
:data:`context` (the kiosk keeps EXHIBIT_MODE and EXHIBIT_SCENE there, so every record, an
error too, says what was on screen); then the record's own upper-case attributes, given as
``log.info(..., extra={"EXHIBIT_SCENE": "hopf"})``.

:func:`install` switches the root logger's stderr handlers to the journal only when stderr is
the journal (systemd sets $JOURNAL_STREAM to its device:inode for a service whose output goes
there; a terminal or a pipe does not match, so a person running `exhibit run` by hand keeps the
log on the screen) and the socket exists. A record that cannot be sent (journald restarting, its
queue full: the socket never blocks the frame loop) goes to stderr instead, as before.
"""

from __future__ import annotations

import array
import errno
import fcntl
import logging
import os
import re
import socket
import struct
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TextIO

__all__ = [
    "JOURNAL_SOCKET",
    "JournalHandler",
    "context",
    "set_context",
    "encode",
    "stderr_is_journal",
    "install",
    "last_errno",
]

JOURNAL_SOCKET = "/run/systemd/journal/socket"
#: Fields added to every record sent; the kiosk sets EXHIBIT_MODE and EXHIBIT_SCENE.
context: dict[str, str] = {}
#: A field name journald accepts from a client: upper-case letters, digits and underscores, not
#: starting with a digit or an underscore (those are the journal's trusted fields), <= 64 long.
_FIELD = re.compile(r"[A-Z][A-Z0-9_]{0,63}")
_PRIORITY = ((logging.CRITICAL, 2), (logging.ERROR, 3), (logging.WARNING, 4), (logging.INFO, 6))
_SEALS = (
    getattr(fcntl, "F_SEAL_SHRINK", 2)
    | getattr(fcntl, "F_SEAL_GROW", 4)
    | getattr(fcntl, "F_SEAL_WRITE", 8)
    | getattr(fcntl, "F_SEAL_SEAL", 1)
)


def set_context(**fields: str | None) -> None:
    """Set fields for every record from now on (None removes one)."""
    for key, value in fields.items():
        if not _FIELD.fullmatch(key):
            raise ValueError(f"{key!r} is not a journal field name")
        if value is None:
            context.pop(key, None)
        else:
            context[key] = str(value)


def encode(fields: Mapping[str, object]) -> bytes:
    """The native protocol's datagram for ``fields``: ``KEY=value\\n``, or the length-prefixed
    form for a value with a line feed. Names that journald would refuse are left out."""
    out = bytearray()
    for key, value in fields.items():
        if not _FIELD.fullmatch(key):
            continue
        data = value if isinstance(value, bytes) else str(value).encode("utf-8", "replace")
        if b"\n" in data:
            out += key.encode() + b"\n" + struct.pack("<Q", len(data)) + data + b"\n"
        else:
            out += key.encode() + b"=" + data + b"\n"
    return bytes(out)


def priority(levelno: int) -> int:
    """syslog's priority for a logging level: CRITICAL 2, ERROR 3, WARNING 4, INFO 6, else 7."""
    return next((p for level, p in _PRIORITY if levelno >= level), 7)


class JournalHandler(logging.Handler):
    """Sends records to the journal's socket at ``socket_path`` (injectable for tests); a record
    that cannot be sent goes to ``fallback`` (a stderr handler unless given)."""

    def __init__(
        self,
        socket_path: str | os.PathLike = JOURNAL_SOCKET,
        identifier: str = "exhibit",
        fallback: logging.Handler | None = None,
        level: int = logging.NOTSET,
    ):
        super().__init__(level)
        self.socket_path = os.fspath(socket_path)
        self.identifier = identifier
        self.fallback = fallback if fallback is not None else logging.StreamHandler(sys.stderr)
        self.failures = 0
        #: The errno name of the last send that failed, None once one succeeds (the health
        #: file's storage errors: exhibit.operations.storage).
        self.errno: str | None = None
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
        self._sock.setblocking(False)  # a full journal queue must not stall the frame loop

    def fields(self, record: logging.LogRecord) -> dict[str, object]:
        fields: dict[str, object] = {
            "MESSAGE": self.format(record),
            "PRIORITY": priority(record.levelno),
            "SYSLOG_IDENTIFIER": self.identifier,
            "LOGGER": record.name,
            "CODE_FILE": record.pathname,
            "CODE_LINE": record.lineno,
            "CODE_FUNC": record.funcName,
            "THREAD_NAME": record.threadName,
        }
        fields.update(context)
        for key, value in vars(record).items():  # extra={"EXHIBIT_SCENE": ...}
            if value is not None and _FIELD.fullmatch(key):
                fields[key] = value
        return fields

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.send(encode(self.fields(record)))
            self.errno = None
        except Exception as exc:  # noqa: BLE001 - the log line must still reach someone
            self.failures += 1
            code = getattr(exc, "errno", None)
            self.errno = errno.errorcode.get(code, str(code)) if isinstance(code, int) else None
            if self.formatter is not None:
                self.fallback.setFormatter(self.formatter)
            self.fallback.handle(record)

    def send(self, data: bytes) -> None:
        """One datagram; too large for one (EMSGSIZE, ENOBUFS), the data in a sealed memfd."""
        try:
            self._sock.sendto(data, self.socket_path)
        except OSError as exc:
            if exc.errno not in (errno.EMSGSIZE, errno.ENOBUFS):
                raise
            fd = os.memfd_create("exhibit-journal", os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(fd, view) :]
                fcntl.fcntl(fd, fcntl.F_ADD_SEALS, _SEALS)
                # (socket.send_fds would drop the address: sendmsg with SCM_RIGHTS itself)
                self._sock.sendmsg(
                    [b""],
                    [(socket.SOL_SOCKET, socket.SCM_RIGHTS, array.array("i", [fd]))],
                    0,
                    self.socket_path,
                )
            finally:
                os.close(fd)

    def close(self) -> None:
        try:
            self._sock.close()
        finally:
            super().close()


def stderr_is_journal(
    environ: Mapping[str, str] | None = None, stream: TextIO | None = None
) -> bool:
    """Whether ``stream`` (stderr) is the journal: $JOURNAL_STREAM ("DEVICE:INODE", set by systemd
    for a service logging there) names the file ``stream`` writes to."""
    env = os.environ if environ is None else environ
    value = env.get("JOURNAL_STREAM", "")
    stream = sys.stderr if stream is None else stream
    try:
        dev, ino = (int(x) for x in value.split(":"))
        info = os.fstat(stream.fileno())
    except (ValueError, OSError, AttributeError):
        return False
    return (info.st_dev, info.st_ino) == (dev, ino)


def install(
    environ: Mapping[str, str] | None = None,
    stream: TextIO | None = None,
    socket_path: str | os.PathLike = JOURNAL_SOCKET,
    logger: logging.Logger | None = None,
) -> JournalHandler | None:
    """Route ``logger``'s (the root logger's) stderr handlers to the journal when stderr is the
    journal and its socket exists; returns the handler, or None when logging stays as it was.
    Idempotent. The replaced handlers' level and formatter carry over, and become the fallback."""
    logger = logging.getLogger() if logger is None else logger
    existing = next((h for h in logger.handlers if isinstance(h, JournalHandler)), None)
    if existing is not None:
        return existing
    stream = sys.stderr if stream is None else stream
    if not stderr_is_journal(environ, stream) or not Path(socket_path).is_socket():
        return None
    on_stderr = [
        h
        for h in logger.handlers
        if type(h) is logging.StreamHandler and getattr(h, "stream", None) is stream
    ]
    fallback = on_stderr[0] if on_stderr else logging.StreamHandler(stream)
    handler = JournalHandler(socket_path, fallback=fallback, level=fallback.level)
    handler.setFormatter(fallback.formatter or logging.Formatter("%(name)s: %(message)s"))
    for h in on_stderr:
        logger.removeHandler(h)
    logger.addHandler(handler)
    return handler


def last_errno(logger: logging.Logger | None = None) -> str | None:
    """The errno name of the last record the installed JournalHandler of ``logger`` (the root
    logger's) could not send, None when it sent the last one or none is installed."""
    logger = logging.getLogger() if logger is None else logger
    handler = next((h for h in logger.handlers if isinstance(h, JournalHandler)), None)
    return None if handler is None else handler.errno
