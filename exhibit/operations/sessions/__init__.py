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

The modules: ``config`` ([sessions] and the file's place), ``session`` (the row), ``store``
(SQLite), ``writer`` (the thread), ``recorder`` (the frame loop's side), ``reading`` (`exhibit
stats`)."""

from exhibit.operations.sessions.config import (
    DB_FILE,
    SessionsConfig,
    SessionsSection,
    candidate_paths,
    default_db_path,
    sessions_config,
)
from exhibit.operations.sessions.reading import SessionsError, read_sessions
from exhibit.operations.sessions.recorder import SessionLog, open_session_log
from exhibit.operations.sessions.session import Session, input_name
from exhibit.operations.sessions.store import SessionStore
from exhibit.operations.sessions.writer import SessionWriter

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
