"""Updating a deployed kiosk (`exhibit update`, `exhibit rollback`; docs/DEPLOYMENT.md, 8) in a
folder standing for /: releases side by side, PREFIX a link switched in one rename, the site
configuration in /etc/exhibit untouched, the mesh cache built as the service's user before the
restart, and one command back. No real systemctl or runuser: the commands are recorded."""

from __future__ import annotations

import errno
import json
import os
import re
import subprocess
import time

import pytest

from exhibit.cli import main
from exhibit.commands import install as inst
from exhibit.commands import _bounded, _release_checks, rollback, update
from exhibit.commands import _update_journal as journal
from exhibit.commands.update import LOCK, Releases
from exhibit.errors import ExhibitError
from exhibit.schema import links
from tests.deploy.unitfile import environment, units

PREFIX = "/opt/exhibit"
RELEASES = "/opt/exhibit-releases"
SITE = "[display]\nmonitor = 1\n"


class Runner:
    """Records each command; ``fail`` maps a word in the command to (exit code, stderr). A
    release's `exhibit --version` (the check that it runs) runs its script under ``root``
    (set by :func:`kiosk`), recorded apart, in ``versions``."""

    def __init__(self, fail: dict[str, tuple[int, str]] | None = None):
        self.commands: list[list[str]] = []
        self.versions: list[str] = []
        self.fail = fail or {}
        self.root = None

    def __call__(self, command, timeout=None):
        if command[1:] == ["--version"] and self.root is not None:
            self.versions.append(command[0])
            return _bounded.run_bounded([str(self.root / command[0].lstrip("/")), "--version"], 60)
        self.commands.append(command)
        for word, (code, err) in self.fail.items():
            if word in command:
                return subprocess.CompletedProcess(command, code, "", err)
        return subprocess.CompletedProcess(command, 0, "", "")

    def index(self, *words: str) -> int:
        return next(i for i, c in enumerate(self.commands) if all(w in c for w in words))


def make_release(root, name, version="0.2.0", prepare=True, folder=None):
    """A release as ./bootstrap.sh update leaves it: source, systemd/, .venv/bin/exhibit."""
    release = root / (folder or RELEASES.lstrip("/")) / name
    (release / "exhibit/commands").mkdir(parents=True)
    (release / "exhibit/__init__.py").write_text(f'__version__ = "{version}"\n')
    if prepare:
        (release / "exhibit/commands/prepare.py").write_text("")
    (release / "systemd").mkdir()
    (release / "systemd/exhibit.service").write_text(
        (inst.SOURCE_DIR / "exhibit.service").read_text()
    )
    exe = release / ".venv/bin/exhibit"
    exe.parent.mkdir(parents=True)
    exe.write_text(f'#!/bin/sh\n[ "$1" = --version ] && echo "exhibit {version}"\nexit 0\n')
    exe.chmod(0o755)
    return release


@pytest.fixture
def root(tmp_path):
    """A kiosk deployed the old way: a checkout at /opt/exhibit, the site file in /etc/exhibit."""
    root = tmp_path / "root"
    make_release(root, "exhibit", version="0.1.0", folder="opt")
    (root / "etc/exhibit").mkdir(parents=True)
    (root / "etc/exhibit/kiosk.toml").write_text(SITE)
    (root / "etc/exhibit/environment").write_text(
        "# site settings\nEXHIBIT_CONFIG=/etc/exhibit/kiosk.toml\nEXHIBIT_DEVICES_CONFIG="
        "/etc/exhibit/devices.toml\n"
    )
    return root


def kiosk(root, runner, lines=None, user=True):
    if isinstance(runner, Runner):
        runner.root = root
    return Releases(
        PREFIX,
        root=root,
        runner=runner,
        out=(lines.append if lines is not None else lambda line: None),
        user_exists=lambda name: user,
    )


def test_the_first_update_moves_the_checkout_aside_and_switches(root):
    make_release(root, "0.2.0-20250601T120000Z")
    runner, lines = Runner(), []
    assert kiosk(root, runner, lines).update(f"{RELEASES}/0.2.0-20250601T120000Z") == 0

    prefix = root / "opt/exhibit"
    assert prefix.is_symlink() and os.readlink(prefix) == "exhibit-releases/0.2.0-20250601T120000Z"
    (moved,) = [
        p for p in (root / "opt/exhibit-releases").iterdir() if p.name.startswith("0.1.0-checkout-")
    ]
    assert (moved / ".venv/bin/exhibit").exists()
    assert os.readlink(root / "opt/exhibit-releases/previous") == moved.name
    # the site configuration is outside every release and untouched
    assert (root / "etc/exhibit/kiosk.toml").read_text() == SITE
    assert lines[-1].endswith(f"{RELEASES}/0.2.0-20250601T120000Z/.venv/bin/exhibit rollback)")


def test_config_and_cache_come_first_as_the_service_user_then_switch_install_restart(root):
    make_release(root, "new")
    seen = {}

    class Watching(Runner):
        def __call__(self, command, timeout=None):
            seen[len(self.commands)] = os.path.realpath(root / "opt/exhibit")
            return super().__call__(command, timeout)

    runner = Watching()
    kiosk(root, runner).update(f"{RELEASES}/new")
    check = runner.index("check-config")
    cache = runner.index("prepare")
    install = runner.index("install", "--prefix")
    restart = runner.index("try-restart")
    assert check < cache < install < restart
    new = f"{RELEASES}/new/.venv/bin/exhibit"
    for step in (check, cache):
        command = runner.commands[step]
        assert command[:6] == ["runuser", "-u", "exhibit", "--", "env", "-i"]
        assert new in command  # the new release's own path: the old one still runs meanwhile
        # the service's environment: the unit's and then the site's file
        assert "EXHIBIT_CACHE_DIR=/var/cache/exhibit/meshes" in command
        assert "EXHIBIT_CONFIG=/etc/exhibit/kiosk.toml" in command
        assert "HOME=/var/lib/exhibit" in command
        # exactly: PATH, HOME, the unit's Environment= and the site's file; nothing of ours
        env = dict(w.split("=", 1) for w in command[6 : command.index(new)])
        unit = environment(units(inst.SOURCE_DIR / "exhibit.service")["Service"])
        assert env == {
            "PATH": inst.SERVICE_PATH,
            "HOME": "/var/lib/exhibit",
            **unit,
            "EXHIBIT_CONFIG": "/etc/exhibit/kiosk.toml",
            "EXHIBIT_DEVICES_CONFIG": "/etc/exhibit/devices.toml",
        }
        assert seen[step].endswith("/opt/exhibit")  # not switched yet
    # the cache folder, and what is in it, for the user
    assert [c[:2] for c in runner.commands[cache - 2 : cache]] == [
        ["install", "-d"],
        ["chown", "-R"],
    ]
    # the install the update runs builds no second cache and prints no first start's hint
    assert runner.commands[install][:3] == [
        "env",
        f"{inst.FOR_UPDATE_ENV}=1",
        f"{PREFIX}/.venv/bin/exhibit",
    ]
    assert runner.commands.count([c for c in runner.commands if "prepare" in c][0]) == 1
    assert seen[install].endswith("/opt/exhibit-releases/new")  # switched before install
    assert runner.commands[restart] == ["systemctl", "try-restart", "exhibit.service"]


def test_rollback_switches_back_and_a_second_rollback_undoes_it(root):
    make_release(root, "a")
    make_release(root, "b")
    k = kiosk(root, Runner())
    k.update(f"{RELEASES}/a")
    k.update(f"{RELEASES}/b")
    assert (k.current(), k.previous()) == ("b", "a")
    runner, lines = Runner(), []
    assert kiosk(root, runner, lines).rollback() == 0
    assert (k.current(), k.previous()) == ("a", "b")
    assert (
        runner.index("prepare") < runner.index("install", "--prefix") < runner.index("try-restart")
    )
    assert f"{RELEASES}/a/.venv/bin/exhibit" in runner.commands[runner.index("prepare")]
    assert lines[-1].endswith(f"{RELEASES}/b/.venv/bin/exhibit rollback")
    kiosk(root, Runner()).rollback()
    assert (k.current(), k.previous()) == ("b", "a")
    assert (root / "etc/exhibit/kiosk.toml").read_text() == SITE


def test_rolling_back_to_the_old_checkout_skips_a_prepare_it_does_not_have(root):
    (root / "opt/exhibit/exhibit/commands/prepare.py").unlink()
    make_release(root, "new")
    kiosk(root, Runner()).update(f"{RELEASES}/new")
    runner, lines = Runner(), []
    kiosk(root, runner, lines).rollback()
    assert not any("prepare" in c for c in runner.commands)
    assert any("has no `exhibit prepare`" in line for line in lines)
    assert os.path.realpath(root / "opt/exhibit").startswith(
        str(root / "opt/exhibit-releases/0.1.0-checkout-")
    )


@pytest.mark.parametrize(
    "word, message",
    [
        (
            "check-config",
            "the site configuration failed (kiosk.toml: display.monitor: bad); "
            "nothing was switched",
        ),
        (
            "prepare",
            "building the mesh cache failed (kiosk.toml: display.monitor: bad); nothing "
            "was switched",
        ),
    ],
)
def test_a_refused_config_or_a_failed_cache_build_switches_nothing(root, word, message):
    make_release(root, "new")
    runner = Runner(fail={word: (2, "Traceback?\nkiosk.toml: display.monitor: bad\n")})
    with pytest.raises(ExhibitError) as info:
        kiosk(root, runner).update(f"{RELEASES}/new")
    assert str(info.value) == message
    assert not (root / "opt/exhibit").is_symlink()  # the old checkout is where it was
    assert not any("try-restart" in c for c in runner.commands)


class FailsOn(Runner):
    """Fails ``word``'s command (exit 1, ``err``) while PREFIX is the release ``bad``."""

    def __init__(self, root, word: str, bad: str, err: str = "udevadm failed"):
        super().__init__()
        self.root, self.word, self.bad, self.err = root, word, bad, err

    def __call__(self, command, timeout=None):
        now = os.path.basename(os.path.realpath(self.root / "opt/exhibit"))
        if self.word in command and now == self.bad:
            self.commands.append(command)
            return subprocess.CompletedProcess(command, 1, "", self.err + "\n")
        return super().__call__(command, timeout)


@pytest.mark.parametrize("word", ["--prefix", "try-restart"])
def test_a_failed_install_or_restart_after_the_switch_rolls_back_by_itself(root, word):
    make_release(root, "a")
    make_release(root, "b")
    k = kiosk(root, Runner())
    k.update(f"{RELEASES}/a")
    checkout = k.previous()
    runner = FailsOn(root, word, "b")
    with pytest.raises(ExhibitError) as info:
        kiosk(root, runner).update(f"{RELEASES}/b")
    what = "exhibit install" if word == "--prefix" else "the restart"
    assert str(info.value) == (
        f"b: {what} failed: udevadm failed; rolled back: /opt/exhibit is a again"
    )
    assert (k.current(), k.previous()) == ("a", checkout)  # both links as they were
    # the old release's units and process are back too: its install and restart ran again
    failed = runner.index(word)
    assert runner.index("install", "--prefix") <= failed
    assert any("install" in c for c in runner.commands[failed + 1 :])
    assert ["systemctl", "try-restart", "exhibit.service"] in runner.commands[failed + 1 :]


def test_a_failed_first_update_goes_back_to_the_moved_checkout(root):
    make_release(root, "new")
    runner = FailsOn(root, "--prefix", "new")
    with pytest.raises(ExhibitError, match="rolled back: /opt/exhibit is 0.1.0-checkout-"):
        kiosk(root, runner).update(f"{RELEASES}/new")
    assert kiosk(root, Runner()).current().startswith("0.1.0-checkout-")
    assert not os.path.lexists(root / "opt/exhibit-releases/previous")  # none before, none now


def test_when_the_old_release_fails_too_the_message_says_both(root):
    make_release(root, "new")
    runner = Runner(fail={"--prefix": (1, "exhibit install: error: udevadm failed\n")})
    with pytest.raises(
        ExhibitError,
        match=r"^new: exhibit install failed: .*udevadm failed; /opt/exhibit is "
        r"0.1.0-checkout-\S+ again, but its exhibit install failed: .* fix that and run "
        r"/opt/exhibit/.venv/bin/exhibit install --prefix /opt/exhibit$",
    ):
        kiosk(root, runner).update(f"{RELEASES}/new")


def test_a_failed_install_on_a_fresh_machine_says_there_is_nothing_to_go_back_to(tmp_path):
    root = tmp_path / "root"
    make_release(root, "first")
    runner = Runner(fail={"--prefix": (1, "udevadm failed\n")})
    with pytest.raises(ExhibitError, match="now first, but exhibit install failed: udevadm "):
        kiosk(root, runner, user=False).update(f"{RELEASES}/first")


def test_a_fresh_machine_gets_its_first_release_and_install_makes_the_user(tmp_path):
    root = tmp_path / "root"
    make_release(root, "first")
    runner, lines = Runner(), []
    kiosk(root, runner, lines, user=False).update(f"{RELEASES}/first")
    assert os.readlink(root / "opt/exhibit") == "exhibit-releases/first"
    assert runner.commands[0][:2] == ["env", "-i"] and runner.commands[0][-1] == "check-config"
    assert not any("prepare" in c for c in runner.commands)  # install runs it, as the new user
    assert not (root / "opt/exhibit-releases/previous").exists()
    with pytest.raises(ExhibitError, match="no previous release"):
        kiosk(root, Runner()).rollback()


def test_old_releases_are_pruned_but_never_the_current_or_previous(root):
    k = kiosk(root, Runner())
    for i, name in enumerate(["r1", "r2", "r3", "r4", "r5"]):
        make_release(root, name)
        os.utime(root / "opt/exhibit-releases" / name, (2e9 + i, 2e9 + i))  # newer each time
        if name == "r5":
            k.rollback()  # current r3, previous r4
        k.update(f"{RELEASES}/{name}", keep=3 if name != "r5" else 2)
        if name == "r4":  # r4, r3 and the newest other one (r2): not r1, not the checkout
            assert listing(root) == [
                "previous",
                "r2",
                "r3",
                "r4",
            ]
    assert listing(root) == ["previous", "r3", "r5"]


def listing(root):
    """PREFIX-releases/, less the lock file (never a half-removed release: no dot-folders)."""
    return sorted(p.name for p in (root / "opt/exhibit-releases").iterdir() if p.name != LOCK)


@pytest.mark.parametrize(
    "release, message",
    [
        ("/srv/elsewhere/new", "a release must be a folder in /opt/exhibit-releases/"),
        (f"{RELEASES}/missing", "/opt/exhibit-releases/missing: no such folder"),
        (f"{RELEASES}/previous", "a release must be a folder"),
    ],
)
def test_bad_releases_are_refused_in_one_line(root, release, message):
    with pytest.raises(ExhibitError, match=message):
        kiosk(root, Runner()).update(release)


def test_a_release_without_its_venv_is_refused(root):
    release = make_release(root, "novenv")
    (release / ".venv/bin/exhibit").unlink()
    with pytest.raises(ExhibitError, match="has no venv"):
        kiosk(root, Runner()).update(f"{RELEASES}/novenv")


def test_the_same_release_twice_is_refused(root):
    make_release(root, "new")
    kiosk(root, Runner()).update(f"{RELEASES}/new")
    with pytest.raises(ExhibitError, match="is the current release already"):
        kiosk(root, Runner()).update(f"{RELEASES}/new")


def test_rollback_without_releases_is_one_line(root):
    with pytest.raises(ExhibitError, match="not a release link: nothing to roll back to"):
        kiosk(root, Runner()).rollback()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["update", "/x", "--keep", "1"], "--keep 1: keep at least 2"),
        (["update", "/x", "--prefix", "/tmp/exhibit"], "cannot use /tmp"),
        (["rollback", "--prefix", "opt"], "must be an absolute path"),
    ],
)
def test_cli_errors_are_one_line(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_cli_needs_root(capsys, monkeypatch):
    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    assert main(["rollback"]) == 2
    assert "rollback needs root" in capsys.readouterr().err


# ---------------------------------------------------------------------- hostile states (issue 33)


def real_runner(root):
    """update's own runner (time limits, decoding) on the commands as the kiosk would run them,
    less what needs root: runuser's user switch and the cache folder's `install -d` and
    `chown -R`."""

    def run(command, timeout=None):
        if command[:4] == ["runuser", "-u", "exhibit", "--"]:
            command = command[4:]
        if command[:2] in (["install", "-d"], ["chown", "-R"]):
            return subprocess.CompletedProcess(command, 0, "", "")
        command = [str(root / c.lstrip("/")) if c.startswith(RELEASES) else c for c in command]
        return _bounded.run_bounded(command, timeout)

    return run


def script_release(root, name, script):
    release = make_release(root, name)
    (release / ".venv/bin/exhibit").write_bytes(
        b'#!/bin/sh\n[ "$1" = --version ] && { echo "exhibit 0.2.0"; exit 0; }\n' + script
    )
    return release


def nothing_changed(root):
    assert not (root / "opt/exhibit").is_symlink()  # the old checkout is where it was
    assert not os.path.lexists(root / "opt/exhibit-releases/previous")


def test_a_release_that_prints_bytes_that_are_not_utf8_is_reported_not_a_traceback(root):
    script_release(root, "new", b"printf 'display.monitor: bad \\377\\376\\n' >&2; exit 2\n")
    with pytest.raises(ExhibitError) as info:
        kiosk(root, real_runner(root)).update(f"{RELEASES}/new")
    assert str(info.value) == (
        "the site configuration failed (display.monitor: bad \ufffd\ufffd); nothing was switched"
    )
    nothing_changed(root)


def test_a_prepare_that_never_returns_is_stopped_and_nothing_is_switched(root, tmp_path):
    """`exhibit prepare` starts a child and never returns: both are stopped (the whole process
    group) at the step's time limit, here shortened to 1 s."""
    pid = tmp_path / "pid"
    script_release(
        root, "new", f'[ "$1" = prepare ] || exit 0\nsleep 600 & echo $! > {pid}\nwait\n'.encode()
    )
    k = kiosk(root, real_runner(root))
    k.timeouts["prepare"] = 1
    with pytest.raises(ExhibitError) as info:
        k.update(f"{RELEASES}/new")
    assert str(info.value) == (
        "building the mesh cache failed (no answer within 1 s: stopped); nothing was switched"
    )
    nothing_changed(root)
    child = int(pid.read_text())
    deadline = time.monotonic() + 60  # only bounds a hang: the kill was sent already
    while time.monotonic() < deadline and alive(child):
        time.sleep(0.05)
    assert not alive(child)


def alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_a_restart_that_times_out_after_the_switch_rolls_back(root):
    rolled_forward(root)
    make_release(root, "c")

    class Hangs(Runner):
        def __call__(self, command, timeout=None):
            now = os.path.basename(os.path.realpath(root / "opt/exhibit"))
            if "try-restart" in command and now == "c":
                self.commands.append(command)
                raise subprocess.TimeoutExpired(command, timeout or 0)
            return super().__call__(command, timeout)

    with pytest.raises(ExhibitError) as info:
        kiosk(root, Hangs()).update(f"{RELEASES}/c")
    assert str(info.value) == (
        f"c: the restart failed: no answer within {update.TIMEOUTS['restart']} s: stopped; "
        "rolled back: /opt/exhibit is b again"
    )
    assert os.readlink(root / "opt/exhibit") == "exhibit-releases/b"
    assert os.readlink(root / "opt/exhibit-releases/previous") == "a"


@pytest.mark.parametrize("kind", ["fifo", "device", "folder"])
def test_a_site_environment_that_is_not_a_file_is_refused_by_name(root, kind):
    env = root / "etc/exhibit/environment"
    env.unlink()
    if kind == "fifo":
        os.mkfifo(env)  # reading it would block forever
    elif kind == "device":
        env.symlink_to("/dev/zero")  # reading it would never end
    else:
        env.mkdir()
    make_release(root, "new")
    runner = Runner()
    with pytest.raises(ExhibitError) as info:
        kiosk(root, runner).update(f"{RELEASES}/new")
    what = {"fifo": "a FIFO", "device": "a character device", "folder": "a folder"}[kind]
    assert str(info.value) == f"cannot read {env}: {what}, not a regular file"
    assert runner.commands == []
    nothing_changed(root)


def test_stale_switch_links_and_an_empty_switch_folder_are_cleaned(root):
    """What a killed switch may leave beside /opt/exhibit, and the old fixed temporary name as
    a folder: the update goes on, the links and the empty folder gone."""
    (root / "opt/.exhibit.exhibit-switch").mkdir()
    (root / "opt/.exhibit.0123456789ab.exhibit-switch").symlink_to("exhibit-releases/gone")
    make_release(root, "new")
    (root / "opt/exhibit-releases/.previous.exhibit-switch").symlink_to("gone")
    assert kiosk(root, Runner()).update(f"{RELEASES}/new") == 0
    assert sorted(p.name for p in (root / "opt").iterdir()) == ["exhibit", "exhibit-releases"]
    assert not os.path.lexists(root / "opt/exhibit-releases/.previous.exhibit-switch")


def test_a_stale_switch_folder_with_something_in_it_is_left_and_named(root):
    stale = root / "opt/.exhibit.exhibit-switch"
    stale.mkdir()
    (stale / "notes.txt").write_text("someone's\n")
    make_release(root, "new")
    lines = []
    assert kiosk(root, Runner(), lines).update(f"{RELEASES}/new") == 0
    assert (stale / "notes.txt").exists()
    assert any(f"{stale} cannot be removed" in line and "left as it is" in line for line in lines)


@pytest.mark.parametrize("kind", ["folder", "empty folder", "file"])
def test_a_previous_that_is_not_a_link_is_refused_before_anything_changes(root, kind):
    """Today a folder at previous failed the update after PREFIX had switched: install and
    restart never ran."""
    make_release(root, "new")
    previous = root / "opt/exhibit-releases/previous"
    if kind == "file":
        previous.write_text("x")
    else:
        previous.mkdir()
        if kind == "folder":
            (previous / "keep").write_text("x")
    runner = Runner()
    with pytest.raises(ExhibitError) as info:
        kiosk(root, runner).update(f"{RELEASES}/new")
    what = "a file" if kind == "file" else "a folder"
    assert str(info.value).startswith(
        f"{RELEASES}/previous is {what}, not a link to a release: nothing was changed"
    )
    assert runner.commands == []
    assert not (root / "opt/exhibit").is_symlink()


def test_a_prefix_linked_to_something_that_is_not_a_release_is_refused(root):
    make_release(root, "new")
    elsewhere = root / "srv/exhibit"
    elsewhere.mkdir(parents=True)
    os.rename(root / "opt/exhibit", elsewhere / "x")
    (root / "opt/exhibit").symlink_to("../srv/exhibit/x")
    with pytest.raises(ExhibitError, match="/opt/exhibit -> ../srv/exhibit/x is not a release in"):
        kiosk(root, Runner()).update(f"{RELEASES}/new")
    assert os.readlink(root / "opt/exhibit") == "../srv/exhibit/x"


@pytest.mark.parametrize("how", ["busy", "mount point"])
def test_a_release_that_cannot_be_pruned_is_kept_and_the_update_is_done(root, monkeypatch, how):
    k = kiosk(root, Runner())
    for i, name in enumerate(["r1", "r2", "r3"]):
        make_release(root, name)
        os.utime(root / "opt/exhibit-releases" / name, (2e9 + i, 2e9 + i))
        k.update(f"{RELEASES}/{name}")
    make_release(root, "r4")
    r1 = root / "opt/exhibit-releases/r1"
    if how == "busy":
        real = _release_checks.shutil.rmtree

        def rmtree(path, *args, **kwargs):
            if path.name.startswith(".r1."):
                raise OSError(errno.EBUSY, "Device or resource busy")
            real(path, *args, **kwargs)

        monkeypatch.setattr(_release_checks.shutil, "rmtree", rmtree)
    else:
        real_ismount = os.path.ismount
        monkeypatch.setattr(
            os.path, "ismount", lambda p: os.fspath(p) == os.fspath(r1) or real_ismount(p)
        )
    lines = []
    assert kiosk(root, Runner(), lines).update(f"{RELEASES}/r4", keep=2) == 0
    assert (k.current(), k.previous()) == ("r4", "r3")
    if how == "busy":
        assert any("could not remove all of /opt/exhibit-releases/r1" in x for x in lines)
        # renamed first: a half-removed release is never taken for a release
        assert not r1.exists() and (root / "opt/exhibit-releases/.r1.exhibit-removing").is_dir()
        monkeypatch.undo()
        make_release(root, "r5")
        kiosk(root, Runner()).update(f"{RELEASES}/r5", keep=2)  # the next prune finishes it
        assert listing(root) == ["previous", "r4", "r5"]
    else:
        assert "note: kept the old release /opt/exhibit-releases/r1: it is a mount point" in lines
        assert (r1 / ".venv/bin/exhibit").exists()  # nothing inside it removed either


def test_only_one_update_or_rollback_at_a_time(root):
    make_release(root, "new")
    lock = root / "opt/exhibit-releases" / LOCK
    fd = links.hold_lock(lock, "pid 4242, exhibit update /opt/exhibit-releases/other\n")
    try:
        runner = Runner()
        for command in (lambda k: k.update(f"{RELEASES}/new"), lambda k: k.rollback()):
            with pytest.raises(ExhibitError) as info:
                command(kiosk(root, runner))
            assert str(info.value) == (
                "another update or rollback is running (pid 4242, exhibit update "
                "/opt/exhibit-releases/other): nothing was changed; wait for it, or see "
                f"{RELEASES}/{LOCK}"
            )
        assert runner.commands == []
        nothing_changed(root)
    finally:
        os.close(fd)
    assert kiosk(root, Runner()).update(f"{RELEASES}/new") == 0  # the lock went with its holder


def rolled_forward(root):
    """a, then b: current b, previous a."""
    for name in ("a", "b"):
        make_release(root, name)
        kiosk(root, Runner()).update(f"{RELEASES}/{name}")


@pytest.mark.parametrize(
    "target, message",
    [
        ("b", "previous -> b is the running release: nothing to roll back to"),
        ("../exhibit-releases/", "previous -> ../exhibit-releases/ is not a release in"),
        (".", "previous -> . is not a release in"),
        ("../exhibit/x", "previous -> ../exhibit/x is not a release in"),
        ("gone", "previous -> gone is not a release in"),
        ("previous", "previous -> previous is not a release in"),
    ],
)
def test_rollback_to_the_running_release_or_to_what_is_not_a_release_is_refused(
    root, target, message
):
    rolled_forward(root)
    link = root / "opt/exhibit-releases/previous"
    link.unlink()
    link.symlink_to(target)
    runner = Runner()
    with pytest.raises(ExhibitError, match=message) as info:
        kiosk(root, runner).rollback()
    assert str(info.value).endswith("nothing was changed")
    assert runner.commands == []  # no install, no restart
    assert os.readlink(root / "opt/exhibit") == "exhibit-releases/b"
    assert os.readlink(link) == target


def test_rollback_cli_refusal_is_one_line_exit_2(root, monkeypatch, capsys):
    rolled_forward(root)
    link = root / "opt/exhibit-releases/previous"
    link.unlink()
    link.symlink_to("b")
    monkeypatch.setattr(os, "geteuid", lambda: 0)
    monkeypatch.setattr(
        rollback,
        "Releases",
        lambda prefix: kiosk(root, Runner()),  # the same, under the root
    )
    assert main(["rollback"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is the running release" in err


# ---------------------------------------------------------------------- kill -9 at any moment

#: What changes the prefix's files; a kill -9 can come before any one of these calls.
_MUTATIONS = ("rename", "replace", "symlink", "unlink", "rmdir", "mkdir")


def killed_at(root, n: int, action) -> bool:
    """Run ``action`` in a forked child that dies (os._exit: no cleanup, no finally, as with
    kill -9) just before its ``n``-th change to the files; False when it finished first."""
    pid = os.fork()
    if pid == 0:  # the child
        code = 1
        try:
            count = [0]
            real_exchange = links.exchange

            def dies(real):
                def call(*args, **kwargs):
                    count[0] += 1
                    if count[0] == n:
                        os._exit(137)
                    return real(*args, **kwargs)

                return call

            for name in _MUTATIONS:
                setattr(os, name, dies(getattr(os, name)))
            links.exchange = dies(real_exchange)  # type: ignore[assignment]
            action()
            code = 0
        finally:  # never back into pytest in the child, whatever happened
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    code = os.waitstatus_to_exitcode(status)
    assert code in (0, 137), code
    return code == 137


def valid(root) -> str:
    """The release PREFIX runs ("" for the plain checkout); fails unless PREFIX and previous
    both name working releases."""
    prefix, releases = root / "opt/exhibit", root / "opt/exhibit-releases"
    assert (prefix / ".venv/bin/exhibit").exists(), "PREFIX does not run"
    previous = releases / "previous"
    if os.path.lexists(previous):
        assert previous.is_symlink() and (previous / ".venv/bin/exhibit").exists()
        assert os.path.dirname(os.path.realpath(previous)) == str(releases)
    if not prefix.is_symlink():
        return ""
    assert os.path.dirname(os.path.realpath(prefix)) == str(releases)
    return os.path.basename(os.path.realpath(prefix))


@pytest.mark.parametrize("first", [True, False])
def test_a_kill_at_any_moment_leaves_a_working_prefix_and_the_next_run_finishes(tmp_path, first):
    """Each change an update makes, in turn, is where it dies: PREFIX still runs the old
    release or the new one, and the same update run again finishes the job."""
    n = 1
    while True:
        root = tmp_path / f"run{n}"
        make_release(root, "exhibit", version="0.1.0", folder="opt")
        (root / "etc/exhibit").mkdir(parents=True)
        for name in [] if first else ["old1", "old2", "a"]:  # an old one to prune, too
            make_release(root, name)
            kiosk(root, Runner()).update(f"{RELEASES}/{name}")
        make_release(root, "b")
        before = valid(root)

        def update(root=root):  # made in the child, where the changes die
            kiosk(root, Runner()).update(f"{RELEASES}/b", keep=2)

        if not killed_at(root, n, update):
            break
        now = valid(root)
        # the old release (the checkout, maybe moved into the releases already) or the new one
        assert now in (before, "b") or (before == "" and now.startswith("0.1.0-checkout-")), n
        try:
            kiosk(root, Runner()).update(f"{RELEASES}/b", keep=2)
        except ExhibitError as exc:
            assert "is the current release already" in str(exc)
        assert valid(root) == "b"
        n += 1
    assert n > 5  # it did die at each step of a whole update


def test_the_time_limits_in_deployment_md_are_the_codes():
    text = " ".join((inst.SOURCE_DIR.parent / "docs/DEPLOYMENT.md").read_text().split())
    limits = update.TIMEOUTS
    assert (limits["check-config"], limits["prepare"], limits["install"]) == (300, 3600, 3600)
    assert limits["restart"] == 420
    assert "(check-config 5 min, prepare and install 1 h, the restart 7 min:" in text
    assert f"which one holds `/opt/exhibit-releases/{LOCK}`" in text


# ---------------------------------------------------------------------- the journal (issue 40)


class DiesAt(Runner):
    """Dies at ``word``'s command, before it runs: ``how`` "kill" (os._exit, as kill -9 or
    SIGHUP: no cleanup) or "ctrl-c" (KeyboardInterrupt, as Ctrl-C gives Python)."""

    def __init__(self, word: str, how: str = "kill"):
        super().__init__()
        self.word, self.how = word, how

    def __call__(self, command, timeout=None):
        if self.word in command:
            if self.how == "kill":
                os._exit(137)
            raise KeyboardInterrupt
        return super().__call__(command, timeout)


def interrupted(root, action, word: str, how: str = "kill") -> None:
    """``action(kiosk)`` stopped at ``word``'s command: a kill in a forked child (nothing of
    pytest runs there), Ctrl-C here."""
    if how == "ctrl-c":
        with pytest.raises(KeyboardInterrupt):
            action(kiosk(root, DiesAt(word, how)))
        return
    pid = os.fork()
    if pid == 0:  # the child
        try:
            action(kiosk(root, DiesAt(word)))
        finally:
            os._exit(1)  # it finished: the test below fails
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 137


def owed(root):
    return journal.owed_steps(root / "opt/exhibit")


@pytest.mark.parametrize("how", ["kill", "ctrl-c"])
@pytest.mark.parametrize("word", ["--prefix", "try-restart"])
def test_an_update_stopped_after_the_switch_is_finished_by_the_next_one(root, word, how):
    """Before: the same update again said `is the current release already` (exit 2), with
    install or restart never run and nothing saying so."""
    rolled_forward(root)
    make_release(root, "c")
    interrupted(root, lambda k: k.update(f"{RELEASES}/c"), word, how)
    assert (kiosk(root, Runner()).current(), kiosk(root, Runner()).previous()) == ("c", "b")
    install = (
        "owed: c's `exhibit install` (units, udev rules) has not run since the switch; by "
        "hand: env EXHIBIT_INSTALL_FOR_UPDATE=1 /opt/exhibit/.venv/bin/exhibit install "
        "--prefix /opt/exhibit"
    )
    restart = (
        "owed: exhibit.service has not been restarted into c; by hand: systemctl try-restart "
        "exhibit.service"
    )
    if how == "kill":
        first, *steps = owed(root)
        assert re.fullmatch(
            r"an update of /opt/exhibit to c stopped half-way \(pid \d+, since \S+\); finish it "
            r"with: /opt/exhibit-releases/c/\.venv/bin/exhibit update /opt/exhibit-releases/c",
            first,
        )
        assert steps == ([install] if word == "--prefix" else []) + [restart]
    runner, lines = Runner(), []
    assert kiosk(root, runner, lines).update(f"{RELEASES}/c") == 0
    assert lines[0] == "finishing the update of /opt/exhibit that stopped half-way: it owes " + (
        "install, restart" if word == "--prefix" else "restart"
    )
    assert lines[-1] == "updated: /opt/exhibit is c (the update that stopped is done)"
    done = [c for c in runner.commands if "install" in c or "try-restart" in c]
    assert done == (
        [
            ["env", "EXHIBIT_INSTALL_FOR_UPDATE=1", "/opt/exhibit/.venv/bin/exhibit", "install"]
            + ["--prefix", PREFIX]
        ]
        if word == "--prefix"
        else []
    ) + [update.RESTART]
    assert not any("check-config" in c for c in runner.commands)  # checked before the switch
    assert owed(root) == []
    assert not os.path.lexists(root / "opt/exhibit-releases" / journal.JOURNAL)
    with pytest.raises(ExhibitError, match="is the current release already"):
        kiosk(root, Runner()).update(f"{RELEASES}/c")  # now it is done


def test_another_update_finishes_the_stopped_one_first(root):
    rolled_forward(root)
    make_release(root, "c")
    make_release(root, "d")
    interrupted(root, lambda k: k.update(f"{RELEASES}/c"), "try-restart")
    runner = Runner()
    kiosk(root, runner).update(f"{RELEASES}/d")
    assert runner.commands[0] == update.RESTART  # c's owed restart, then d's update
    assert (kiosk(root, Runner()).current(), kiosk(root, Runner()).previous()) == ("d", "c")


@pytest.mark.parametrize("word", ["--prefix", "try-restart"])
def test_a_rollback_stopped_half_way_and_run_again_ends_where_one_rollback_does(root, word):
    """Before: the second rollback went back to where the first had started (b)."""
    rolled_forward(root)
    interrupted(root, lambda k: k.rollback(), word)
    assert owed(root)[0].endswith(
        "finish it with: /opt/exhibit-releases/b/.venv/bin/exhibit rollback"
    )
    runner, lines = Runner(), []
    assert kiosk(root, runner, lines).rollback() == 0
    k = kiosk(root, Runner())
    assert (k.current(), k.previous()) == ("a", "b")  # where one rollback ends
    assert runner.commands[-1] == update.RESTART
    assert lines[-1] == (
        "rolled back: /opt/exhibit is a (the rollback that stopped is done); to undo: "
        "/opt/exhibit-releases/b/.venv/bin/exhibit rollback"
    )
    assert owed(root) == []
    kiosk(root, Runner()).rollback()  # a third one is a rollback again: it undoes the first
    assert (k.current(), k.previous()) == ("b", "a")


def test_a_switch_back_that_was_stopped_is_finished_and_the_failure_said(root):
    rolled_forward(root)
    make_release(root, "c")

    class FailsThenDies(FailsOn):
        def __call__(self, command, timeout=None):
            now = os.path.basename(os.path.realpath(self.root / "opt/exhibit"))
            if "--prefix" in command and now == "b":
                os._exit(137)  # killed while installing b again
            return super().__call__(command, timeout)

    pid = os.fork()
    if pid == 0:
        try:
            kiosk(root, FailsThenDies(root, "try-restart", "c")).update(f"{RELEASES}/c")
        finally:
            os._exit(1)
    assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 137
    first = owed(root)[0]
    assert first.startswith(
        "an update of /opt/exhibit failed (c: the restart failed: udevadm failed) and was "
        "switching back to b when it stopped"
    )
    assert first.endswith(
        "finish switching back with: /opt/exhibit-releases/c/.venv/bin/"
        "exhibit update /opt/exhibit-releases/c"
    )
    runner = Runner()
    with pytest.raises(ExhibitError) as info:
        kiosk(root, runner).update(f"{RELEASES}/c")
    assert str(info.value) == (
        "the update that stopped had failed (c: the restart failed: udevadm failed); now "
        "switched back: /opt/exhibit is b"
    )
    assert runner.commands[-1] == update.RESTART and not any(
        "prepare" in c for c in runner.commands
    )
    assert (kiosk(root, Runner()).current(), kiosk(root, Runner()).previous()) == ("b", "a")
    assert owed(root) == []


def test_a_journal_of_a_switch_that_never_happened_owes_nothing(root):
    """Killed after the journal was written, before the switch: the kiosk runs what it ran."""
    rolled_forward(root)
    make_release(root, "c")
    releases = root / "opt/exhibit-releases"
    plan = journal.Journal(
        what="update",
        prefix=PREFIX,
        release="c",
        previous="b",
        owed=list(journal.STEPS),
        finish=["x"],
        before=("b", "a"),
    )
    journal.write(releases, plan)
    assert owed(root) == []
    runner, lines = Runner(), []
    kiosk(root, runner, lines).update(f"{RELEASES}/c")
    assert lines[0] == (
        f"note: {RELEASES}/{journal.JOURNAL}: the update it records owes nothing now: removed"
    )
    assert any("check-config" in c for c in runner.commands)  # the whole update, checks first
    # a switch half done (previous switched, PREFIX not yet) owes the rest of it
    journal.write(
        releases,
        journal.Journal(**{**plan.__dict__, "release": "b", "previous": "a", "before": ("c", "b")}),
    )
    (releases / "previous").unlink()
    (releases / "previous").symlink_to("c")
    assert [line.split(";")[0] for line in owed(root)[1:]] == [
        f"owed: {PREFIX} -> {RELEASES}/b and {RELEASES}/previous -> a, which x switches",
        "owed: b's `exhibit install` (units, udev rules) has not run since the switch",
        "owed: exhibit.service has not been restarted into b",
    ]


@pytest.mark.parametrize(
    "text, why",
    [
        ("{not json", "not valid JSON (JSONDecodeError)"),
        ('{"what": "upgrade"}', "what: neither update nor rollback"),
        ("[]", "not a JSON object"),
    ],
)
def test_a_journal_that_is_not_one_is_named_in_one_line(root, capsys, monkeypatch, text, why):
    rolled_forward(root)
    path = root / "opt/exhibit-releases" / journal.JOURNAL
    path.write_text(text)
    make_release(root, "c")
    runner = Runner()
    with pytest.raises(ExhibitError) as info:
        kiosk(root, runner).update(f"{RELEASES}/c")
    shown = f"{RELEASES}/{journal.JOURNAL}"
    assert str(info.value) == (
        f"{shown}: {why}: an earlier update or rollback stopped and its journal cannot be "
        f"read; nothing was changed: check the links by hand (ls -l {PREFIX} {RELEASES}), then "
        f"remove it (rm {shown})"
    )
    assert runner.commands == []
    assert owed(root) == [
        f"{path}: {why}: an update or rollback stopped and its journal cannot be read; check "
        f"the links by hand (ls -l {root / 'opt/exhibit'} {root / 'opt/exhibit-releases'}), "
        f"then: rm {path}"
    ]
    monkeypatch.setattr(os, "geteuid", lambda: 0)
    monkeypatch.setattr(rollback, "Releases", lambda prefix: kiosk(root, Runner()))
    assert main(["rollback"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"exhibit rollback: error: {shown}: {why}")


@pytest.mark.parametrize(
    "script, why",
    [
        (None, "/opt/exhibit-releases/new/.venv/bin/exhibit: Exec format error"),
        (b"#!/bin/sh\necho garbage\n", "printed 'garbage', not 'exhibit 0.2.0'"),
        (b"#!/bin/sh\necho 'exhibit 0.1.9'\n", "printed 'exhibit 0.1.9', not 'exhibit 0.2.0'"),
        (b"#!/bin/sh\nexit 0\n", "printed nothing, not 'exhibit 0.2.0'"),
        (
            b"#!/bin/sh\necho \"ModuleNotFoundError: No module named 'pydantic'\" >&2; exit 1\n",
            "--version: ModuleNotFoundError: No module named 'pydantic'",
        ),
    ],
)
def test_a_release_that_does_not_print_its_version_is_not_switched_to(root, script, why):
    """Before: a 0-byte `exhibit`, or one that printed anything and exited 0, was switched in."""
    release = make_release(root, "new")
    (release / ".venv/bin/exhibit").write_bytes(script or b"")
    runner = Runner()
    with pytest.raises(ExhibitError) as info:
        kiosk(root, runner).update(f"{RELEASES}/new")
    message = str(info.value)
    assert message.startswith(f"{RELEASES}/new does not run: ") and message.endswith(
        "; nothing was switched"
    )
    assert why in message
    assert runner.commands == []  # not even check-config
    nothing_changed(root)


def test_pruning_counts_only_releases_that_run_and_leaves_one_being_made(root):
    """Before: a half-made release (pip killed filling its venv) was kept as one of --keep 3,
    and two working releases were deleted."""
    import fcntl

    k = kiosk(root, Runner())
    for i, name in enumerate(["r1", "r2", "r3"]):
        make_release(root, name)
        os.utime(root / "opt/exhibit-releases" / name, (2e9 + i, 2e9 + i))
        k.update(f"{RELEASES}/{name}")
    half = {}
    for i, name in enumerate(["old-bootstrap", "killed", "building"]):
        half[name] = make_release(root, name)
        (half[name] / ".venv/bin/exhibit").unlink()  # pip was filling the venv
        if name != "old-bootstrap":
            (half[name] / _release_checks.BUILDING).write_text("")
        os.utime(half[name], (2e9 + 10 + i, 2e9 + 10 + i))  # newer than every release
    make_release(root, "r4")
    os.utime(root / "opt/exhibit-releases/r4", (2e9 + 20, 2e9 + 20))
    held = os.open(half["building"] / _release_checks.BUILDING, os.O_RDONLY)
    try:
        fcntl.flock(held, fcntl.LOCK_EX)  # ./bootstrap.sh update is making it now
        lines = []
        kiosk(root, Runner(), lines).update(f"{RELEASES}/r4", keep=3)
    finally:
        os.close(held)
    # r4 and r3 (current, previous), r2 the newest other one that runs; r1 beyond --keep
    assert listing(root) == ["building", "old-bootstrap", "previous", "r2", "r3", "r4"]
    assert (
        f"removing {RELEASES}/killed, which a killed ./bootstrap.sh update left half-made" in lines
    )
    assert (
        f"note: {RELEASES}/old-bootstrap does not run ({RELEASES}/old-bootstrap/.venv/bin/exhibit: "
        "No such file or directory): not counted as a release; left there"
    ) in lines
    assert f"removing the old release {RELEASES}/r1" in lines
    assert not any("building" in line for line in lines)


def test_the_first_update_makes_the_moved_checkouts_venv_its_own(root):
    """Before: the checkout's scripts and editable install named /opt/exhibit, so once that was
    another release, the checkout's `exhibit` (previous/.venv/bin/exhibit, the way back from a
    dead release) ran that release's Python and code, and its ModuleNotFoundError."""
    venv = root / "opt/exhibit/.venv"
    (venv / "bin/pip").write_text("#!/opt/exhibit/.venv/bin/python\nimport pip\n")
    (venv / "bin/pip").chmod(0o755)
    (venv / "bin/activate").write_text('VIRTUAL_ENV="/opt/exhibit/.venv"\n')
    site = venv / "lib/python3.11/site-packages"
    site.mkdir(parents=True)
    finder = site / "__editable___exhibit_0_1_0_finder.py"
    finder.write_text(
        "MAPPING: dict[str, str] = {'exhibit': '/opt/exhibit/exhibit'}\n"
        "OTHER = '/opt/exhibit-releases/x'\n"
    )
    (site / "__editable__.exhibit-0.1.0.pth").write_text("/opt/exhibit\n")
    make_release(root, "new")
    kiosk(root, Runner()).update(f"{RELEASES}/new")
    moved = f"{RELEASES}/{kiosk(root, Runner()).previous()}"
    venv = root / moved.lstrip("/") / ".venv"
    site = venv / "lib/python3.11/site-packages"
    assert (venv / "bin/pip").read_text() == f"#!{moved}/.venv/bin/python\nimport pip\n"
    assert os.access(venv / "bin/pip", os.X_OK)  # its mode kept
    assert (venv / "bin/activate").read_text() == 'VIRTUAL_ENV="/opt/exhibit/.venv"\n'
    assert (site / finder.name).read_text() == (
        f"MAPPING: dict[str, str] = {{'exhibit': '{moved}/exhibit'}}\n"
        "OTHER = '/opt/exhibit-releases/x'\n"
    )
    assert (site / "__editable__.exhibit-0.1.0.pth").read_text() == f"{moved}\n"


def test_a_checkout_moved_by_an_older_update_gets_its_own_venv_at_the_next_switch(root):
    """A kiosk whose first update ran an older version: its moved checkout still names PREFIX.
    The next switch away from it (to a release here) fixes it before it becomes previous."""
    make_release(root, "a")
    old = root / "opt/exhibit-releases/0.1.0-checkout-old"
    os.rename(root / "opt/exhibit", old)
    (root / "opt/exhibit").symlink_to("exhibit-releases/0.1.0-checkout-old")
    (old / ".venv/bin/exhibit").write_text(
        '#!/opt/exhibit/.venv/bin/python\nprint("exhibit 0.1.0")\n'
    )
    kiosk(root, Runner()).update(f"{RELEASES}/a")
    assert (
        (old / ".venv/bin/exhibit")
        .read_text()
        .startswith(f"#!{RELEASES}/0.1.0-checkout-old/.venv/bin/python\n")
    )


def test_bootstrap_holds_the_building_file_while_it_makes_a_release():
    text = (inst.SOURCE_DIR.parent / "bootstrap.sh").read_text()
    body = text[text.index("update_kiosk() {") : text.index("\n}\n", text.index("update_kiosk"))]
    assert f'"$release/{_release_checks.BUILDING}"' in body and "flock -n" in body


def test_deployment_md_names_the_journal_and_the_way_back_from_a_dead_release():
    text = " ".join((inst.SOURCE_DIR.parent / "docs/DEPLOYMENT.md").read_text().split())
    assert f"`/opt/exhibit-releases/{journal.JOURNAL}`" in text
    assert "/opt/exhibit-releases/previous/.venv/bin/exhibit rollback" in text
    assert f"`{_release_checks.BUILDING}`" in text


def test_status_reports_what_a_stopped_update_owes(root, tmp_path, capsys):
    """`exhibit status` names the owed steps with their commands: a warning (exit 6) beside a
    kiosk that draws, and a second line beside one that does not run (no health file)."""
    from exhibit.cli import main
    from exhibit.operations.health import write_health

    health = tmp_path / "health.json"
    prefix = str(root / "opt/exhibit")
    write_health(health, {"time": time.time(), "pid": os.getpid(), "fps": 30.0, "frames": 9})
    capsys.readouterr()
    assert main(["status", "--file", str(health), "--prefix", prefix]) == 0
    rolled_forward(root)
    make_release(root, "c")
    interrupted(root, lambda k: k.update(f"{RELEASES}/c"), "try-restart")
    capsys.readouterr()
    assert main(["status", "--file", str(health), "--prefix", prefix]) == 6
    err = capsys.readouterr().err
    assert "exhibit status: UPDATE UNFINISHED: an update of /opt/exhibit to c stopped" in err
    assert "by hand: systemctl try-restart exhibit.service" in err
    assert main(["status", "--file", str(tmp_path / "none.json"), "--prefix", prefix]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("exhibit status: MISSING:")
    assert err[1].startswith("exhibit status: UPDATE UNFINISHED: an update of /opt/exhibit")
    assert main(["status", "--file", str(health), "--prefix", prefix, "--json"]) == 6
    assert json.loads(capsys.readouterr().out)["update_owed"][0].startswith("an update of")
