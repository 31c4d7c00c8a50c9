"""Updating a deployed kiosk (`exhibit update`, `exhibit rollback`; docs/DEPLOYMENT.md, 8) in a
folder standing for /: releases side by side, PREFIX a link switched in one rename, the site
configuration in /etc/exhibit untouched, the mesh cache built as the service's user before the
restart, and one command back. No real systemctl or runuser: the commands are recorded."""

from __future__ import annotations

import os
import subprocess

import pytest

from exhibit.cli import main
from exhibit.commands import install as inst
from exhibit.commands.update import LOCK, Kiosk
from exhibit.errors import ExhibitError
from tests.deploy.unitfile import environment, units

PREFIX = "/opt/exhibit"
RELEASES = "/opt/exhibit-releases"
SITE = "[display]\nmonitor = 1\n"


class Runner:
    """Records each command; ``fail`` maps a word in the command to (exit code, stderr)."""

    def __init__(self, fail: dict[str, tuple[int, str]] | None = None):
        self.commands: list[list[str]] = []
        self.fail = fail or {}

    def __call__(self, command, timeout=None):
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
    exe.write_text("#!/bin/sh\n")
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
    return Kiosk(
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
    assert runner.commands[cache - 1][:2] == ["install", "-d"]  # the cache folder, for the user
    assert runner.commands[install][0] == f"{PREFIX}/.venv/bin/exhibit"
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
