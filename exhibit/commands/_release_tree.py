"""The releases of one kiosk as they lie (`exhibit update`, `exhibit rollback`): the links
PREFIX and PREFIX-releases/previous, the checks a release passes before it is switched to (it
runs, the site config holds, its mesh cache is built), the external steps under their time
limits (:data:`TIMEOUTS`, run by exhibit/commands/_bounded.py), the lock, and the switch of the
links. The update and rollback as transactions on them, with their journal and undo, are
exhibit/commands/_releases.py's :class:`~exhibit.commands._releases.Releases`, built on
:class:`ReleaseTree`.
"""

from __future__ import annotations

import os
import stat
import subprocess
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from exhibit.commands import _checkout as checkout
from exhibit.commands import _release_checks as checks
from exhibit.commands import _update_journal as jr
from exhibit.commands import install as inst
from exhibit.commands._bounded import decode, run_bounded
from exhibit.errors import ExhibitError
from exhibit.schema import files, links

PREVIOUS = "previous"
#: The lock file in PREFIX-releases/ that keeps two updates or rollbacks apart.
LOCK = jr.LOCK
#: Seconds each external step may take before it is stopped (its whole process group) and the
#: update fails: a hung `exhibit prepare` or restart never makes an update wait forever.
#: `exhibit install` builds the mesh cache too; a restart waits for the unit's
#: TimeoutStartSec=300 and TimeoutStopSec=10.
#: `exhibit --version`, the check that a release runs at all, before it is switched to.
TIMEOUTS = {"check-config": 300, "prepare": 3600, "install": 3600, "restart": 420, "version": 120}


def _user_exists(name: str) -> bool:
    return inst._user_exists(name)


def _release_name(name: str) -> bool:
    return name not in ("", ".", "..", PREVIOUS) and not name.startswith(".")


class ReleaseTree:
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
            checkout.clean_links(self.host(self.releases))
            yield
        finally:
            os.close(fd)

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
        why = self._runs(name)
        if why:
            raise ExhibitError(f"{self.releases}/{name} does not run: {why}; nothing was switched")
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

    def _runs(self, name: str) -> str:
        """Why the release ``name`` does not run, or "": its `exhibit --version` must print
        ``exhibit VERSION``, VERSION its own exhibit/__init__.py's (not only exit 0)."""
        exe = self.exe(name)
        version = checks.expected_version(self.host(f"{self.releases}/{name}"))
        if version is None:
            return f"no __version__ in {self.releases}/{name}/exhibit/__init__.py"
        result, why = self._call([exe, "--version"], "version")
        said = result.stdout.strip()
        if why:
            return why if why.startswith(exe) else f"{exe} --version: {why}"
        if said != f"exhibit {version}":
            shown = repr(said[:60]) if said else "nothing"
            return f"{exe} --version printed {shown}, not 'exhibit {version}'"
        return ""

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

    def _switch(
        self, name: str, current: str | None, old_previous: str | None, moved: bool = False
    ) -> None:
        """PREFIX-releases/previous -> ``current``, then PREFIX -> the release, each replaced in
        one rename (a running kiosk sees the old or the new link, never none). When a rename
        fails, what was done is undone (previous -> ``old_previous``, the ``moved`` checkout
        back at PREFIX) and nothing is switched. ``current``'s venv is made its own first (a
        checkout moved by an older update still names PREFIX), so `previous` runs by itself."""
        base = os.path.basename(self.releases)
        previous = self.host(f"{self.releases}/{PREVIOUS}")
        if current:
            where = f"{self.releases}/{current}"
            checkout.own_venv(self.host(where), self.prefix, where, self.out)
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

    def _switch_links(self, name: str, previous: str | None, owed: str) -> None:
        """PREFIX -> ``name`` and previous -> the text ``previous`` (None: no link), each in one
        rename; an ExhibitError ending in ``owed`` when one fails."""
        link = self.host(f"{self.releases}/{PREVIOUS}")
        try:
            links.replace_link(self.host(self.prefix), f"{os.path.basename(self.releases)}/{name}")
            if previous is None:
                link.unlink(missing_ok=True)
            else:
                links.replace_link(link, previous)
        except OSError as exc:
            raise ExhibitError(
                f"cannot switch {self.prefix} to {name}: {exc.strerror or exc}; {owed}"
            ) from None
        self.out(f"switched {self.prefix} -> {self.releases}/{name}")


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
