"""`exhibit update RELEASE [--prefix DIR] [--keep N]`: switch a deployed kiosk to a new release
(docs/DEPLOYMENT.md, "8. Updating"); `./bootstrap.sh update` makes RELEASE and then runs this.

Releases live side by side in PREFIX-releases/ (/opt/exhibit-releases/VERSION-DATE/), each with
its own .venv; PREFIX (/opt/exhibit) is a symbolic link to the current one, so the units, which
run PREFIX/.venv/bin/exhibit, never change. The site configuration is in /etc/exhibit, outside
every release, and is never touched. An update, in order, stopping at the first failure:

1. checks the site configuration with the new release (`exhibit check-config`, as the service's
   user with the service's environment): a file the new version refuses stops the update here;
2. builds the mesh cache with the new release (`exhibit prepare`, the same way), while the old
   release still runs: the restart draws at once;
3. switches PREFIX to the new release in one rename (a checkout that is a plain folder at PREFIX,
   as step 2 of the deployment makes it, first moves into PREFIX-releases/ as a release itself),
   and remembers the old one as PREFIX-releases/previous;
4. runs the new release's `exhibit install` (units, udev, systemd reload) and restarts
   exhibit.service if it runs;
5. removes the oldest releases beyond --keep, never the current or the previous one.

`exhibit rollback` (exhibit/commands/rollback.py) switches back the same way.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

from exhibit.commands import install as inst
from exhibit.errors import ExhibitError

HELP = (
    "switch a deployed kiosk to a release made by ./bootstrap.sh update: check the site "
    "config, build the cache, switch, restart"
)

PREVIOUS = "previous"
#: releases kept by default, the current and the previous one included
KEEP = 3
RESTART = ["systemctl", "try-restart", "exhibit.service"]


def add_arguments(parser) -> None:
    parser.add_argument(
        "release",
        metavar="RELEASE",
        help="the new release's folder, in PREFIX-releases/, with its .venv "
        "(./bootstrap.sh update makes it)",
    )
    add_prefix(parser)
    parser.add_argument(
        "--keep",
        type=int,
        default=KEEP,
        metavar="N",
        help="releases to keep, the current and the previous one included "
        f"(default {KEEP}, at least 2)",
    )


def add_prefix(parser) -> None:
    parser.add_argument(
        "--prefix",
        default=inst.DEFAULT_PREFIX,
        metavar="DIR",
        help=f"the path the units run the exhibit from (default "
        f"{inst.DEFAULT_PREFIX}); the releases are in DIR-releases/",
    )


def run(args) -> int:
    prefix = inst.check_prefix(args.prefix)
    if args.keep < 2:
        raise ExhibitError(
            f"--keep {args.keep}: keep at least 2 (the current and the previous release)"
        )
    need_root("update", prefix)
    release = os.path.normpath(os.path.abspath(args.release))
    return Kiosk(prefix).update(release, keep=args.keep)


def need_root(what: str, prefix: str) -> None:
    if os.geteuid() != 0:
        raise ExhibitError(f"{what} needs root (it switches {prefix} and restarts the kiosk)")


def _run(command: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(command, capture_output=True, text=True)


def _user_exists(name: str) -> bool:
    return inst._user_exists(name)


class Kiosk:
    """The releases of one kiosk. Paths are as the kiosk sees them (``prefix``); files are read
    and changed under ``root`` (/ on the kiosk, a folder in the tests). ``runner`` runs a command
    and returns a CompletedProcess, ``out`` hears the progress."""

    def __init__(
        self,
        prefix: str = inst.DEFAULT_PREFIX,
        root: Path = Path("/"),
        runner: Callable = _run,
        out: Callable[[str], None] = print,
        user_exists: Callable[[str], bool] = _user_exists,
    ):
        self.prefix = prefix
        self.releases = prefix + "-releases"
        self.root, self.runner, self.out, self.user_exists = root, runner, out, user_exists

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

    # ------------------------------------------------------------------ commands

    def update(self, release: str, keep: int = KEEP) -> int:
        parent, name = os.path.split(release)
        if parent != self.releases or name in ("", PREVIOUS) or name.startswith("."):
            raise ExhibitError(
                f"{release}: a release must be a folder in {self.releases}/ "
                "(./bootstrap.sh update makes one)"
            )
        if not self.host(release).is_dir():
            raise ExhibitError(f"{release}: no such folder")
        self._check_release(name)
        current = self.current()
        if current == name:
            raise ExhibitError(f"{release} is the current release already")
        self.out(f"updating {self.prefix} to {name}")
        self._ready(name)
        if current == "":
            current = self._move_checkout()
        self._switch(name, previous=current)
        self._install_and_restart(name)
        self._prune(keep)
        back = self.exe(name)
        self.out(
            f"updated: {self.prefix} is {name}"
            + (f" (previous: {current}; back to it with: {back} rollback)" if current else "")
        )
        return 0

    def rollback(self) -> int:
        current = self.current()
        if not current:
            raise ExhibitError(
                f"{self.prefix} is not a release link: nothing to roll back to "
                "(./bootstrap.sh update makes releases; docs/DEPLOYMENT.md, 8)"
            )
        previous = self.previous()
        if previous is None:
            raise ExhibitError(
                f"no previous release in {self.releases}/ to roll back to "
                f"(the current one, {current}, is the only one)"
            )
        if not self.host(f"{self.releases}/{previous}").is_dir():
            raise ExhibitError(f"the previous release {self.releases}/{previous} is gone")
        self._check_release(previous)
        self.out(f"rolling {self.prefix} back from {current} to {previous}")
        self._ready(previous)
        self._switch(previous, previous=current)
        self._install_and_restart(previous)
        self.out(
            f"rolled back: {self.prefix} is {previous}; to undo (back to {current}): "
            f"{self.exe(current)} rollback"
        )
        return 0

    # ------------------------------------------------------------------ steps

    def _check_release(self, name: str) -> None:
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
            text = inst.render(unit.read_text(encoding="utf-8"), self.prefix)
        except OSError:  # a release installed from its wheel alone: the shipped unit
            text = inst.render(
                (inst.SOURCE_DIR / "exhibit.service").read_text(encoding="utf-8"), self.prefix
            )
        return inst.service_environment(
            text, inst.environment_file(self.root / inst.SITE_ENVIRONMENT)
        )

    def _ready(self, name: str) -> None:
        """Check the site config with the release, and build its mesh cache, as the service's
        user with the service's environment, before anything is switched."""
        env, exe = self._environment(name), self.exe(name)
        if not self.user_exists(inst.USER):
            self._step(["env", "-i", *env, exe, "check-config"], "the site configuration")
            self.out(
                f"note: no user {inst.USER} yet: `exhibit install` makes it and builds the cache"
            )
            return
        self._step(inst.as_service(exe, ["check-config"], env), "the site configuration")
        if not self._has_prepare(name):
            self.out(f"note: {name} has no `exhibit prepare`: its first start builds the cache")
            return
        for command in inst.prepare_steps(exe, env):
            self._step(command, "building the mesh cache")

    def _has_prepare(self, name: str) -> bool:
        release = self.host(f"{self.releases}/{name}")
        return any(release.glob("exhibit/commands/prepare.py")) or any(
            release.glob(".venv/lib/python3*/site-packages/exhibit/commands/prepare.py")
        )

    def _step(self, command: list[str], what: str) -> subprocess.CompletedProcess:
        self.out("$ " + _short(command))
        try:
            result = self.runner(command)
        except OSError as exc:
            raise ExhibitError(
                f"{what}: {command[0]}: {exc.strerror or exc}; nothing was switched"
            ) from None
        if result.returncode != 0:
            lines = (result.stdout or "").strip().splitlines() + (
                result.stderr or ""
            ).strip().splitlines()
            for line in lines[-20:-1]:
                self.out("  " + line)
            why = lines[-1] if lines else f"exit code {result.returncode}"
            raise ExhibitError(f"{what} failed ({why}); nothing was switched")
        return result

    def _move_checkout(self) -> str:
        """Move the plain folder at PREFIX (a checkout from before releases) into the releases,
        as a release; its .venv keeps working, since everything in it names PREFIX."""
        version = "old"
        init = self.host(f"{self.prefix}/exhibit/__init__.py")
        match = (
            re.search(r'^__version__ = "([^"]+)"', init.read_text(encoding="utf-8"), re.M)
            if init.is_file()
            else None
        )
        if match:
            version = match.group(1)
        name = f"{version}-checkout-{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}"
        target = self.host(f"{self.releases}/{name}")
        self.out(f"moving the checkout {self.prefix} to {self.releases}/{name}")
        try:
            os.rename(self.host(self.prefix), target)
        except OSError as exc:
            raise ExhibitError(
                f"cannot move {self.prefix} to {self.releases}/{name}: "
                f"{exc.strerror or exc} (a mount point? move it by hand, then "
                f"ln -s {os.path.basename(self.releases)}/{name} {self.prefix})"
            ) from None
        return name

    def _switch(self, name: str, previous: str | None) -> None:
        """PREFIX -> the release, and PREFIX-releases/previous -> ``previous``, each replaced in
        one rename (a running kiosk sees the old or the new link, never none)."""
        base = os.path.basename(self.releases)
        _replace_link(self.host(self.prefix), f"{base}/{name}")
        if previous:
            _replace_link(self.host(f"{self.releases}/{PREVIOUS}"), previous)
        self.out(f"switched {self.prefix} -> {self.releases}/{name}")

    def _install_and_restart(self, name: str) -> None:
        exe = f"{self.prefix}/.venv/bin/exhibit"
        for command, what in (
            ([exe, "install", "--prefix", self.prefix], "exhibit install"),
            (RESTART, "the restart"),
        ):
            self.out("$ " + _short(command))
            try:
                result = self.runner(command)
            except OSError as exc:
                result = subprocess.CompletedProcess(command, 1, "", exc.strerror or str(exc))
            for line in (result.stdout or "").strip().splitlines():
                self.out("  " + line)
            if result.returncode != 0:
                lines = (result.stderr or result.stdout or "").strip().splitlines()
                why = lines[-1] if lines else f"exit code {result.returncode}"
                raise ExhibitError(
                    f"{self.prefix} is now {name}, but {what} failed: {why}; fix "
                    f"that and run it again, or go back: {exe} rollback"
                )

    def _prune(self, keep: int) -> None:
        folder = self.host(self.releases)
        held = {self.current(), self.previous()}
        names = [
            p
            for p in folder.iterdir()
            if p.is_dir()
            and not p.is_symlink()
            and not p.name.startswith(".")
            and p.name != PREVIOUS
        ]
        old = sorted(
            (p for p in names if p.name not in held), key=lambda p: p.stat().st_mtime, reverse=True
        )
        for path in old[max(0, keep - len(held & {p.name for p in names})) :]:
            self.out(f"removing the old release {self.releases}/{path.name}")
            shutil.rmtree(path)


def _replace_link(link: Path, target: str) -> None:
    tmp = link.with_name(f".{link.name}.exhibit-switch")
    try:
        tmp.unlink()
    except FileNotFoundError:
        pass
    os.symlink(target, tmp)
    os.replace(tmp, link)


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
