"""The thread that owns the database, so a slow disk never stalls a frame: finished sessions
come through a bounded queue, and a full queue drops one rather than wait. A session the
database refuses (a full or read-only state disk) waits in a bounded backlog and is written,
in order, once the disk takes writes again: a visitor who came while the disk was full is
still counted."""

from __future__ import annotations

import logging
import os
import queue
import sqlite3
import threading
import time
from collections import deque
from collections.abc import Callable

from exhibit.operations.sessions.session import Session
from exhibit.operations.storage import errno_name, sqlite_errno
from exhibit.operations.sessions.store import SessionStore, is_corrupt

log = logging.getLogger("exhibit.operations.sessions")

#: Finished sessions waiting for the writer; one ends every few seconds at the busiest, so a
#: full queue means the disk has stopped answering, and then dropping is right.
QUEUE_SIZE = 256
#: Rotation runs at open, then after this many sessions or this many seconds, whichever first.
ROTATE_EVERY = 200
ROTATE_S = 3600.0
#: Sessions kept while the database refuses writes (a few hundred bytes each: a busy day's
#: worth, about 2 MB), and how often they are tried again when no new session comes.
BACKLOG = 5000
RETRY_S = 5.0

_STOP = object()


class SessionWriter:
    """The thread that owns the database: finished sessions arrive through a bounded queue.

    ``submit`` never blocks (a full queue drops the session and counts it in ``dropped``).
    ``on_commit(session, row_id)``, if given, is called after each commit (tests)."""

    def __init__(
        self,
        path: str | os.PathLike,
        keep_days: float = 400,
        max_sessions: int = 200_000,
        wall: Callable[[], float] = time.time,
        queue_size: int = QUEUE_SIZE,
        on_commit: Callable[[Session, int], None] | None = None,
    ):
        self.store = SessionStore(path, keep_days, max_sessions, wall)
        self.queue: queue.Queue = queue.Queue(maxsize=queue_size)
        self.on_commit = on_commit
        self.dropped = 0  # the queue was full
        self.failed = 0  # the database refused the write, and the session is lost
        self.written = 0
        #: Sessions the database refused, oldest first, to be written when it takes them.
        self.backlog: deque[Session] = deque()
        self._refused = 0
        self.ready = threading.Event()  # set once the database is open (or given up)
        self.usable = False
        #: Why sessions are not recorded (None while they are): for the health file.
        self.reason: str | None = None
        #: The errno name ("ENOSPC", "EROFS", "EACCES") of the last open or write that failed,
        #: None once one succeeds: the health file's storage errors (exhibit.operations.storage).
        self.errno: str | None = None
        self._thread = threading.Thread(target=self._run, name="exhibit-sessions", daemon=True)
        self._thread.start()

    def submit(self, session: Session) -> bool:
        try:
            self.queue.put_nowait(session)
            return True
        except queue.Full:
            self.dropped += 1
            if self.dropped & (self.dropped - 1) == 0:  # 1st, 2nd, 4th...: a few lines at most
                log.warning("sessions: the writer is behind, %d session(s) dropped", self.dropped)
            return False

    def close(self, timeout: float = 5.0) -> None:
        """Write what is queued (waiting at most ``timeout`` s), then stop the thread."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                self.queue.put(_STOP, timeout=max(0.0, deadline - time.monotonic()))
                break
            except queue.Full:
                if time.monotonic() >= deadline:
                    break
        self._thread.join(max(0.0, deadline - time.monotonic()))

    def _run(self) -> None:
        try:
            self.store.open()
            self.usable = True
        except (OSError, sqlite3.Error) as exc:
            self.reason = f"cannot open {self.store.path} ({getattr(exc, 'strerror', None) or exc})"
            self.errno = errno_name(sqlite_errno(exc))
            log.warning(
                "sessions: cannot open %s (%s): visitor sessions are not recorded",
                self.store.path,
                getattr(exc, "strerror", None) or exc,
            )
        finally:
            self.ready.set()
        last_rotate, since_rotate = time.monotonic(), 0
        try:
            while True:
                try:
                    item = self.queue.get(timeout=RETRY_S if self.backlog else None)
                except queue.Empty:
                    since_rotate += self._flush()
                    continue
                if item is _STOP:
                    self._flush()
                    break
                if not self.usable:
                    self.failed += 1
                    continue
                self._keep(item)
                since_rotate += self._flush()
                if since_rotate >= ROTATE_EVERY or time.monotonic() - last_rotate >= ROTATE_S:
                    last_rotate, since_rotate = time.monotonic(), 0
                    try:
                        self.store.rotate()
                    except sqlite3.Error as exc:
                        log.warning("sessions: rotation failed: %s", exc)
        finally:
            if self.backlog:
                self.failed += len(self.backlog)
                log.warning(
                    "sessions: %d session(s) not written at exit (%s)",
                    len(self.backlog),
                    self.errno or "the database refused them",
                )
            self.store.close()

    def _keep(self, session: Session) -> None:
        """Queue ``session`` behind those still waiting; the oldest goes when BACKLOG are."""
        if len(self.backlog) >= BACKLOG:
            self.backlog.popleft()
            self.failed += 1
        self.backlog.append(session)

    def _flush(self) -> int:
        """Write the waiting sessions in order, up to the first the database refuses; how many
        were written."""
        done = 0
        while self.backlog and self.usable:
            session = self.backlog[0]
            row = self._write(session)
            if row is None:
                break
            self.backlog.popleft()
            self.written += 1
            done += 1
            if self.on_commit is not None:
                self.on_commit(session, row)
        return done

    def _write(self, session: Session) -> int | None:
        """Add one session; a file found broken now is moved aside and the write retried once."""
        for attempt in (1, 2):
            try:
                row = self.store.add(session)
                self.errno = None
                return row
            except sqlite3.Error as exc:
                error: Exception = exc
                self.errno = errno_name(sqlite_errno(exc))
                if attempt == 1 and is_corrupt(exc):
                    try:
                        self.store.close()
                        self.store.move_aside(str(exc))
                        self.store.open()
                        continue
                    except (OSError, sqlite3.Error) as again:
                        error = again
                        self.usable = False
                        self.reason = f"cannot reopen {self.store.path} ({again})"
                self._refused += 1
                if self._refused & (self._refused - 1) == 0:
                    log.warning(
                        "sessions: a session was not written (%s; %d refusals so far), "
                        "kept to try again",
                        error,
                        self._refused,
                    )
                return None
        return None
