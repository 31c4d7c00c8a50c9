"""Reading the database back for `exhibit stats`: read-only, never repairing, and every row checked
against bounds, so a hand-edited or damaged file gives a count of skipped rows, not a
traceback."""

from __future__ import annotations

import math
import os
import sqlite3
import stat
from collections import Counter
from pathlib import Path
from typing import Any

from exhibit.errors import ExhibitError
from exhibit.operations.sessions.session import MAX_ITEMS, Session
from exhibit.operations.sessions.store import COLUMNS, is_corrupt
from exhibit.schema.files import loads_json


class SessionsError(ExhibitError):
    """The sessions database cannot be read (for `exhibit stats`): the message says why."""


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
            f"SELECT {', '.join(COLUMNS[1:])} FROM sessions"
            + (" WHERE start + utc_offset_s >= ?" if since_local is not None else "")
            + " ORDER BY start, id"
        )
        rows = db.execute(query, () if since_local is None else (since_local,)).fetchall()
    except sqlite3.DatabaseError as exc:
        what = "not a sessions database" if is_corrupt(exc) else "cannot read it"
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
