"""The releases of one kiosk, and the update and rollback as transactions on them
(`exhibit update`, `exhibit rollback`; what each does, step by step, is in
exhibit/commands/update.py's docstring and docs/DEPLOYMENT.md, "8. Updating").

Releases live side by side in PREFIX-releases/, each with its own .venv; PREFIX is a symbolic
link to the current one and PREFIX-releases/previous to the one before. Every check comes before
the switch, every external step has a time limit (:data:`TIMEOUTS`, run by
exhibit/commands/_bounded.py), one update or rollback runs at a time (:data:`LOCK`), and a kill
-9 at any moment leaves PREFIX a working release.

Why one module of this size: the update is one transaction, and its checks, its switch and its
undo must see the same state (the lock, the links, what was switched); split, each part would
have to trust the others' assumptions about a prefix that a power cut may have left half-way.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import stat
import subprocess
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from exhibit.commands import install as inst
from exhibit.commands._bounded import decode, run_bounded
from exhibit.errors import ExhibitError
from exhibit.schema import files, links

PREVIOUS = "previous"
#: releases kept by default, the current and the previous one included
KEEP = 3
RESTART = ["systemctl", "try-restart", "exhibit.service"]
#: The lock file in PREFIX-releases/ that keeps two updates or rollbacks apart.
LOCK = ".exhibit-lock"
#: Seconds each external step may take before it is stopped (its whole process group) and the
#: update fails: a hung `exhibit prepare` or restart never makes an update wait forever.
#: `exhibit install` builds the mesh cache too; a restart waits for the unit's
#: TimeoutStartSec=300 and TimeoutStopSec=10.
TIMEOUTS = {"check-config": 300, "prepare": 3600, "install": 3600, "restart": 420}
#: What a release being removed is renamed to first, so a half-removed one is never taken for
#: a release.
_REMOVING = re.compile(r"\..+\.exhibit-removing")


def _user_exists(name: str) -> bool:
    return inst._user_exists(name)


class StepFailed(ExhibitError):
    """A step after the switch failed: ``what`` and ``why``."""

    def __init__(self, what: str, why: str):
        super().__init__(f"{what} failed: {why}")
        self.what, self.why = what, why


def _release_name(name: str) -> bool:
    return name not in ("", ".", "..", PREVIOUS) and not name.startswith(".")


class Kiosk:
    """The releases of one kiosk. Paths are as the kiosk sees them (``prefix``); files are read
    and changed under ``root`` (/ on the kiosk, a folder in the tests). ``runner(command,
    timeout)`` runs a command and returns a CompletedProcess (subprocess.TimeoutExpired after
    ``timeout`` seconds), ``out`` hears the progress, ``timeouts`` overrides :data:`TIMEOUTS`."""

    def __init__(
        self,
        prefix: str = inst.DEFAULT_PREFIX,
        root: Path = Path("/"),
        runner: Callable = run_bounded,
        out: Callable[[str], None] = print,
        user_exists: Callable[[str], bool] = _user_exists,
        timeouts: dict[str, float] | None = None,
    ):
        self.prefix = prefix
        self.releases = prefix + "-releases"
        self.root, self.runner, self.out, self.user_exists = root, runner, out, user_exists
        self.timeouts = {**TIMEOUTS, **(timeouts or {})}

    def host(self, path: str) -> Path:
        """``path`` on the kiosk as a path here (under the root)."""
        return self.root / path.lstrip("/")

    # ------------------------------------------------------------------ state

    def current(self) -> str | None:
        """The current release's name; "" when PREFIX is a plain folder (a checkout not yet
        moved into the releases), None when there is nothing at PREFIX."""
        link = self.host(self.prefix)
        if link.is_symlink():
            return os.path.basename(os.path.normpath(os.readlink(link)))
        return "" if link.exists() else None

    def previous(self) -> str | None:
        link = self.host(f"{self.releases}/{PREVIOUS}")
        return os.path.basename(os.readlink(link)) if link.is_symlink() else None

    def exe(self, name: str) -> str:
        return f"{self.releases}/{name}/.venv/bin/exhibit"

    def _release_at(self, link: str) -> tuple[str | None, str]:
        """(the release the symbolic link ``link`` (a kiosk path) names, or None when it names
        anything else; the link's text)."""
        target = os.readlink(self.host(link))
        full = os.path.normpath(os.path.join(os.path.dirname(link), target))
        folder, name = os.path.split(full)
        if folder != self.releases or not _release_name(name):
            return None, target
        try:
            info = os.lstat(self.host(full))
        except OSError:
            return None, target
        return (name if stat.S_ISDIR(info.st_mode) else None), target

    def _checked_current(self) -> str | None:
        """:meth:`current`, refusing a PREFIX that is neither a link to a release, nor a plain
        folder, nor absent."""
        path = self.host(self.prefix)
        try:
            info = os.lstat(path)
        except FileNotFoundError:
            return None
        if stat.S_ISDIR(info.st_mode):
            return ""
        if not stat.S_ISLNK(info.st_mode):
            raise ExhibitError(
                f"{self.prefix} is {files.kind_of(info.st_mode)}, not a release link nor a "
                "checkout: nothing was changed; move it away by hand"
            )
        name, target = self._release_at(self.prefix)
        if name is None:
            raise ExhibitError(
                f"{self.prefix} -> {target} is not a release in {self.releases}/: nothing was "
                "changed; point it at one by hand "
                f"(ln -sfn {os.path.basename(self.releases)}/NAME {self.prefix})"
            )
        return name

    def _previous_link(self) -> str | None:
        """The text of PREFIX-releases/previous, None when there is none; refuses anything there
        that is not a symbolic link (a switch could not replace it)."""
        path = self.host(f"{self.releases}/{PREVIOUS}")
        try:
            info = os.lstat(path)
        except FileNotFoundError:
            return None
        if not stat.S_ISLNK(info.st_mode):
            raise ExhibitError(
                f"{self.releases}/{PREVIOUS} is {files.kind_of(info.st_mode)}, not a link to a "
                "release: nothing was changed; move it away by hand (exhibit keeps a link there)"
            )
        return os.readlink(path)

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
            self._check_release(name)
            current = self._checked_current()
            if current == name:
                raise ExhibitError(f"{release} is the current release already")
            old_previous = self._previous_link()
            if current == "":
                self._check_checkout()
            self.out(f"updating {self.prefix} to {name}")
            self._ready(name)
            moved = current == ""
            if moved:
                current = self._move_checkout()
            self._switch(name, current, old_previous, moved)
            try:
                self._install_and_restart()
            except StepFailed as failed:
                self._undo(name, current, old_previous, failed)
            self._prune(keep)
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
            self._switch(previous, current, link)
            try:
                self._install_and_restart()
            except StepFailed as failed:
                self._undo(previous, current, link, failed)
        self.out(
            f"rolled back: {self.prefix} is {previous}; to undo (back to {current}): "
            f"{self.exe(current)} rollback"
        )
        return 0

    # ------------------------------------------------------------------ steps

    @contextmanager
    def _locked(self, what: str) -> Iterator[None]:
        """One update or rollback at a time: PREFIX-releases/.exhibit-lock, held until the end
        (or the process's); what a killed switch left behind is cleaned under it."""
        path = self.host(f"{self.releases}/{LOCK}")
        stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        try:
            fd = links.hold_lock(path, f"pid {os.getpid()}, {what}, since {stamp}\n")
        except links.Busy as busy:
            raise ExhibitError(
                f"another update or rollback is running ({busy.holder or 'unknown'}): "
                f"nothing was changed; wait for it, or see {self.releases}/{LOCK}"
            ) from None
        except OSError as exc:
            raise ExhibitError(
                f"cannot lock {self.releases}/{LOCK}: {exc.strerror or exc}; nothing was changed"
            ) from None
        try:
            for link in (self.host(self.prefix), self.host(f"{self.releases}/{PREVIOUS}")):
                for line in links.clean_switch_leftovers(link):
                    self.out(f"note: {line}")
            self._clean_checkout_links()
            yield
        finally:
            os.close(fd)

    def _clean_checkout_links(self) -> None:
        """Remove the link a killed :meth:`_move_checkout` left in PREFIX-releases/ (NAME ->
        PREFIX-releases/NAME: only ever meant to be seen from PREFIX's folder)."""
        folder, base = self.host(self.releases), os.path.basename(self.releases)
        try:
            for entry in os.scandir(folder):
                if entry.is_symlink() and os.readlink(entry.path) == f"{base}/{entry.name}":
                    os.unlink(entry.path)
        except OSError:
            pass

    def _check_release(self, name: str) -> None:
        path = self.host(f"{self.releases}/{name}")
        if path.is_symlink():
            raise ExhibitError(
                f"{self.releases}/{name} is a symbolic link: a release must be a folder "
                "(./bootstrap.sh update makes one)"
            )
        exe = self.exe(name)
        if not os.access(self.host(exe), os.X_OK):
            raise ExhibitError(
                f"{exe} does not exist: {self.releases}/{name} has no venv "
                "(./bootstrap.sh update makes one)"
            )

    def _check_checkout(self) -> None:
        """The plain checkout at PREFIX can move into the releases in one rename."""
        here, there = self.host(self.prefix), self.host(self.releases)
        if os.path.ismount(here) or os.stat(here).st_dev != os.stat(there).st_dev:
            raise ExhibitError(
                f"cannot move the checkout {self.prefix} into {self.releases}/: it is a mount "
                f"point or on another file system; nothing was changed (move it there by hand, "
                f"then ln -s {os.path.basename(self.releases)}/NAME {self.prefix})"
            )

    def _environment(self, name: str) -> list[str]:
        """exhibit.service's environment as the release will run: its unit and the site's file."""
        unit = self.host(f"{self.releases}/{name}/systemd/exhibit.service")
        try:
            text = files.read_regular(unit, files.MAX_CONFIG_BYTES).decode("utf-8", "replace")
        except FileNotFoundError:  # a release installed from its wheel alone: the shipped unit
            text = (inst.SOURCE_DIR / "exhibit.service").read_text(encoding="utf-8")
        except (OSError, ValueError) as exc:
            raise ExhibitError(
                f"cannot read {self.releases}/{name}/systemd/exhibit.service: "
                f"{getattr(exc, 'strerror', None) or exc}; nothing was switched"
            ) from None
        return inst.service_environment(
            inst.render(text, self.prefix),
            inst.environment_file(self.root / inst.SITE_ENVIRONMENT),
        )

    def _ready(self, name: str) -> None:
        """Check the site config with the release, and build its mesh cache, as the service's
        user with the service's environment, before anything is switched."""
        env, exe = self._environment(name), self.exe(name)
        if not self.user_exists(inst.USER):
            self._step(
                ["env", "-i", *env, exe, "check-config"], "the site configuration", "check-config"
            )
            self.out(
                f"note: no user {inst.USER} yet: `exhibit install` makes it and builds the cache"
            )
            return
        self._step(
            inst.as_service(exe, ["check-config"], env), "the site configuration", "check-config"
        )
        if not self._has_prepare(name):
            self.out(f"note: {name} has no `exhibit prepare`: its first start builds the cache")
            return
        for command in inst.prepare_steps(exe, env):
            self._step(command, "building the mesh cache", "prepare")

    def _has_prepare(self, name: str) -> bool:
        release = self.host(f"{self.releases}/{name}")
        return any(release.glob("exhibit/commands/prepare.py")) or any(
            release.glob(".venv/lib/python3*/site-packages/exhibit/commands/prepare.py")
        )

    def _call(self, command: list[str], timeout: str) -> tuple[subprocess.CompletedProcess, str]:
        """Run ``command`` with the time limit ``TIMEOUTS[timeout]``: (its result, why it failed
        or "")."""
        limit = self.timeouts[timeout]
        try:
            result = self.runner(command, limit)
        except OSError as exc:
            result = subprocess.CompletedProcess(command, 127, "", "")
            return result, f"{command[0]}: {exc.strerror or exc}"
        except subprocess.TimeoutExpired as exc:
            result = subprocess.CompletedProcess(command, 124, decode(exc.stdout), "")
            return result, f"no answer within {limit:g} s: stopped"
        result.stdout, result.stderr = decode(result.stdout), decode(result.stderr)
        if result.returncode == 0:
            return result, ""
        lines = (result.stderr or result.stdout or "").strip().splitlines()
        return result, lines[-1] if lines else f"exit code {result.returncode}"

    def _step(self, command: list[str], what: str, timeout: str) -> subprocess.CompletedProcess:
        self.out("$ " + _short(command))
        result, why = self._call(command, timeout)
        if why:
            lines = result.stdout.strip().splitlines() + result.stderr.strip().splitlines()
            for line in lines[-20:-1]:
                self.out("  " + line)
            raise ExhibitError(f"{what} failed ({why}); nothing was switched")
        return result

    def _move_checkout(self) -> str:
        """Move the plain folder at PREFIX (a checkout from before releases) into the releases,
        as a release; its .venv keeps working, since everything in it names PREFIX."""
        version = "old"
        try:
            text = files.read_regular(
                self.host(f"{self.prefix}/exhibit/__init__.py"), files.MAX_CONFIG_BYTES
            ).decode("utf-8", "replace")
        except (OSError, ValueError):
            text = ""
        match = re.search(r'^__version__ = "([^"/]+)"', text, re.M)
        if match and _release_name(match.group(1)):
            version = match.group(1)
        name = f"{version}-checkout-{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}"
        target = self.host(f"{self.releases}/{name}")
        self.out(f"moving the checkout {self.prefix} to {self.releases}/{name}")
        try:
            # a link at the checkout's new place, pointing there as seen from PREFIX's folder,
            # exchanged with the checkout in one step: PREFIX is never missing
            os.symlink(f"{os.path.basename(self.releases)}/{name}", target)
            try:
                links.exchange(self.host(self.prefix), target)
            except OSError as exc:
                if exc.errno not in (errno.EINVAL, errno.ENOSYS):
                    target.unlink()
                    raise
                target.unlink()  # no exchange on this file system: two renames
                os.rename(self.host(self.prefix), target)
                links.replace_link(
                    self.host(self.prefix), f"{os.path.basename(self.releases)}/{name}"
                )
        except OSError as exc:
            raise ExhibitError(
                f"cannot move {self.prefix} to {self.releases}/{name}: "
                f"{exc.strerror or exc}; nothing was switched (a mount point? move it by hand, "
                f"then ln -s {os.path.basename(self.releases)}/{name} {self.prefix})"
            ) from None
        return name

    def _switch(
        self, name: str, current: str | None, old_previous: str | None, moved: bool = False
    ) -> None:
        """PREFIX-releases/previous -> ``current``, then PREFIX -> the release, each replaced in
        one rename (a running kiosk sees the old or the new link, never none). When a rename
        fails, what was done is undone (previous -> ``old_previous``, the ``moved`` checkout
        back at PREFIX) and nothing is switched."""
        base = os.path.basename(self.releases)
        previous = self.host(f"{self.releases}/{PREVIOUS}")
        try:
            if current:
                links.replace_link(previous, current)
            links.replace_link(self.host(self.prefix), f"{base}/{name}")
        except OSError as exc:
            try:
                if old_previous is None:
                    previous.unlink(missing_ok=True)
                else:
                    links.replace_link(previous, old_previous)
                if moved and current and not os.path.lexists(self.host(self.prefix)):
                    os.rename(self.host(f"{self.releases}/{current}"), self.host(self.prefix))
            except OSError:
                pass
            raise ExhibitError(
                f"cannot switch {self.prefix} to {name}: {exc.strerror or exc}; nothing was "
                "switched"
            ) from None
        self.out(f"switched {self.prefix} -> {self.releases}/{name}")

    def _install_and_restart(self) -> None:
        """The current release's `exhibit install` and the restart; StepFailed says which
        failed."""
        exe = f"{self.prefix}/.venv/bin/exhibit"
        for command, what, timeout in (
            (
                ["env", f"{inst.FOR_UPDATE_ENV}=1", exe, "install", "--prefix", self.prefix],
                "exhibit install",
                "install",
            ),
            (RESTART, "the restart", "restart"),
        ):
            self.out("$ " + _short(command))
            result, why = self._call(command, timeout)
            for line in result.stdout.strip().splitlines():
                self.out("  " + line)
            if why:
                raise StepFailed(what, why)

    def _undo(self, name: str, back: str | None, previous: str | None, failed: StepFailed) -> None:
        """After ``failed`` (a step after switching to ``name``): the links back as they were
        (PREFIX -> ``back``, previous -> the link text ``previous``), the old release's install
        and restart again; always raises, saying what happened."""
        if not back:
            raise ExhibitError(
                f"{self.prefix} is now {name}, but {failed}; there is no release to go back to: "
                f"fix that and run {self.prefix}/.venv/bin/exhibit install --prefix "
                f"{self.prefix} again"
            )
        self.out(f"{failed}: switching {self.prefix} back to {back}")
        try:
            links.replace_link(self.host(self.prefix), f"{os.path.basename(self.releases)}/{back}")
            link = self.host(f"{self.releases}/{PREVIOUS}")
            if previous is None:
                link.unlink(missing_ok=True)
            else:
                links.replace_link(link, previous)
        except OSError as exc:
            raise ExhibitError(
                f"{self.prefix} is now {name}, but {failed}, and switching back failed too "
                f"({exc.strerror or exc}); go back by hand: {self.exe(back)} rollback"
            ) from None
        try:
            self._install_and_restart()
        except StepFailed as again:
            raise ExhibitError(
                f"{name}: {failed}; {self.prefix} is {back} again, but its {again}: fix that "
                f"and run {self.prefix}/.venv/bin/exhibit install --prefix {self.prefix}"
            ) from None
        raise ExhibitError(f"{name}: {failed}; rolled back: {self.prefix} is {back} again")

    def _prune(self, keep: int) -> None:
        """Remove the oldest releases beyond ``keep``; never fails the update: a release that
        cannot be removed is kept, with a line saying why."""
        try:
            folder = self.host(self.releases)
            held = {self.current(), self.previous()}
            names, removing = [], []
            for p in folder.iterdir():
                if not p.is_dir() or p.is_symlink():
                    continue
                if _REMOVING.fullmatch(p.name):
                    removing.append(p)
                elif not p.name.startswith(".") and p.name != PREVIOUS:
                    names.append(p)
            old = sorted(
                (p for p in names if p.name not in held),
                key=lambda p: p.stat().st_mtime,
                reverse=True,
            )
            doomed = old[max(0, keep - len(held & {p.name for p in names})) :]
        except OSError as exc:
            self.out(f"note: old releases not pruned: {exc.strerror or exc}")
            return
        for path in removing:  # left by a prune that was killed
            self._remove(path, f"{self.releases}/{path.name}")
        for path in doomed:
            shown = f"{self.releases}/{path.name}"
            why = _mounted(path)
            if why:
                self.out(f"note: kept the old release {shown}: {why}")
                continue
            self.out(f"removing the old release {shown}")
            gone = path.with_name(f".{path.name}.exhibit-removing")
            try:
                os.rename(path, gone)
            except OSError as exc:
                self.out(f"note: kept the old release {shown}: {exc.strerror or exc}")
                continue
            self._remove(gone, shown)

    def _remove(self, path: Path, shown: str) -> None:
        why = _mounted(path)
        if not why:
            try:
                shutil.rmtree(path)
                return
            except OSError as exc:
                why = exc.strerror or str(exc)
        self.out(f"note: could not remove all of {shown} (now {path.name}): {why}; left there")


def _mounted(path: Path) -> str:
    """Why ``path`` must not be removed: it or a folder in it is a mount point (rmtree would
    empty the mounted file system), or ""."""
    if os.path.ismount(path):
        return "it is a mount point"
    try:
        device = os.lstat(path).st_dev
    except OSError as exc:
        return exc.strerror or str(exc)
    for folder, subfolders, _ in os.walk(path):
        for sub in subfolders:
            inner = os.path.join(folder, sub)
            try:
                if os.lstat(inner).st_dev != device or os.path.ismount(inner):
                    return f"{inner} in it is a mount point"
            except OSError:
                continue
    return ""


def _short(command: list[str]) -> str:
    """A command for the progress lines: the long environment of `env -i` left out."""
    import shlex

    if "env" in command and "-i" in command:
        start = command.index("-i") + 1
        end = start
        while end < len(command) and "=" in command[end] and not command[end].startswith("/"):
            end += 1
        command = [*command[:start], "(the service's environment)", *command[end:]]
    return shlex.join(command)
