"""The releases of one kiosk, and the update and rollback as transactions on them
(`exhibit update`, `exhibit rollback`; what each does, step by step, is in
exhibit/commands/update.py's docstring and docs/DEPLOYMENT.md, "8. Updating").

Releases live side by side in PREFIX-releases/, each with its own .venv; PREFIX is a symbolic
link to the current one and PREFIX-releases/previous to the one before. Every check comes before
the switch, every external step has a time limit (:data:`TIMEOUTS`, run by
exhibit/commands/_bounded.py), one update or rollback runs at a time (:data:`LOCK`), and a kill
-9 at any moment leaves PREFIX a working release. What the switch and each step after it still
owe is written first to the journal (exhibit/commands/_update_journal.py), which the next update
or rollback finishes before anything else. A release is switched to only when it runs, and
pruning counts only releases that run (exhibit/commands/_release_checks.py); the plain checkout
of a first deployment becomes a release in exhibit/commands/_checkout.py.

The releases as they lie (the links, the checks before a switch, the steps under their time
limits, the lock and the switch itself) are :class:`~exhibit.commands._release_tree.ReleaseTree`
(exhibit/commands/_release_tree.py); :class:`Releases` adds the transactions on them.
"""

from __future__ import annotations

import os
import shlex

from exhibit.commands import _checkout as checkout
from exhibit.commands import _release_checks as checks
from exhibit.commands import _update_journal as jr
from exhibit.commands import install as inst
from exhibit.commands._release_tree import (
    LOCK,
    PREVIOUS,
    TIMEOUTS,
    ReleaseTree,
    _release_name,
    _short,
)
from exhibit.errors import ExhibitError

__all__ = ["KEEP", "LOCK", "PREVIOUS", "RESTART", "TIMEOUTS", "Releases", "StepFailed"]

#: releases kept by default, the current and the previous one included
KEEP = 3
RESTART = ["systemctl", "try-restart", "exhibit.service"]


class StepFailed(ExhibitError):
    """A step after the switch failed: ``what`` and ``why``."""

    def __init__(self, what: str, why: str):
        super().__init__(f"{what} failed: {why}")
        self.what, self.why = what, why


class Releases(ReleaseTree):
    """The update and rollback of one kiosk's releases as transactions (:class:`ReleaseTree`
    holds the releases as they lie: the links, the checks, the steps, the switch): what the
    switch and each step after it owe is journalled first and finished by the next one; a step
    that fails after the switch switches back."""

    # ------------------------------------------------------------------ commands

    def update(self, release: str, keep: int = KEEP) -> int:
        parent, name = os.path.split(release)
        if parent != self.releases or not _release_name(name):
            raise ExhibitError(
                f"{release}: a release must be a folder in {self.releases}/ "
                "(./bootstrap.sh update makes one)"
            )
        if not self.host(release).is_dir():
            raise ExhibitError(f"{release}: no such folder")
        with self._locked(f"exhibit update {release}"):
            done = self._finish()
            if done and done.what == "update" and done.release == name:
                self._prune(keep, name)
                self.out(f"updated: {self.prefix} is {name} (the update that stopped is done)")
                return 0
            self._check_release(name)
            current = self._checked_current()
            if current == name:
                raise ExhibitError(f"{release} is the current release already")
            old_previous = self._previous_link()
            if current == "":
                checkout.check(self.host(self.prefix), self.host(self.releases), self.prefix)
            self.out(f"updating {self.prefix} to {name}")
            self._ready(name)
            moved = current == ""
            if moved:
                current = checkout.move(
                    self.host(self.prefix), self.host(self.releases), self.prefix, self.out
                )
            journal = self._plan("update", name, current, old_previous, self.exe(name))
            self._switch(name, current, old_previous, moved)
            try:
                self._install_and_restart(journal)
            except StepFailed as failed:
                self._undo(journal, failed)
            self._journal(None)
            self._prune(keep, name)
        back = self.exe(name)
        self.out(
            f"updated: {self.prefix} is {name}"
            + (f" (previous: {current}; back to it with: {back} rollback)" if current else "")
        )
        return 0

    def rollback(self) -> int:
        if not self.host(self.releases).is_dir():
            raise ExhibitError(
                f"{self.prefix} is not a release link: nothing to roll back to "
                "(./bootstrap.sh update makes releases; docs/DEPLOYMENT.md, 8)"
            )
        with self._locked("exhibit rollback"):
            done = self._finish()
            if done and done.what == "rollback":
                self.out(
                    f"rolled back: {self.prefix} is {done.release} (the rollback that stopped is "
                    f"done); to undo: {shlex.join(done.finish)}"
                )
                return 0
            current = self._checked_current()
            if not current:
                raise ExhibitError(
                    f"{self.prefix} is not a release link: nothing to roll back to "
                    "(./bootstrap.sh update makes releases; docs/DEPLOYMENT.md, 8)"
                )
            link = self._previous_link()
            if link is None:
                raise ExhibitError(
                    f"no previous release in {self.releases}/ to roll back to "
                    f"(the current one, {current}, is the only one)"
                )
            previous, _ = self._release_at(f"{self.releases}/{PREVIOUS}")
            if previous is None:
                raise ExhibitError(
                    f"{self.releases}/{PREVIOUS} -> {link} is not a release in "
                    f"{self.releases}/: nothing to roll back to; nothing was changed"
                )
            if previous == current:
                raise ExhibitError(
                    f"{self.releases}/{PREVIOUS} -> {link} is the running release: nothing to "
                    "roll back to; nothing was changed"
                )
            self._check_release(previous)
            self.out(f"rolling {self.prefix} back from {current} to {previous}")
            self._ready(previous)
            journal = self._plan("rollback", previous, current, link, self.exe(current))
            self._switch(previous, current, link)
            try:
                self._install_and_restart(journal)
            except StepFailed as failed:
                self._undo(journal, failed)
            self._journal(None)
        self.out(
            f"rolled back: {self.prefix} is {previous}; to undo (back to {current}): "
            f"{self.exe(current)} rollback"
        )
        return 0

    # ------------------------------------------------------------------ transaction

    def _install_and_restart(self, journal: jr.Journal) -> None:
        """The current release's `exhibit install` and the restart, those of them that
        ``journal`` owes, each written to it as owed before it runs; StepFailed says which
        failed."""
        exe = f"{self.prefix}/.venv/bin/exhibit"
        for step, command, what in (
            (
                "install",
                ["env", f"{inst.FOR_UPDATE_ENV}=1", exe, "install", "--prefix", self.prefix],
                "exhibit install",
            ),
            ("restart", RESTART, "the restart"),
        ):
            if step not in journal.owed:
                continue
            journal.owed = [s for s in jr.STEPS[jr.STEPS.index(step) :] if s in journal.owed]
            self._journal(journal, before_switch=False)
            self.out("$ " + _short(command))
            result, why = self._call(command, step)
            for line in result.stdout.strip().splitlines():
                self.out("  " + line)
            if why:
                raise StepFailed(what, why)

    def _plan(
        self, what: str, name: str, current: str | None, previous: str | None, exe: str
    ) -> jr.Journal:
        """The journal of switching from ``current`` (previous -> the text ``previous``) to
        ``name``, written before the switch: it owes every step."""
        journal = jr.Journal(
            what=what,
            prefix=self.prefix,
            release=name,
            previous=current or None,
            owed=list(jr.STEPS),
            finish=jr.finish_command(what, self.prefix, exe, f"{self.releases}/{name}"),
            before=(current, previous),
        )
        self._journal(journal)
        return journal

    def _journal(self, journal: jr.Journal | None, before_switch: bool = True) -> None:
        """Write ``journal`` (None: remove it: nothing is owed). Before a switch a failure stops
        the update; after it the steps matter more than their record: a note, and on."""
        folder, shown = self.host(self.releases), f"{self.releases}/{jr.JOURNAL}"
        try:
            if journal is None:
                jr.clear(folder)
            else:
                jr.write(folder, journal)
        except OSError as exc:
            why = f"cannot write {shown}: {exc.strerror or exc}"
            if journal is not None and before_switch and "switch" in journal.owed:
                raise ExhibitError(f"{why}; nothing was switched") from None
            self.out(f"note: {why}")

    def _finish(self) -> jr.Journal | None:
        """Finish what an update or rollback that stopped half-way (a kill, SIGHUP, Ctrl-C, a
        power cut) owes, as its journal says; the finished journal, or None when nothing was
        owed. Its own failure is switched back as an update's is."""
        journal = jr.check(self.host(self.releases), self.prefix)
        if journal is None:
            return None
        owed = jr.still_owed(journal, jr.state(self.host(self.prefix)))
        shown = f"{self.releases}/{jr.JOURNAL}"
        if not owed:
            self.out(f"note: {shown}: the {journal.what} it records owes nothing now: removed")
            self._journal(None)
            return None
        self.out(
            f"finishing the {journal.what} of {self.prefix} that stopped half-way"
            f"{' while switching back' if journal.failed else ''}: it owes " + ", ".join(owed)
        )
        journal.owed = owed
        if "switch" in owed:
            found = self.host(f"{self.releases}/{journal.release}")
            if found.is_symlink() or not found.is_dir():
                raise ExhibitError(
                    f"{shown}: it owes a switch to {journal.release}, which is no release in "
                    f"{self.releases}/ now: nothing was changed; point {self.prefix} at a "
                    f"release by hand, then remove {shown}"
                )
            self._switch_links(journal.release, journal.previous, f"{shown} still owes it")
            journal.owed = owed[1:]
        try:
            self._install_and_restart(journal)
        except StepFailed as failed:
            if journal.failed or journal.before is None or not journal.before[0]:
                raise ExhibitError(
                    f"{self.prefix} is {journal.release}, but {failed}: fix that and run "
                    f"{shlex.join(journal.finish)}"
                ) from None
            self._undo(journal, failed)
        self._journal(None)
        if journal.failed:
            raise ExhibitError(
                f"the {journal.what} that stopped had failed ({journal.failed}); now switched "
                f"back: {self.prefix} is {journal.release}"
            )
        return journal

    def _undo(self, journal: jr.Journal, failed: StepFailed) -> None:
        """After ``failed`` (a step after ``journal``'s switch): the links back as they were
        (``journal.before``), the old release's install and restart again, each written to the
        journal first; always raises, saying what happened."""
        name = journal.release
        back, previous = journal.before or (None, None)
        if not back:
            raise ExhibitError(
                f"{self.prefix} is now {name}, but {failed}; there is no release to go back to: "
                f"fix that and run {self.prefix}/.venv/bin/exhibit install --prefix "
                f"{self.prefix} again"
            )
        self.out(f"{failed}: switching {self.prefix} back to {back}")
        journal.release, journal.previous, journal.before = back, previous, None
        journal.owed, journal.failed = list(jr.STEPS), f"{name}: {failed}"
        self._journal(journal, before_switch=False)
        self._switch_links(
            back,
            previous,
            f"{self.releases}/{jr.JOURNAL} still owes it: {shlex.join(journal.finish)} finishes it",
        )
        journal.owed = journal.owed[1:]
        try:
            self._install_and_restart(journal)
        except StepFailed as again:
            raise ExhibitError(
                f"{name}: {failed}; {self.prefix} is {back} again, but its {again}: fix that "
                f"and run {self.prefix}/.venv/bin/exhibit install --prefix {self.prefix}"
            ) from None
        self._journal(None)
        raise ExhibitError(f"{name}: {failed}; rolled back: {self.prefix} is {back} again")

    def _prune(self, keep: int, installing: str) -> None:
        """Remove the oldest releases beyond ``keep`` that run; never the current, the previous
        or ``installing`` (exhibit/commands/_release_checks.py)."""
        held = {self.current() or "", self.previous() or "", installing}
        checks.prune(self.host(self.releases), self.releases, held, keep, self._runs, self.out)
