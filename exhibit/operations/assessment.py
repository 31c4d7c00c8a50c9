"""What a health file says about the kiosk, as `exhibit status` and its metrics report it: one
status for the metrics (HEALTH_STATUSES: is it up?) and the issues, most serious first, each
with the exit code `exhibit status` gives for it and a one-line reason.

- The kiosk is up ("ok") when its health file is fresh and it drew a frame within --max-age
  ("last_frame"; a file from a kiosk older than that key counts by its freshness alone).
- "stale": the file is old (or stamped in the future) or its process is gone; "not_drawing":
  fresh, but no frame drawn for --max-age (every frame failing); both exit 1.
- "unwritable": the file is old but its process still runs, and its state folder is full or
  read-only as this reader sees it: the kiosk cannot update the file. Exit 5, not 1: it is not
  known to be dead.
- A fresh file whose "storage" says the state folder is full, read-only or not writable, or a
  write there failed with ENOSPC, EROFS or EACCES: exit 5 (the kiosk draws; what it records is
  lost). A device missing for longer than --max-lost: exit 3. Scenes skipped, or any other
  problem the kiosk names: exit 6 (WARN).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

from exhibit.operations import storage
from exhibit.operations.health import (
    Health,
    drawing,
    format_duration,
    freshness,
    missing_devices,
    pid_alive,
    storage_problem,
)

__all__ = [
    "EXIT_STALE",
    "EXIT_DEVICE_MISSING",
    "EXIT_METRICS_UNWRITTEN",
    "EXIT_STORAGE",
    "EXIT_WARN",
    "Issue",
    "Assessment",
    "assess",
    "folder_issue",
]

EXIT_STALE = 1
EXIT_DEVICE_MISSING = 3
EXIT_METRICS_UNWRITTEN = 4
EXIT_STORAGE = 5
EXIT_WARN = 6
#: At most this many of the kiosk's problems on the WARN line (all are in the summary).
WARN_PROBLEMS = 3


@dataclass(frozen=True)
class Issue:
    """One thing wrong: the exit code it gives, a head for people ("STATE FOLDER FULL") and a
    one-line reason."""

    code: int
    head: str
    text: str


@dataclass
class Assessment:
    """A health file judged: ``status`` (one of exhibit.operations.prometheus.HEALTH_STATUSES),
    its ``age`` in seconds, the ``issues`` most serious first, the devices missing too long,
    and the state ``folder``'s {"problem", "free_bytes"} (the kiosk's view in a fresh file,
    else this reader's own look at the folder; None when neither tells)."""

    status: str
    age: float
    issues: list[Issue] = field(default_factory=list)
    missing: list[dict] = field(default_factory=list)
    folder: dict | None = None

    @property
    def folder_problem(self) -> str | None:
        return None if self.folder is None else self.folder.get("problem")

    @property
    def fresh(self) -> bool:
        return self.status in ("ok", "not_drawing")

    @property
    def up(self) -> bool:
        """Drawing frames, by a fresh file: what exhibit_up says."""
        return self.status == "ok"

    @property
    def exit_code(self) -> int:
        return self.issues[0].code if self.issues else 0

    @property
    def head(self) -> str:
        return self.issues[0].head if self.issues else "OK"

    @property
    def reason(self) -> str | None:
        return self.issues[0].text if self.issues else None


def folder_issue(folder: str | os.PathLike) -> tuple[dict | None, str | None]:
    """The folder as a reader sees it (exhibit.operations.storage.check_folder): its
    {"problem", "free_bytes"} (None when it cannot be looked at), and the reason when it is
    full or its file system read-only (else None)."""
    info = storage.check_folder(folder, writer=False)
    found = storage.problem_in(info)
    seen = None if info.get("error") else {k: info[k] for k in ("problem", "free_bytes")}
    return seen, None if found is None else found[1]


def assess(
    data: Health,
    path: Path,
    max_age: float,
    max_lost: float,
    now: float | None = None,
) -> Assessment:
    """The health file ``data`` read from ``path``, judged as the module's docstring says."""
    now = time.time() if now is None else now
    fresh, age, reason = freshness(data, max_age, now=now)
    if not fresh:
        return _not_fresh(data, path, age, reason or "stale", max_age)
    out = Assessment("ok", age)
    draws, why = drawing(data, max_age, now)
    if draws is False:
        out.status = "not_drawing"
        out.issues.append(Issue(EXIT_STALE, "NOT DRAWING", why or "no frame drawn"))
    found = storage_problem(data)
    if isinstance(data.storage, dict):
        free = data.storage.get("free_bytes")
        out.folder = {
            "problem": None if found is None else found[0],
            "free_bytes": free if isinstance(free, int) and not isinstance(free, bool) else None,
        }
    if found is not None:
        out.issues.append(Issue(EXIT_STORAGE, f"STATE FOLDER {found[0].upper()}", found[1]))
    out.missing = missing_devices(data, max_lost, age)
    if out.missing:
        text = "; ".join(_missing_text(m, max_lost) for m in out.missing)
        out.issues.append(Issue(EXIT_DEVICE_MISSING, "DEVICE MISSING", text))
    warn = _warning(data)
    if warn is not None:
        out.issues.append(Issue(EXIT_WARN, "WARN", warn))
    return out


def _not_fresh(data: Health, path: Path, age: float, reason: str, max_age: float) -> Assessment:
    """Stale, unless its process runs and its folder is full or read-only: unwritable."""
    seen, why = folder_issue(path.parent)
    out = Assessment("stale", age, folder=seen)
    problem = out.folder_problem
    pid = data.pid
    if problem and why and age > max_age and isinstance(pid, int) and pid > 0 and pid_alive(pid):
        out.status = "unwritable"
        out.issues.append(
            Issue(
                EXIT_STORAGE,
                f"STATE FOLDER {problem.upper()}",
                f"the kiosk (pid {pid}) is running but cannot update its health file (last "
                f"update {format_duration(age)} ago): {why}",
            )
        )
        return out
    text = reason if why is None else f"{reason}; {why}"
    out.issues.append(Issue(EXIT_STALE, "STALE", text))
    return out


def _missing_text(m: dict, max_lost: float) -> str:
    how = "waiting (never connected since the start)" if m["state"] == "waiting" else m["state"]
    return (
        f"{m['device']} ({m['url']}) {how} for {format_duration(m['missing_s'])} "
        f"(more than {max_lost:g} s)"
    )


def _warning(data: Health) -> str | None:
    """The kiosk's problems (scenes skipped first), on one line; None when it names none."""
    problems = [p for p in (data.problems or []) if isinstance(p, str)]
    failed = [f for f in (data.scenes_failed or []) if isinstance(f, dict)]
    if failed and not any("skipped" in p for p in problems):
        names = ", ".join(str(f.get("scene")) for f in failed)
        problems.insert(0, f"{len(failed)} scene(s) skipped: {names}")
    if not problems:
        return None
    text = "; ".join(p[:200] for p in problems[:WARN_PROBLEMS])
    more = len(problems) - WARN_PROBLEMS
    return text + (f" (and {more} more: exhibit status)" if more > 0 else "")
