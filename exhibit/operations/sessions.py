"""What visitors actually do: one row per visitor session in a local SQLite database.

A session runs from a visitor's takeover to the idle return to attract mode. It records when it
started and ended (wall clock, with the kiosk's UTC offset then, so a curator's report counts
local hours wherever it is made), how long it lasted, when the last real input came, the scenes
shown in order (each once), the inputs used ("controller.stick", "knobs.knob", ...: a configured
device name and what kind of control) and the language. Nothing else: no picture, no timing of
single events, no identifier that could link two sessions to one person. The museum learns what
its visitors do, not who they are.

Why it is built like this:

* **Never on the frame path.** The frame loop only keeps the current session in memory
  (:class:`SessionLog`, a few list appends a frame). A finished session goes into a bounded
  queue; a writer thread (:class:`SessionWriter`) owns the database. A full queue drops the
  session and counts it: a slow disk must never stall a frame. A recorder bug is logged once
  and turns the recorder off, so it cannot make frames fail.
* **Survives a power cut.** WAL mode with ``synchronous=NORMAL``: each session is one
  transaction, and the file is consistent after a crash at any instant (a test kills a writing
  process with SIGKILL and reopens it with ``PRAGMA integrity_check``). A power cut (not a mere
  crash) may lose the last sessions written before it, never the file: syncing every session
  would wear the kiosk's flash for rows a curator will not miss.
* **Bounded.** At open and every ROTATE_EVERY sessions (or ROTATE_S seconds), sessions older
  than ``keep_days`` are deleted, then all but the newest ``max_sessions``; incremental
  auto-vacuum gives the pages back, so the file shrinks too, and the WAL is truncated to
  WAL_LIMIT after checkpoints.
* **Never stops the kiosk.** A file that is not a database, fails its quick check, is from a
  newer exhibit or is not a regular file (a FIFO, a folder) is moved aside, renamed
  ``NAME.corrupt-YYYYmmddTHHMMSSZ`` (the last KEEP_ASIDE of them are kept), and a fresh one is
  started, with one log line. A folder that cannot be written turns the log off, with one line.

Where: ``[sessions] path`` in kiosk.toml, else ``sessions.db`` in the state folder
(exhibit.operations.health.state_dir: $EXHIBIT_STATE_DIR, /var/lib/exhibit under systemd).
`exhibit stats` reads it (:func:`read_sessions`).

Why one module of this size: the recorder, its SQLite store and the writer thread share one row
format and one queue; apart, each would restate them."""

from __future__ import annotations

import json
import logging
import math
import os
import queue
import sqlite3
import stat
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Callable, Iterable

from pydantic import PlainValidator

from exhibit.devices.base import Event, Kind
from exhibit.errors import ExhibitError
from exhibit.operations.health import SERVICE_STATE_DIR, state_dir
from exhibit.schema import Model
from exhibit.schema.files import loads_json
from exhibit.schema.types import Integer, fail, text_check

log = logging.getLogger("exhibit.operations.sessions")

__all__ = [
    "DB_FILE",
    "SessionsSection",
    "SessionsConfig",
    "sessions_config",
    "Session",
    "SessionStore",
    "SessionWriter",
    "SessionLog",
    "SessionsError",
    "input_name",
    "read_sessions",
    "default_db_path",
    "candidate_paths",
    "open_session_log",
]

DB_FILE = "sessions.db"
SCHEMA_VERSION = 1
#: Finished sessions waiting for the writer; one ends every few seconds at the busiest, so a
#: full queue means the disk has stopped answering, and then dropping is right.
QUEUE_SIZE = 256
#: Rotation runs at open, then after this many sessions or this many seconds, whichever first.
ROTATE_EVERY = 200
ROTATE_S = 3600.0
#: The WAL is truncated to this many bytes after a checkpoint.
WAL_LIMIT = 1 << 20
#: Moved-aside files kept (older ones are deleted): a failing disk must not fill itself.
KEEP_ASIDE = 3
#: An ABS control counts as used past this deflection (a real push, never noise or drift).
STICK_USED = 0.5
#: What a kind of control is called in the inputs list.
KIND_NAMES = {Kind.REL: "knob", Kind.ABS: "stick", Kind.BUTTON: "button"}
#: Lists longer than this are cut (a fuzzing device with a thousand names must not bloat rows).
MAX_ITEMS = 64

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
_COLUMNS = (
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


# ---------------------------------------------------------------------- [sessions] in kiosk.toml


def _db_path(value: Any) -> str:
    """ "" (the state folder) or an absolute path to a file: a relative one would land beside
    the site config in /etc, which the kiosk must not write."""
    value = text_check(4096, empty_ok=True)(value)
    if value and not os.path.isabs(value):
        raise fail('must be an absolute path, or "" for sessions.db in the state folder', value)
    if value.endswith("/"):
        raise fail("must name a file, not a folder", value)
    return value


class SessionsSection(Model):
    """``[sessions]`` of kiosk.toml, as written."""

    enabled: bool = True
    path: Annotated[str, PlainValidator(_db_path)] = ""
    keep_days: Annotated[int, Integer(1, 3650)] = 400
    max_sessions: Annotated[int, Integer(100, 10_000_000)] = 200_000


@dataclass(frozen=True)
class SessionsConfig:
    """``[sessions]``, checked: ``path`` None means sessions.db in the state folder."""

    enabled: bool = True
    path: Path | None = None
    keep_days: int = 400
    max_sessions: int = 200_000

    def resolved(self) -> Path:
        return self.path if self.path is not None else state_dir() / DB_FILE


def sessions_config(section: SessionsSection) -> SessionsConfig:
    return SessionsConfig(
        section.enabled,
        Path(section.path) if section.path else None,
        section.keep_days,
        section.max_sessions,
    )


def default_db_path() -> Path:
    return state_dir() / DB_FILE


def candidate_paths() -> list[Path]:
    """Where a reader looks without --db: the state folder, then the service's (so staff can
    run `exhibit stats` from their own shell), as exhibit.operations.health does for the health
    file."""
    paths = [default_db_path()]
    service = SERVICE_STATE_DIR / DB_FILE
    if not os.environ.get("EXHIBIT_STATE_DIR") and service not in paths:
        paths.append(service)
    return paths


# ---------------------------------------------------------------------- one session


@dataclass
class Session:
    """One visitor session, as stored."""

    start: float
    end: float
    duration_s: float
    active_s: float
    utc_offset_s: int
    language: str = "en"
    scenes: list[str] = field(default_factory=list)
    inputs: list[str] = field(default_factory=list)

    def row(self) -> tuple:
        return (
            self.start,
            self.end,
            self.duration_s,
            self.active_s,
            self.utc_offset_s,
            self.language,
            json.dumps(self.scenes[:MAX_ITEMS]),
            json.dumps(self.inputs[:MAX_ITEMS]),
        )

    @property
    def local_start(self) -> float:
        """Seconds since 1970-01-01 00:00 in the kiosk's local time: day and hour buckets."""
        return self.start + self.utc_offset_s


def input_name(event: Event) -> str | None:
    """What an event says was used ("controller.stick"), or None if it is no real use: a knob
    that did not move, a button released, a stick within STICK_USED of rest."""
    if event.kind is Kind.ABS:
        if abs(event.value) < STICK_USED:
            return None
    elif not event.value or (event.kind is Kind.BUTTON and event.value < 0):
        return None
    return f"{event.device}.{KIND_NAMES.get(event.kind, str(event.kind.value))}"


# ---------------------------------------------------------------------- the database


class SessionsError(ExhibitError):
    """The sessions database cannot be read (for `exhibit stats`): the message says why."""


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

    def open(self) -> "SessionStore":
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
                if not _is_corrupt(exc):
                    self.close()
                    raise
                reason = str(exc)
        if reason is not None:
            self.close()
            self._move_aside(reason)
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
            if columns != _COLUMNS:
                return f"unexpected columns {columns}"
        self.db.executescript(
            "BEGIN;" + _SCHEMA + f"PRAGMA user_version = {SCHEMA_VERSION};COMMIT;"
        )
        return None

    def _move_aside(self, reason: str) -> None:
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
                try:
                    q.unlink()
                except OSError:
                    pass

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


def _is_corrupt(exc: sqlite3.Error) -> bool:
    """The file is broken (not a database, malformed), as opposed to unreachable or busy."""
    name = getattr(exc, "sqlite_errorname", "")
    return name.startswith(("SQLITE_CORRUPT", "SQLITE_NOTADB")) or (
        not name and any(w in str(exc) for w in ("malformed", "not a database"))
    )


# ---------------------------------------------------------------------- the writer thread

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
        self.failed = 0  # the database refused the write
        self.written = 0
        self.ready = threading.Event()  # set once the database is open (or given up)
        self.usable = False
        #: Why sessions are not recorded (None while they are): for the health file.
        self.reason: str | None = None
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
                item = self.queue.get()
                if item is _STOP:
                    break
                if not self.usable:
                    self.failed += 1
                    continue
                row = self._write(item)
                if row is not None:
                    self.written += 1
                    since_rotate += 1
                    if self.on_commit is not None:
                        self.on_commit(item, row)
                if since_rotate >= ROTATE_EVERY or time.monotonic() - last_rotate >= ROTATE_S:
                    last_rotate, since_rotate = time.monotonic(), 0
                    try:
                        self.store.rotate()
                    except sqlite3.Error as exc:
                        log.warning("sessions: rotation failed: %s", exc)
        finally:
            self.store.close()

    def _write(self, session: Session) -> int | None:
        """Add one session; a file found broken now is moved aside and the write retried once."""
        for attempt in (1, 2):
            try:
                return self.store.add(session)
            except sqlite3.Error as exc:
                error: Exception = exc
                if attempt == 1 and _is_corrupt(exc):
                    try:
                        self.store.close()
                        self.store._move_aside(str(exc))
                        self.store.open()
                        continue
                    except (OSError, sqlite3.Error) as again:
                        error = again
                        self.usable = False
                        self.reason = f"cannot reopen {self.store.path} ({again})"
                self.failed += 1
                if self.failed & (self.failed - 1) == 0:
                    log.warning(
                        "sessions: a session was not written (%s; %d so far)", error, self.failed
                    )
                return None
        return None


# ---------------------------------------------------------------------- the recorder


class SessionLog:
    """What the kiosk calls, on the frame thread: cheap, never raises, never blocks.

    ``observe(mode, scene, events, now)`` once a frame does it all; ``started``, ``scene``,
    ``input`` and ``ended`` are the steps, for callers that know the transitions. ``now`` is the
    kiosk's monotonic clock (lengths are differences of it, immune to clock steps); the wall
    clock dates the session. ``language`` is the language on screen (the kiosk sets it as it
    changes: exhibit.kiosk.language).
    """

    def __init__(
        self,
        writer: SessionWriter | None,
        wall: Callable[[], float] = time.time,
        language: str = "en",
    ):
        self.writer = writer
        self.wall = wall
        self.language = language
        self.current: Session | None = None
        self._start = self._last_input = 0.0
        self._broken = False

    def health(self) -> dict:
        """For the health file: what the writer has done (sessions written, dropped because it
        was behind, refused by the database) and the language on screen."""
        w = self.writer
        counts = {"written": w.written, "dropped": w.dropped, "failed": w.failed} if w else {}
        # What the writer really does: recording only once the database is open and while it
        # stays usable; otherwise false, with the reason the log gave.
        reason = None
        if w is None:
            reason = "no writer"
        elif self._broken:
            reason = "the recorder failed (see the log)"
        elif not w.ready.is_set():
            reason = "opening the database"
        elif not w.usable:
            reason = w.reason or "the database cannot be written"
        state: dict[str, int | str] = {**counts, "recording": reason is None}
        if reason is not None:
            state["reason"] = reason
        return {"sessions": state, "language": self.language}

    # -- the steps

    def started(self, now: float, scene: str) -> None:
        wall = self.wall()
        offset = int(time.localtime(wall).tm_gmtoff) if math.isfinite(wall) else 0
        self.current = Session(
            start=wall,
            end=wall,
            duration_s=0.0,
            active_s=0.0,
            utc_offset_s=offset,
            language=self.language,
        )
        self._start = self._last_input = now
        self.scene(scene)

    def scene(self, name: str) -> None:
        if self.current is not None and name not in self.current.scenes:
            self.current.scenes.append(name)

    def input(self, name: str, now: float | None = None) -> None:
        if self.current is None:
            return
        if name not in self.current.inputs:
            self.current.inputs.append(name)
        if now is not None and now > self._last_input:
            self._last_input = now

    def inputs(self, events: Iterable[Event], now: float) -> None:
        for event in events:
            name = input_name(event)
            if name is not None:
                self.input(name, now)

    def ended(self, now: float) -> Session | None:
        """End the session (if one is open) and hand it to the writer; returns it."""
        session, self.current = self.current, None
        if session is None:
            return None
        session.duration_s = max(0.0, now - self._start)
        session.active_s = min(session.duration_s, max(0.0, self._last_input - self._start))
        session.end = session.start + session.duration_s
        session.language = self.language
        if self.writer is not None:
            self.writer.submit(session)
        return session

    # -- once a frame

    def observe(self, mode: str, scene: str, events: Iterable[Event], now: float) -> None:
        """Follow the kiosk: a visitor frame starts a session or continues it (the scene and
        the inputs used), an attract frame ends the open one. A bug here is logged once and
        turns recording off: it must never make a frame fail."""
        if self._broken:
            return
        try:
            if mode == "visitor":
                if self.current is None:
                    self.started(now, scene)
                else:
                    self.scene(scene)
                self.inputs(events, now)
            elif self.current is not None:
                self.ended(now)
        except Exception:  # noqa: BLE001 - statistics are never worth a frame
            self._broken = True
            log.exception(
                "sessions: the recorder failed; visitor sessions are no longer "
                "recorded until the kiosk restarts"
            )

    def close(self, now: float, timeout: float = 5.0) -> None:
        """End an open session (the kiosk is stopping) and let the writer finish."""
        try:
            if self.current is not None:
                self.ended(now)
        finally:
            if self.writer is not None:
                self.writer.close(timeout)


def open_session_log(config: SessionsConfig) -> SessionLog | None:
    """The kiosk's recorder for ``[sessions]``, or None when it is disabled. Never raises: the
    database is opened on the writer thread, which logs any problem."""
    if not config.enabled:
        return None
    writer = SessionWriter(config.resolved(), config.keep_days, config.max_sessions)
    return SessionLog(writer)


# ---------------------------------------------------------------------- reading (exhibit stats)


def read_sessions(
    path: str | os.PathLike, since_local: float | None = None, skipped: Counter | None = None
) -> list[Session]:
    """Every stored session (starting at or after ``since_local``, in the kiosk's local seconds
    since 1970, when given), oldest first. Read-only: never creates, rotates or repairs.
    SessionsError says, in one line, why a file cannot be read. A row whose values are out of
    bounds (:func:`_session_from_row`: a date outside 2000..2200, a duration over a week or not
    finite, JSON lists too long or nested) is left out and, with ``skipped``, counted there by
    reason."""
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise SessionsError(f"no sessions database at {path}") from None
    except OSError as exc:
        raise SessionsError(f"{path}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(st.st_mode):
        raise SessionsError(f"{path} is a folder, not a sessions database")
    if not stat.S_ISREG(st.st_mode):
        raise SessionsError(
            f"{path} is not a regular file (a FIFO or a device?), not a sessions database"
        )
    if not os.access(path, os.R_OK):
        raise SessionsError(f"{path}: permission denied")
    try:
        db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, timeout=5.0)
    except sqlite3.Error as exc:
        raise SessionsError(f"{path}: cannot open: {exc}") from None
    try:
        tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if "sessions" not in tables:
            raise SessionsError(f"{path}: a SQLite database, but not a sessions database")
        query = (
            f"SELECT {', '.join(_COLUMNS[1:])} FROM sessions"
            + (" WHERE start + utc_offset_s >= ?" if since_local is not None else "")
            + " ORDER BY start, id"
        )
        rows = db.execute(query, () if since_local is None else (since_local,)).fetchall()
    except sqlite3.DatabaseError as exc:
        what = "not a sessions database" if _is_corrupt(exc) else "cannot read it"
        raise SessionsError(f"{path}: {what} ({exc})") from None
    finally:
        db.close()
    out = []
    for row in rows:
        try:
            out.append(_session_from_row(*row))
        except ValueError as exc:  # a row written by hand or by a broken kiosk: counted, not used
            if skipped is not None:
                skipped[str(exc)] += 1
    return out


#: What a stored row must hold to be counted (a hand-written or damaged row is skipped, and
#: `exhibit stats` says how many and why): sessions that start (in local time) within these years,
#: last at most MAX_SESSION_S, with a UTC offset of at most a day and short name lists.
FIRST_YEAR, LAST_YEAR = 2000, 2200
_FIRST_S = 946684800.0  # 2000-01-01 00:00
_END_S = 7289654400.0  # 2201-01-01 00:00
MAX_SESSION_S = 7 * 86400.0
MAX_OFFSET_S = 86400
#: The most JSON text a scenes or inputs cell may hold (the kiosk writes MAX_ITEMS short names).
MAX_LIST_TEXT = 1 << 16
MAX_LANGUAGE = 64


def _real(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{what} is not a number")
    try:
        value = float(value)
    except OverflowError:  # an integer beyond any float
        raise ValueError(f"{what} is out of range") from None
    if not math.isfinite(value):
        raise ValueError(f"{what} is not finite")
    return value


def _session_from_row(start, end, duration, active, offset, language, scenes, inputs) -> Session:
    """The Session a stored row describes; ValueError with a short reason (the same for every
    row with that problem, so they can be counted) when any value is out of bounds."""
    start, end = _real(start, "start"), _real(end, "end")
    duration, active = _real(duration, "duration"), _real(active, "active time")
    if isinstance(offset, bool) or not isinstance(offset, int) or abs(offset) > MAX_OFFSET_S:
        raise ValueError("utc offset is not whole seconds within a day")
    if not _FIRST_S <= start + offset < _END_S:
        raise ValueError(f"start outside the years {FIRST_YEAR}..{LAST_YEAR} (clock not set?)")
    if not 0.0 <= duration <= MAX_SESSION_S:
        raise ValueError(f"duration outside 0..{MAX_SESSION_S:.0f} s")
    if not 0.0 <= active <= MAX_SESSION_S:
        raise ValueError(f"active time outside 0..{MAX_SESSION_S:.0f} s")
    if not isinstance(language, str) or len(language) > MAX_LANGUAGE:
        raise ValueError(f"language is not a text of at most {MAX_LANGUAGE} characters")
    return Session(
        start,
        end,
        duration,
        active,
        offset,
        language,
        _names(scenes, "scenes"),
        _names(inputs, "inputs"),
    )


def _names(text: Any, what: str = "list") -> list[str]:
    """The names of a stored JSON list (at most MAX_ITEMS, strings only); ValueError for a text
    that is too long, nested, or not a JSON list."""
    try:
        value = loads_json(text, max_bytes=MAX_LIST_TEXT, max_depth=2)
    except ValueError as exc:
        reason = str(exc)
        raise ValueError(
            f"{what}: "
            + (
                "too long or too deep"
                if "limit" in reason or "nested" in reason
                else "not a JSON list"
            )
        ) from None
    if not isinstance(value, list):
        raise ValueError(f"{what}: not a JSON list")
    return [v for v in value if isinstance(v, str)][:MAX_ITEMS]
