"""``[sessions]`` of kiosk.toml and where the database lives: the state folder unless the config
names a file (exhibit.operations.health.state_dir)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

from pydantic import PlainValidator

from exhibit.operations.health import SERVICE_STATE_DIR, state_dir
from exhibit.schema import Model
from exhibit.schema.types import Integer, fail, text_check

DB_FILE = "sessions.db"


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
    """Where a reader looks without --db, in the order exhibit.operations.health looks for the
    health file: $EXHIBIT_STATE_DIR alone when set; else the service's /var/lib/exhibit first
    (on a kiosk machine that is the log staff ask about, whoever asks: root's own state folder
    holds at most a log of a kiosk someone once ran by hand), then this user's own."""
    if os.environ.get("EXHIBIT_STATE_DIR"):
        return [default_db_path()]
    service = SERVICE_STATE_DIR / DB_FILE
    own = default_db_path()
    return [service] if own == service else [service, own]
