"""What an interrupted `exhibit update` or `exhibit rollback` still owes: the journal,
PREFIX-releases/.exhibit-journal.json (docs/DEPLOYMENT.md, "8. Updating").

Before each step that changes the kiosk (the switch of the links, the new release's
`exhibit install`, the restart; and the same three when a failed step switches back), the
update writes here, in one rename (:func:`exhibit.schema.files.write_atomic`), where the links
must end (``release``, ``previous``) and the steps still owed from that one on; when the last
one is done the file is removed. A kill -9, a SIGHUP or Ctrl-C in between leaves the file: the
next `exhibit update` or `exhibit rollback` finishes what it owes before anything else
(exhibit/commands/_releases.py), and :func:`owed_steps` says it in sentences, each with the
exact command, for `exhibit status`.

What is owed is read against the links as they are (:func:`still_owed`): a switch that had not
happened yet owes nothing (the kiosk runs what it ran), a switch half done owes its end, and
links changed by hand since (no switch owed, yet not where the journal says) make the journal
stale: it owes nothing and is dropped.
"""

from __future__ import annotations

import json
import os
import shlex
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from exhibit.errors import ExhibitError
from exhibit.schema import files

#: The journal's name in PREFIX-releases/ (a dot name: never taken for a release).
JOURNAL = ".exhibit-journal.json"
#: The lock file in PREFIX-releases/ that an update or rollback holds while it runs.
LOCK = ".exhibit-lock"
#: The steps an update or rollback owes once it switches, in order.
STEPS = ("switch", "install", "restart")
#: The default prefix (exhibit/commands/install.py's), left out of the commands it prints.
_DEFAULT_PREFIX = "/opt/exhibit"
_BOOT_ID = Path("/proc/sys/kernel/random/boot_id")


@dataclass
class Journal:
    """``what`` ("update" or "rollback") of ``prefix`` (as the kiosk sees it) must end with
    PREFIX -> ``release`` and PREFIX-releases/previous -> ``previous`` (its text; None: no
    link), then ``owed``'s steps. ``before``: (release, previous) before a switch forward, so a
    kill before it owes nothing; None while switching back after ``failed`` (what failed).
    ``finish``: the command that finishes it. ``pid``, ``boot`` and ``since``: who wrote it."""

    what: str
    prefix: str
    release: str
    previous: str | None
    owed: list[str]
    finish: list[str]
    before: tuple[str | None, str | None] | None = None
    failed: str = ""
    pid: int = 0
    boot: str = ""
    since: str = ""


def journal_path(releases: Path) -> Path:
    """The journal in the releases folder ``releases`` (a path here)."""
    return releases / JOURNAL


def _boot_id() -> str:
    try:
        return _BOOT_ID.read_text().strip()
    except OSError:
        return ""


def write(releases: Path, journal: Journal) -> None:
    """Write ``journal`` at once (the old one or the new one is there, never a part)."""
    journal.pid, journal.boot = os.getpid(), _boot_id()
    journal.since = journal.since or time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    data = asdict(journal)
    files.write_atomic(journal_path(releases), json.dumps(data, indent=1) + "\n")


def clear(releases: Path) -> None:
    journal_path(releases).unlink(missing_ok=True)


def _names(value: object, what: str, none: bool = False) -> str | None:
    if value is None and none:
        return None
    if not isinstance(value, str) or (value == "" and not none) or "\n" in value:
        raise ValueError(f"{what}: not a release name")
    return value


def read(releases: Path) -> Journal | None:
    """The journal in ``releases``, None when there is none; ValueError (a short reason) when
    it is not one (not JSON, a field missing or of the wrong kind), OSError when unreadable."""
    path = journal_path(releases)
    try:
        raw = files.read_regular(path, files.MAX_JSON_BYTES, follow=False)
    except FileNotFoundError:
        return None
    data = files.loads_json(raw)
    if not isinstance(data, dict):
        raise ValueError("not a JSON object")
    if data.get("what") not in ("update", "rollback"):
        raise ValueError("what: neither update nor rollback")
    owed = data.get("owed")
    if not isinstance(owed, list) or any(step not in STEPS for step in owed):
        raise ValueError(f"owed: not a list of {', '.join(STEPS)}")
    finish = data.get("finish")
    if not isinstance(finish, list) or not finish or not all(isinstance(w, str) for w in finish):
        raise ValueError("finish: not a command")
    before = data.get("before")
    if before is not None:
        if not isinstance(before, list) or len(before) != 2:
            raise ValueError("before: not [release, previous]")
        before = (_names(before[0], "before", True), _names(before[1], "before", True))
    prefix = data.get("prefix")
    if not isinstance(prefix, str) or not prefix.startswith("/"):
        raise ValueError("prefix: not an absolute path")
    failed, pid = data.get("failed", ""), data.get("pid", 0)
    if not isinstance(failed, str) or not isinstance(pid, int) or isinstance(pid, bool):
        raise ValueError("failed, pid: of the wrong kind")
    return Journal(
        what=data["what"],
        prefix=prefix,
        release=_names(data.get("release"), "release") or "",
        previous=_names(data.get("previous"), "previous", True),
        owed=list(owed),
        finish=list(finish),
        before=before,
        failed=failed,
        pid=pid,
        boot=str(data.get("boot", "")),
        since=str(data.get("since", "")),
    )


def state(prefix: Path) -> tuple[str | None, str | None]:
    """(the release PREFIX links to, None when it is no link; the text of
    PREFIX-releases/previous, None when there is none), ``prefix`` a path here."""
    previous = Path(f"{prefix}-releases") / "previous"
    try:
        current: str | None = os.path.basename(os.path.normpath(os.readlink(prefix)))
    except OSError:
        current = None
    try:
        link: str | None = os.readlink(previous)
    except OSError:
        link = None
    return current, link


def still_owed(journal: Journal, now: tuple[str | None, str | None]) -> list[str]:
    """The steps ``journal`` still owes with the links as they are (``now``, :func:`state`)."""
    if now == (journal.release, journal.previous):
        return [step for step in journal.owed if step != "switch"]
    if "switch" not in journal.owed:
        return []  # switched, then changed by hand since: the journal is stale
    if journal.before is not None and now == journal.before and not journal.failed:
        return []  # killed before its switch: the kiosk runs what it ran
    return list(STEPS)


def running(journal: Journal) -> bool:
    """Whether the update that wrote ``journal`` still runs: its pid, this boot, is an
    exhibit process (no lock is taken to find out: that could turn an update away)."""
    if not journal.pid or journal.boot != _boot_id():
        return False
    try:
        command = Path(f"/proc/{journal.pid}/cmdline").read_bytes()
    except OSError:
        return False
    return b"exhibit" in command


def finish_command(what: str, prefix: str, exe: str, release: str = "") -> list[str]:
    """The command that finishes ``what`` (`exhibit update RELEASE` or `exhibit rollback`)
    with the release executable ``exe``."""
    command = [exe, what] + ([release] if what == "update" else [])
    return command + (["--prefix", prefix] if prefix != _DEFAULT_PREFIX else [])


def describe(journal: Journal, owed: list[str]) -> list[str]:
    """Sentences for what ``journal`` still owes (``owed``), each with the exact command."""
    finish, prefix = shlex.join(journal.finish), journal.prefix
    releases = f"{prefix}-releases"
    when = f" (pid {journal.pid}, since {journal.since})" if journal.since else ""
    if journal.failed:
        head = (
            f"an {journal.what} of {prefix} failed ({journal.failed}) and was switching back to "
            f"{journal.release} when it stopped{when}; finish switching back with: {finish}"
        )
    else:
        head = (
            f"an {journal.what} of {prefix} to {journal.release} stopped half-way{when}; "
            f"finish it with: {finish}"
        )
    lines = [head]
    for step in owed:
        if step == "switch":
            lines.append(
                f"owed: {prefix} -> {releases}/{journal.release} and {releases}/previous -> "
                f"{journal.previous or '(none)'}, which {finish} switches"
            )
        elif step == "install":
            lines.append(
                f"owed: {journal.release}'s `exhibit install` (units, udev rules) has not run "
                f"since the switch; by hand: env EXHIBIT_INSTALL_FOR_UPDATE=1 "
                f"{prefix}/.venv/bin/exhibit install --prefix {prefix}"
            )
        else:
            lines.append(
                f"owed: exhibit.service has not been restarted into {journal.release}; by "
                "hand: systemctl try-restart exhibit.service"
            )
    return lines


def owed_steps(prefix: Path) -> list[str]:
    """What an interrupted `exhibit update` or `exhibit rollback` of ``prefix`` (a path here,
    /opt/exhibit on the kiosk) still owes, as sentences each with the exact command to run;
    empty when nothing is owed, or while the update that wrote the journal still runs. Never
    raises: a journal that cannot be read is one sentence naming it and what is wrong."""
    releases = Path(f"{prefix}-releases")
    try:
        journal = read(releases)
    except (OSError, ValueError) as exc:
        path = journal_path(releases)
        why = getattr(exc, "strerror", None) or str(exc)
        return [
            f"{path}: {why}: an update or rollback stopped and its journal cannot be read; "
            f"check the links by hand (ls -l {prefix} {releases}), then: rm {path}"
        ]
    if journal is None or running(journal):
        return []
    owed = still_owed(journal, state(prefix))
    return describe(journal, owed) if owed else []


def check(releases: Path, prefix: str) -> Journal | None:
    """:func:`read` for the update itself: an unreadable journal is a one-line ExhibitError
    naming it (as the kiosk sees it, under ``prefix``-releases/) and what to do."""
    shown = f"{prefix}-releases/{JOURNAL}"
    try:
        return read(releases)
    except (OSError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
        raise ExhibitError(
            f"{shown}: {why}: an earlier update or rollback stopped and its journal cannot be "
            f"read; nothing was changed: check the links by hand (ls -l {prefix} "
            f"{prefix}-releases), then remove it (rm {shown})"
        ) from None
