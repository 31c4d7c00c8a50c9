"""The SQLite file itself: opened in WAL mode, checked, moved aside when broken, one transaction
per session, rotated to its bounds. Only the writer thread (exhibit.operations.sessions.writer)
writes through it."""

from __future__ import annotations

import logging
import os
import sqlite3
import stat
import time
from collections.abc import Callable
from pathlib import Path

from exhibit.operations.sessions.session import Session
import contextlib

log = logging.getLogger("exhibit.operations.sessions")

SCHEMA_VERSION = 1
#: The WAL is truncated to this many bytes after a checkpoint.
WAL_LIMIT = 1 << 20
#: Moved-aside files kept (older ones are deleted): a failing disk must not fill itself.
KEEP_ASIDE = 3

_SCHEMA = """
CREATE TABLE IF NOT EXISTS sessions (
    id INTEGER PRIMARY KEY,
    start REAL NOT NULL,            -- unix seconds (UTC) at takeover
    end REAL NOT NULL,              -- unix seconds at the idle return
    duration_s REAL NOT NULL,       -- end - start, on the monotonic clock
    active_s REAL NOT NULL,         -- takeover to the last real input
    utc_offset_s INTEGER NOT NULL,  -- the kiosk's local offset at start, for local hours
    language TEXT NOT NULL,
    scenes TEXT NOT NULL,           -- JSON list, in the order first shown
    inputs TEXT NOT NULL            -- JSON list, in the order first used
);
CREATE INDEX IF NOT EXISTS sessions_start ON sessions (start);
"""
COLUMNS = (
    "id",
    "start",
    "end",
    "duration_s",
    "active_s",
    "utc_offset_s",
    "language",
    "scenes",
    "inputs",
)


def _aside_name(path: Path, now: float) -> Path:
    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime(now))
    target = path.with_name(f"{path.name}.corrupt-{stamp}")
    n = 1
    while os.path.lexists(target):
        n += 1
        target = path.with_name(f"{path.name}.corrupt-{stamp}-{n}")
    return target


class SessionStore:
    """The database file, opened for writing by one thread (the writer; tests use it directly).

    ``open`` recovers from a broken file by moving it aside and rotates. ``add`` is one
    transaction per session."""

    def __init__(
        self,
        path: str | os.PathLike,
        keep_days: float = 400,
        max_sessions: int = 200_000,
        wall: Callable[[], float] = time.time,
    ):
        self.path = Path(path)
        self.keep_days = keep_days
        self.max_sessions = max_sessions
        self.wall = wall
        self.db: sqlite3.Connection | None = None
        #: Files moved aside by this store (for tests and the log).
        self.moved_aside: list[Path] = []

    # -- opening

    def open(self) -> SessionStore:
        """Open (creating the folder and file if needed); a broken file is moved aside and a
        fresh one started. Raises OSError or sqlite3.Error when even a fresh file cannot be
        made (a read-only folder): the caller logs it and records nothing."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        reason = self._unusable()
        if reason is None:
            try:
                self._connect()
                reason = self._check()
            except sqlite3.DatabaseError as exc:
                if not is_corrupt(exc):
                    self.close()
                    raise
                reason = str(exc)
        if reason is not None:
            self.close()
            self.move_aside(reason)
            self._connect()
            if self._check() is not None:  # pragma: no cover - a fresh file is fine
                raise sqlite3.DatabaseError("a fresh sessions database failed its check")
        self._readable()
        self.rotate()
        return self

    def _readable(self) -> None:
        """World-readable (0644), whatever the service's UMask=0077, so staff run `exhibit
        stats` without sudo, as they read the health file: nothing in it is personal. SQLite
        gives the -wal and -shm files made later the database file's mode."""
        for name in (self.path, Path(f"{self.path}-wal"), Path(f"{self.path}-shm")):
            try:
                if name.stat().st_uid == os.geteuid():
                    os.chmod(name, 0o644)
            except OSError:
                pass

    def _unusable(self) -> str | None:
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            return None
        except OSError as exc:  # a symlink loop, a dangling link's ELOOP
            return f"cannot stat it ({exc.strerror})"
        if not stat.S_ISREG(st.st_mode):
            return "not a regular file"
        return None

    def _connect(self) -> None:
        self.db = sqlite3.connect(
            self.path, timeout=5.0, isolation_level=None, check_same_thread=False
        )
        self.db.execute("PRAGMA auto_vacuum = INCREMENTAL")  # takes effect on a new file only
        mode = self.db.execute("PRAGMA journal_mode = WAL").fetchone()[0]
        if mode.lower() != "wal":
            raise sqlite3.OperationalError(f"journal_mode is {mode}, not wal")
        self.db.execute("PRAGMA synchronous = NORMAL")
        self.db.execute(f"PRAGMA journal_size_limit = {WAL_LIMIT}")

    def _check(self) -> str | None:
        """Why the open file is not a usable sessions database, or None (and the schema made)."""
        assert self.db is not None
        result = self.db.execute("PRAGMA quick_check").fetchall()
        if [r[0] for r in result] != ["ok"]:
            return "quick_check: " + "; ".join(str(r[0]) for r in result[:3])
        version = self.db.execute("PRAGMA user_version").fetchone()[0]
        tables = {
            r[0] for r in self.db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")
        }
        if version > SCHEMA_VERSION:
            return f"schema version {version}, newer than this exhibit's {SCHEMA_VERSION}"
        if tables and "sessions" not in tables:
            return "a database, but not a sessions database (no sessions table)"
        if "sessions" in tables:
            columns = tuple(r[1] for r in self.db.execute("PRAGMA table_info(sessions)"))
            if columns != COLUMNS:
                return f"unexpected columns {columns}"
        self.db.executescript(
            "BEGIN;" + _SCHEMA + f"PRAGMA user_version = {SCHEMA_VERSION};COMMIT;"
        )
        return None

    def move_aside(self, reason: str) -> None:
        target = _aside_name(self.path, self.wall())
        if os.path.lexists(self.path):
            os.rename(self.path, target)
        for suffix in ("-wal", "-journal"):
            side = Path(f"{self.path}{suffix}")
            if os.path.lexists(side):
                os.rename(side, Path(f"{target}{suffix}"))
        shm = Path(f"{self.path}-shm")
        if os.path.lexists(shm):
            os.unlink(shm)
        self.moved_aside.append(target)
        log.warning(
            "sessions database %s unusable (%s): moved aside to %s, starting a fresh one",
            self.path,
            reason,
            target.name,
        )
        asides = sorted(
            p
            for p in self.path.parent.glob(f"{self.path.name}.corrupt-*")
            if not p.name.endswith(("-wal", "-journal"))
        )  # oldest first, by name
        old = asides[:-KEEP_ASIDE]
        for p in old:
            for q in (p, Path(f"{p}-wal"), Path(f"{p}-journal")):
                with contextlib.suppress(OSError):
                    q.unlink()

    # -- writing

    def add(self, session: Session) -> int:
        """Store one session in its own transaction; returns its row id."""
        assert self.db is not None, "open() first"
        with _transaction(self.db):
            cursor = self.db.execute(
                "INSERT INTO sessions (start, end, duration_s, active_s, utc_offset_s, "
                "language, scenes, inputs) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                session.row(),
            )
        rowid = cursor.lastrowid
        assert rowid is not None  # set by the INSERT
        return int(rowid)

    def rotate(self) -> int:
        """Delete sessions older than keep_days, then all but the newest max_sessions, and give
        the freed pages back to the file system. Returns how many were deleted."""
        assert self.db is not None
        cutoff = self.wall() - self.keep_days * 86400.0
        with _transaction(self.db):
            old = self.db.execute("DELETE FROM sessions WHERE start < ?", (cutoff,)).rowcount
            extra = self.db.execute(
                "DELETE FROM sessions WHERE id <= (SELECT id FROM sessions ORDER BY id DESC "
                "LIMIT 1 OFFSET ?)",
                (self.max_sessions,),
            ).rowcount
        if old + extra:
            # executescript steps it to the end (execute() would free one page only)
            self.db.executescript("PRAGMA incremental_vacuum;")
            self.db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            log.info(
                "sessions: %d older than %g days and %d beyond the newest %d deleted",
                old,
                self.keep_days,
                extra,
                self.max_sessions,
            )
        return old + extra

    def count(self) -> int:
        assert self.db is not None
        return int(self.db.execute("SELECT count(*) FROM sessions").fetchone()[0])

    def close(self) -> None:
        if self.db is not None:
            try:
                self.db.close()
            finally:
                self.db = None


class _transaction:
    """BEGIN IMMEDIATE ... COMMIT, or ROLLBACK on an error (autocommit connection)."""

    def __init__(self, db: sqlite3.Connection):
        self.db = db

    def __enter__(self):
        self.db.execute("BEGIN IMMEDIATE")

    def __exit__(self, kind, exc, tb):
        if kind is None:
            self.db.execute("COMMIT")
        elif self.db.in_transaction:
            self.db.execute("ROLLBACK")
        return False


def is_corrupt(exc: sqlite3.Error) -> bool:
    """The file is broken (not a database, malformed), as opposed to unreachable or busy."""
    name = getattr(exc, "sqlite_errorname", "")
    return name.startswith(("SQLITE_CORRUPT", "SQLITE_NOTADB")) or (
        not name and any(w in str(exc) for w in ("malformed", "not a database"))
    )
