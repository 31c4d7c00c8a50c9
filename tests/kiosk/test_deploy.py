"""Deployment files: the units `exhibit install` writes pass `systemd-analyze verify` and score
at most 2.5 in `systemd-analyze security`; the udev rules parse and cover the shipped devices; the
kernel settings turn SysRq off; the install command's modes, errors and the order of its steps.
(tests/deploy runs cage and the kiosk under the units' sandbox.)"""

from __future__ import annotations

import os
import re
import shutil
import stat
import subprocess
import tempfile
import threading
from pathlib import Path

import pytest

from exhibit.commands import install as inst
from exhibit.errors import ExhibitError
from exhibit.operations import health
from tests.deploy.unitfile import units

REPO = Path(__file__).resolve().parents[2]
SYSTEMD = REPO / "systemd"


def unavailable(reason: str):
    """Skip, except under CI=true, where these checks must really run."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: these tests must run)")
    pytest.skip(reason)


@pytest.fixture
def staged(tmp_path, capsys):
    """`exhibit install --root tmp --prefix /srv/museum/exhibit`, plus stub executables for what
    the units run and the host's own units (sysinit.target ...), as systemd-analyze needs."""
    from exhibit.cli import main

    root = tmp_path / "root"
    root.mkdir()
    assert main(["install", "--root", str(root), "--prefix", "/srv/museum/exhibit"]) == 0
    capsys.readouterr()
    for exe in (
        "srv/museum/exhibit/.venv/bin/exhibit",
        "usr/bin/cage",
        "usr/bin/env",
        "bin/sh",
        "bin/sleep",
    ):
        path = root / exe
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("#!/bin/sh\n")
        path.chmod(0o755)
    return root


def analyze(root: Path, *args: str) -> subprocess.CompletedProcess:
    if shutil.which("systemd-analyze") is None:
        unavailable("systemd-analyze is not installed (Debian: apt-get install systemd)")
    host_units = next(
        (
            p
            for p in (Path("/usr/lib/systemd/system"), Path("/lib/systemd/system"))
            if (p / "sysinit.target").exists()
        ),
        None,
    )
    if host_units is None:
        unavailable("no systemd unit directory with sysinit.target on this machine")
    (root / "usr/lib/systemd").mkdir(parents=True, exist_ok=True)
    link = root / "usr/lib/systemd/system"
    if not link.exists():
        link.symlink_to(host_units)
    return subprocess.run(
        ["systemd-analyze", *args, f"--root={root}"], capture_output=True, text=True, timeout=60
    )


def verify(root: Path, *names: str) -> list[str]:
    """Every complaint systemd-analyze verify has about our units (it exits 0 on mere warnings
    such as an unknown key, so the lines are what count)."""
    result = analyze(root, "verify", "--man=no", "--generators=no", *names)
    lines = [line for line in (result.stdout + result.stderr).splitlines() if "exhibit" in line]
    if result.returncode != 0 and not lines:
        lines = [f"exit {result.returncode}: {result.stderr.strip()}"]
    return lines


# ---------------------------------------------------------------------- the units


def test_units_pass_systemd_analyze_verify(staged):
    assert (
        verify(staged, *[name for name in inst.FILES if name.endswith((".service", ".timer"))])
        == []
    )


def test_verify_does_catch_a_broken_unit(staged):
    """The check above can fail: the same verification flags a typo and a missing program."""
    unit = staged / "etc/systemd/system/exhibit.service"
    unit.write_text(unit.read_text().replace("WatchdogSec=10", "WatchdogSecs=10"))
    problems = verify(staged, "exhibit.service")
    assert any("Unknown key 'WatchdogSecs'" in line for line in problems)
    (staged / "srv/museum/exhibit/.venv/bin/exhibit").unlink()
    assert any(
        "/srv/museum/exhibit/.venv/bin/exhibit is not executable" in line
        for line in verify(staged, "exhibit.service")
    )


#: The most `systemd-analyze security` may score any of our services (0 best, 10 worst). Before
#: issue 11: exhibit.service 2.8, exhibit-kiosk.service 5.5; now 1.0 (0.9 before narration's
#: sched_setscheduler) and 1.3.
MAX_EXPOSURE = 2.5
SERVICES = [name for name in inst.FILES if name.endswith(".service")]


def exposure(root: Path, name: str) -> float:
    result = analyze(root, "security", "--offline=yes", "--no-pager", name)
    match = re.search(rf"Overall exposure level for {re.escape(name)}: (\d+\.\d+)", result.stdout)
    assert match, result.stdout[-600:] + result.stderr[-600:]
    return float(match.group(1))


@pytest.mark.parametrize("name", SERVICES)
def test_unit_exposure_is_at_most_2_5(staged, name):
    """systemd's own hardening score for each service as installed; the settings left out are
    explained in the unit files and in docs/DEPLOYMENT.md ("Hardening")."""
    score = exposure(staged, name)
    assert score <= MAX_EXPOSURE, f"{name}: exposure {score} > {MAX_EXPOSURE}"


def test_the_exposure_check_can_fail(staged):
    """Without its sandbox the app scores far above the limit: the check above measures."""
    unit = staged / "etc/systemd/system/exhibit.service"
    kept = [
        line
        for line in unit.read_text().splitlines()
        if not line.startswith(("SystemCallFilter=", "PrivateUsers=", "CapabilityBounding"))
    ]
    unit.write_text("\n".join(kept) + "\n")
    assert exposure(staged, "exhibit.service") > MAX_EXPOSURE


def test_hardening_both_units_share(staged):
    for name in inst.UNITS:
        service = units(staged / "etc/systemd/system" / name)["Service"]
        assert service["CapabilityBoundingSet"] == [""], name
        assert service["NoNewPrivileges"] == ["yes"], name
        assert service["SystemCallFilter"][:2] == ["@system-service", "~@privileged @resources"]
        assert service["SystemCallErrorNumber"] == ["EPERM"], name
        assert service["SystemCallArchitectures"] == ["native"], name
        assert service["ProtectSystem"] == ["strict"], name
        # llvmpipe compiles shaders to machine code (tests/deploy/test_sandbox.py)
        assert "MemoryDenyWriteExecute" not in service, name
        # udev's hotplug announcements do not cross network namespaces
        assert "PrivateNetwork" not in service, name
    app = units(staged / "etc/systemd/system/exhibit.service")["Service"]
    assert app["PrivateUsers"] == ["yes"]
    # The one call given back, for narration's audio thread; real-time stays refused.
    assert app["SystemCallFilter"][2:] == ["sched_setscheduler"]
    assert app["RestrictRealtime"] == ["yes"]
    kiosk = units(staged / "etc/systemd/system/exhibit-kiosk.service")["Service"]
    assert kiosk["SystemCallFilter"][2:] == []


def test_sysrq_is_turned_off(staged):
    text = (staged / "etc/sysctl.d/90-exhibit.conf").read_text()
    settings = dict(
        line.replace(" ", "").split("=", 1)
        for line in text.splitlines()
        if line.strip() and not line.startswith(("#", ";"))
    )
    assert settings == {"kernel.sysrq": "0"}


def test_app_unit_settings(staged):
    unit = units(staged / "etc/systemd/system/exhibit.service")
    service = unit["Service"]
    expected = {
        "Type": ["notify"],
        "NotifyAccess": ["main"],
        "WatchdogSec": ["10"],
        "Restart": ["always"],
        "RestartSec": ["2"],
        "User": ["exhibit"],
        "NoNewPrivileges": ["yes"],
        "ProtectSystem": ["strict"],
        "ProtectHome": ["yes"],
        "PrivateTmp": ["yes"],
        "IPAddressDeny": ["any"],
        "DevicePolicy": ["closed"],
        "StateDirectory": ["exhibit"],
        "CacheDirectory": ["exhibit"],
        "ExecStart": ["/srv/museum/exhibit/.venv/bin/exhibit run"],
    }
    for key, value in expected.items():
        assert service.get(key) == value, key
    families = service["RestrictAddressFamilies"][0].split()
    assert "AF_UNIX" in families and not {"AF_INET", "AF_INET6", "AF_PACKET"} & set(families)
    allowed = {v.split()[0] for v in service["DeviceAllow"]}
    assert {"char-drm", "char-hidraw", "char-ttyUSB", "char-ttyACM"} <= allowed
    assert unit["Unit"]["StartLimitIntervalSec"] == ["0"]  # never give up restarting
    env = dict(pair.split("=", 1) for line in service["Environment"] for pair in line.split())
    # The health file lands where `exhibit status` looks for the service's.
    assert Path(env["EXHIBIT_STATE_DIR"]) == health.SERVICE_STATE_DIR
    assert env["EXHIBIT_STATE_DIR"] == "/var/lib/" + service["StateDirectory"][0]
    assert env["EXHIBIT_CACHE_DIR"].startswith("/var/cache/" + service["CacheDirectory"][0])
    assert "/opt/exhibit" not in (staged / "etc/systemd/system/exhibit.service").read_text()


def test_app_and_display_meet_at_the_same_wayland_socket(staged):
    app = units(staged / "etc/systemd/system/exhibit.service")
    kiosk = units(staged / "etc/systemd/system/exhibit-kiosk.service")
    env = dict(
        pair.split("=", 1) for line in app["Service"]["Environment"] for pair in line.split()
    )
    runtime = "/run/" + kiosk["Service"]["RuntimeDirectory"][0]
    assert env["XDG_RUNTIME_DIR"] == runtime
    assert f"XDG_RUNTIME_DIR={runtime} /usr/bin/cage" in kiosk["Service"]["ExecStart"][0]
    assert kiosk["Service"]["User"] == app["Service"]["User"]
    assert "exhibit-kiosk.service" in app["Unit"]["BindsTo"]
    assert "exhibit.service" in kiosk["Unit"]["Wants"]
    assert kiosk["Service"]["PAMName"] == ["login"]
    assert kiosk["Service"]["TTYPath"] == ["/dev/tty1"]


def _wait_script(unit_file: Path) -> str:
    """The ExecStartPre shell snippet as sh would receive it ($$ is systemd's escape for $)."""
    line = units(unit_file)["Service"]["ExecStartPre"][0]
    assert line.startswith("/bin/sh -c '") and line.endswith("'")
    return line[len("/bin/sh -c '") : -1].replace("$$", "$")


def test_socket_wait_returns_as_soon_as_the_socket_exists(staged):
    import socket

    script = _wait_script(staged / "etc/systemd/system/exhibit.service")
    with tempfile.TemporaryDirectory(prefix="exw-", dir="/tmp") as runtime:
        env = {"PATH": "/usr/bin:/bin", "XDG_RUNTIME_DIR": runtime, "WAYLAND_DISPLAY": "wayland-0"}
        server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            # No socket yet: still waiting after 0.5 s.
            with pytest.raises(subprocess.TimeoutExpired):
                subprocess.run(["sh", "-c", script], env=env, timeout=0.5)
            server.bind(f"{runtime}/wayland-0")
            result = subprocess.run(
                ["sh", "-c", script], env=env, timeout=5, capture_output=True, text=True
            )
        finally:
            server.close()
    assert result.returncode == 0 and result.stderr == ""


def test_modules_loaded_at_boot_cover_the_serial_device_classes(staged):
    modules = [
        line
        for line in (staged / "etc/modules-load.d/exhibit.conf").read_text().splitlines()
        if line and not line.startswith("#")
    ]
    assert modules == ["usbserial", "cdc_acm"]


# ---------------------------------------------------------------------- udev rules

MATCH_KEYS = {
    "ACTION",
    "SUBSYSTEM",
    "SUBSYSTEMS",
    "KERNEL",
    "KERNELS",
    "DRIVER",
    "DRIVERS",
    "ATTR",
    "ATTRS",
    "ENV",
    "TAG",
    "TAGS",
    "DEVPATH",
    "PROGRAM",
    "RESULT",
}
ASSIGN_KEYS = {
    "GROUP",
    "OWNER",
    "MODE",
    "SYMLINK",
    "ENV",
    "TAG",
    "RUN",
    "NAME",
    "LABEL",
    "GOTO",
    "OPTIONS",
}
PAIR = re.compile(r'\s*([A-Z_]+)(?:\{([A-Za-z0-9_]+)\})?\s*(==|!=|\+=|-=|:=|=)\s*"([^"]*)"\s*(,|$)')


def parse_rule(line: str) -> list[tuple[str, str | None, str, str]]:
    """(key, attribute, operator, value) for each comma-separated pair; ValueError otherwise."""
    pairs, pos = [], 0
    while pos < len(line):
        m = PAIR.match(line, pos)
        if not m:
            raise ValueError(f"cannot parse at column {pos + 1}: {line[pos : pos + 30]!r}")
        key, attr, op, value, _ = m.groups()
        if op in ("==", "!=") and key not in MATCH_KEYS:
            raise ValueError(f"{key} is not a match key")
        if op not in ("==", "!=") and key not in ASSIGN_KEYS:
            raise ValueError(f"{key} cannot be assigned")
        if (key in ("ATTR", "ATTRS", "ENV")) != (attr is not None):
            raise ValueError(f"{key}{{{attr}}}: attribute braces are wrong")
        pairs.append((key, attr, op, value))
        pos = m.end()
    return pairs


def rules() -> list[list[tuple[str, str | None, str, str]]]:
    text = (SYSTEMD / "99-exhibit.rules").read_text()
    return [
        parse_rule(line)
        for line in text.splitlines()
        if line.strip() and not line.lstrip().startswith("#")
    ]


def test_every_udev_rule_parses_into_known_keys():
    parsed = rules()
    assert len(parsed) >= 5
    for rule in parsed:
        keys = {(k, a): v for k, a, _op, v in rule}
        assert ("SUBSYSTEM", None) in keys
        if ("GROUP", None) in keys:
            assert keys[("GROUP", None)] == inst.USER and keys[("MODE", None)] == "0660"
        for (_key, attr), value in keys.items():
            if attr in ("idVendor", "idProduct"):
                assert re.fullmatch(r"[0-9a-f]{4}(\|[0-9a-f]{4})*", value), value


def test_the_parser_rejects_what_udev_would():
    for bad in (
        'SUBSYSTEM="tty"',
        'GROUP=="exhibit"',
        'SUBSYSTEM=="tty" GROUP="x"',
        'ATTRS=="1a86"',
        "SUBSYSTEM==tty",
        'FOO=="x"',
    ):
        with pytest.raises(ValueError):
            parse_rule(bad)


def _by_id() -> dict[tuple[str, str, str], dict]:
    table = {}
    for rule in rules():
        d = {(k if a is None else f"{k}{{{a}}}"): v for k, a, _op, v in rule}
        vendor = d.get("ATTRS{idVendor}") or d.get("ATTR{idVendor}")
        for product in (d.get("ATTRS{idProduct}") or d.get("ATTR{idProduct}") or "*").split("|"):
            table[(d["SUBSYSTEM"], vendor, product)] = d
    return table


def test_controller_and_knob_box_rules():
    table = _by_id()
    for vid_pid in (("1a86", "7523"), ("0403", "6001"), ("2341", "0043")):
        rule = table[("tty", *vid_pid)]
        assert rule["SYMLINK"] == "exhibit-controller"
        assert rule["ENV{ID_MM_DEVICE_IGNORE}"] == "1" and rule["GROUP"] == "exhibit"
    knobs = table[("hidraw", "2341", "8037")]
    assert knobs["SYMLINK"] == "exhibit-knobs" and knobs["MODE"] == "0660"


def test_shipped_device_configs_are_covered_by_the_rules():
    """The default device config opens /dev/exhibit-controller, and every shipped layout's
    VID:PID can be opened by the service's group."""
    import tomllib

    default = tomllib.loads((REPO / "configs/devices/default.toml").read_text())
    assert default["devices"]["controller"]["url"].startswith("serial:///dev/exhibit-controller")
    table = _by_id()
    for layout_file in (REPO / "configs/devices").glob("*.toml"):
        layout = tomllib.loads(layout_file.read_text()).get("layout")
        if not layout:
            continue
        subsystem = "hidraw" if layout.get("backend", "hidraw") == "hidraw" else "usb"
        for vid_pid in layout["match"]:
            vid, pid = vid_pid.lower().split(":")
            rule = table.get((subsystem, vid, pid)) or table.get((subsystem, vid, "*"))
            assert rule and rule["GROUP"] == "exhibit", f"{layout_file.name}: {vid_pid}"


# ---------------------------------------------------------------------- exhibit install


def test_install_stages_files_with_the_prefix_and_is_idempotent(tmp_path, capsys):
    from exhibit.cli import main

    assert main(["install", "--root", str(tmp_path), "--prefix", "/srv/x/../exhibit"]) == 0
    out = capsys.readouterr().out
    for dest in inst.FILES.values():
        assert (tmp_path / dest).is_file() and f"wrote {tmp_path / dest} (new)" in out
    assert (
        "ExecStart=/srv/exhibit/.venv/bin/exhibit run"
        in (tmp_path / "etc/systemd/system/exhibit.service").read_text()
    )
    assert "remaining steps (on the kiosk, as root):" in out
    assert "  useradd --system --user-group --home-dir /var/lib/exhibit" in out
    assert "  systemctl enable exhibit.service exhibit-kiosk.service exhibit-metrics.timer\n" in out
    assert main(["install", "--root", str(tmp_path), "--prefix", "/srv/exhibit"]) == 0
    assert capsys.readouterr().out.count("unchanged: ") == len(inst.FILES)


def test_dry_run_writes_nothing(tmp_path, capsys):
    from exhibit.cli import main

    assert main(["install", "--root", str(tmp_path), "--dry-run"]) == 0
    assert list(tmp_path.iterdir()) == []
    assert "would write" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args, message",
    [
        (["--prefix", "opt/exhibit"], "must be an absolute path"),
        (["--prefix", "/home/museum/exhibit"], "cannot use /home"),
        (["--prefix", "/tmp/exhibit"], "cannot use /tmp"),
        (["--prefix", "/opt/my exhibit"], "use only letters"),
        (["--prefix", "/"], "give the folder of the checkout"),
        (["--root", "/nonexistent/stage"], "--root /nonexistent/stage: no such folder"),
        (["--root", ""], "--root '': give a folder"),
    ],
)
def test_install_argument_errors_are_one_line(cli, args, message):
    result = cli("install", *args)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and message in result.stderr
    assert result.stderr.startswith("exhibit install: error: ")


def test_installing_into_slash_needs_root(monkeypatch, capsys):
    from exhibit.cli import main

    monkeypatch.setattr(inst.os, "geteuid", lambda: 1000)
    assert main(["install"]) == 2
    assert "installing into / needs root" in capsys.readouterr().err


def test_install_never_writes_through_a_planted_temporary_name(tmp_path, monkeypatch, capsys):
    """A symlink at the old fixed temporary names, and at the random one with its random part
    guessed (the first try for each file), is left alone, and so are its target and mode."""
    from exhibit.cli import main
    from exhibit.schema import files

    victim = tmp_path / "shadow"
    victim.write_text("root:secret\n")
    victim.chmod(0o600)
    root = tmp_path / "root"
    guessed = "0" * 12
    planted = []
    for dest in inst.FILES.values():
        path = root / dest
        path.parent.mkdir(parents=True, exist_ok=True)
        for name in (
            f".{path.name}.exhibit-install",
            f".{path.name}.{'0' * 16}.exhibit-install",
            f".{path.name}.{guessed}.tmp",
        ):
            if not (path.parent / name).is_symlink():
                (path.parent / name).symlink_to(victim)
                planted.append(path.parent / name)
    calls = iter(range(10**6))
    real = files.secrets.token_hex
    monkeypatch.setattr(
        files.secrets, "token_hex", lambda n: guessed if next(calls) % 2 == 0 else real(n)
    )
    old_umask = os.umask(0o077)
    try:
        assert main(["install", "--root", str(root)]) == 0
    finally:
        os.umask(old_umask)
    assert victim.read_text() == "root:secret\n" and (victim.stat().st_mode & 0o777) == 0o600
    assert all(p.is_symlink() and p.resolve() == victim for p in planted)
    for dest in inst.FILES.values():
        path = root / dest
        assert path.is_file() and not path.is_symlink()
        assert stat.S_IMODE(path.stat().st_mode) == 0o644  # despite the umask
        assert sorted(p.name for p in path.parent.iterdir() if p.name.startswith(".")) == sorted(
            p.name for p in planted if p.parent == path.parent
        )
    capsys.readouterr()


@pytest.mark.parametrize("linked", ["etc", "etc/systemd/system", "etc/udev"])
def test_install_never_writes_through_a_symlinked_folder_below_the_root(tmp_path, capsys, linked):
    from exhibit.cli import main

    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    link = root / linked
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(outside)
    for argv in (["install", "--root", str(root)], ["install", "--root", str(root), "--dry-run"]):
        assert main(argv) == 2
        out, err = capsys.readouterr()
        assert "wrote" not in out and "internal error" not in err
        assert err.count("\n") == 1 and f"{link} is a symbolic link" in err
    assert list(outside.rglob("*")) == []
    assert [p for p in root.rglob("*") if p.is_file()] == []


def test_install_replaces_a_symlink_to_a_file_without_following_it(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    root = tmp_path / "root"
    service = root / inst.FILES["exhibit.service"]
    service.parent.mkdir(parents=True)
    service.symlink_to(victim)
    inst.install(root, "/opt/exhibit", out=lambda line: None)
    assert victim.read_text() == "keep"
    assert service.is_file() and not service.is_symlink()


@pytest.mark.parametrize("kind", ["fifo", "folder", "link to a fifo", "masked"])
def test_install_refuses_what_is_not_a_file_at_a_target_and_writes_nothing(tmp_path, kind, capsys):
    """Checked before any write, without hanging on a FIFO: one line naming it, no 'wrote'."""
    from exhibit.cli import main

    root = tmp_path / "root"
    rules = root / inst.FILES["99-exhibit.rules"]
    rules.parent.mkdir(parents=True)
    if kind == "fifo":
        os.mkfifo(rules)
    elif kind == "folder":  # the last file: the old code said "wrote" for six, then failed
        rules = root / inst.FILES["exhibit-metrics.timer"]
        rules.mkdir(parents=True)
    elif kind == "link to a fifo":
        os.mkfifo(tmp_path / "fifo")
        rules.symlink_to(tmp_path / "fifo")
    else:  # systemctl mask: a unit linked to /dev/null
        rules = root / inst.FILES["exhibit-metrics.timer"]
        rules.parent.mkdir(parents=True)
        rules.symlink_to("/dev/null")
    done = threading.Thread(target=main, args=(["install", "--root", str(root)],), daemon=True)
    done.start()
    done.join(20)
    assert not done.is_alive(), "install hung"
    out, err = capsys.readouterr()
    assert "wrote" not in out and "internal error" not in err
    assert err.count("\n") == 1 and str(rules) in err and "nothing written" in err
    assert [p for p in root.rglob("*") if p.is_file() and not p.is_symlink()] == []


def test_a_failed_write_leaves_no_temporary_file(tmp_path, monkeypatch):
    def fail(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(inst.os, "replace", fail)
    with pytest.raises(ExhibitError, match="No space left on device"):
        inst.install(tmp_path, "/opt/exhibit", out=lambda line: None)
    assert [p for p in tmp_path.rglob("*") if p.is_file()] == []


class Runner:
    def __init__(self, fail: str | None = None):
        self.commands, self.fail = [], fail

    def __call__(self, command):
        self.commands.append(command)
        failed = self.fail is not None and command[0] == self.fail
        return subprocess.CompletedProcess(
            command,
            1 if failed else 0,
            "",
            "modprobe: FATAL: Module usbserial not found\n" if failed else "",
        )


@pytest.fixture
def prefix(tmp_path):
    exe = tmp_path / "prefix/.venv/bin/exhibit"
    exe.parent.mkdir(parents=True)
    exe.write_text("#!/bin/sh\n")
    exe.chmod(0o755)
    return str(tmp_path / "prefix")


def test_perform_runs_the_steps_in_order(tmp_path, prefix):
    root = tmp_path / "root"
    root.mkdir()
    runner, lines = Runner(), []
    assert (
        inst.install(
            root,
            prefix,
            perform=True,
            out=lines.append,
            runner=runner,
            user_exists=lambda name: False,
            group_exists=lambda name: True,
        )
        == 0
    )
    assert [c[:2] for c in runner.commands] == [
        ["useradd", "--system"],
        ["modprobe", "-a"],
        ["sysctl", "--system"],
        ["udevadm", "control"],
        ["udevadm", "trigger"],
        ["systemctl", "daemon-reload"],
        ["systemctl", "enable"],
        ["install", "-d"],  # the state folder
        ["chown", "-R"],  # ... the user's, whatever root made there before it existed
        ["runuser", "-u"],  # the speech cache's key in it
        ["install", "-d"],
        ["chown", "-R"],
        ["runuser", "-u"],
    ]
    assert runner.commands[0][-1] == "exhibit"
    # last: the mesh cache, built by the installed exhibit as the service's user
    assert runner.commands[-1][-2:] == [f"{prefix}/.venv/bin/exhibit", "prepare"]
    assert all((root / dest).is_file() for dest in inst.FILES.values())
    # The user exists the second time: no useradd.
    runner = Runner()
    inst.install(
        root,
        prefix,
        perform=True,
        out=lines.append,
        runner=runner,
        user_exists=lambda name: True,
        group_exists=lambda name: True,
    )
    assert runner.commands[0][0] == "modprobe"


def test_an_updates_install_builds_no_second_cache_and_no_start_hint(tmp_path, prefix, monkeypatch):
    """`exhibit update` built the cache before the switch and restarts next: the install it
    runs (FOR_UPDATE_ENV, which an older release rolled back to ignores) leaves both out."""
    root = tmp_path / "root"
    root.mkdir()
    monkeypatch.setenv(inst.FOR_UPDATE_ENV, "1")
    runner, lines = Runner(), []
    assert (
        inst.install(
            root,
            prefix,
            perform=True,
            out=lines.append,
            runner=runner,
            user_exists=lambda name: True,
            group_exists=lambda name: True,
        )
        == 0
    )
    assert not any("prepare" in c for c in runner.commands)
    assert runner.commands[-1][:2] == ["systemctl", "enable"]
    assert not any("Start now" in line for line in lines)


def test_perform_stops_at_a_failing_step_and_says_what_is_left(tmp_path, prefix):
    root = tmp_path / "root"
    root.mkdir()
    runner, lines = Runner(fail="modprobe"), []
    with pytest.raises(ExhibitError) as info:
        inst.install(
            root,
            prefix,
            perform=True,
            out=lines.append,
            runner=runner,
            user_exists=lambda name: True,
            group_exists=lambda name: True,
        )
    assert str(info.value) == (
        "modprobe -a usbserial cdc_acm failed: modprobe: FATAL: Module usbserial not found"
    )
    assert len(runner.commands) == 1
    assert "  systemctl daemon-reload" in lines and "  udevadm control --reload" in lines


def test_perform_refuses_without_the_venv(tmp_path):
    with pytest.raises(ExhibitError, match=r"/nowhere/\.venv/bin/exhibit does not exist"):
        inst.install(tmp_path, "/nowhere", perform=True, out=lambda s: None, runner=Runner())
    assert not (tmp_path / "etc").exists()


def test_perform_makes_the_units_missing_groups_first(tmp_path, prefix):
    """A minimal Debian without udev's rules has no `render` group; the unit's
    SupplementaryGroups= names it, so the install makes it (as systemd-sysusers would) before
    the user, instead of stopping a first install halfway (the offline install did)."""
    runner, lines = Runner(), []
    assert (
        inst.install(
            tmp_path,
            prefix,
            perform=True,
            out=lines.append,
            runner=runner,
            user_exists=lambda name: False,
            group_exists=lambda name: name != "render",
        )
        == 0
    )
    assert runner.commands[0] == ["groupadd", "--system", "render"]
    assert runner.commands[1][0] == "useradd"
    assert not any(c[0] == "groupadd" and c[-1] != "render" for c in runner.commands)


@pytest.fixture
def cli(capsys):
    from exhibit.cli import main

    def run(*args):
        code = main(list(args))
        out, err = capsys.readouterr()
        return subprocess.CompletedProcess(args, code, out, err)

    return run


def test_perform_names_a_missing_compositor_or_xwayland(tmp_path, prefix, monkeypatch):
    """Debian's cage 0.1.4 exits with `Cannot find Xwayland binary` when xwayland is missing,
    even for a Wayland client: the installer says so instead of leaving a black screen."""
    monkeypatch.setattr(
        inst,
        "_DISPLAY_PROGRAMS",
        (
            (str(tmp_path / "cage"), "cage", "exhibit-kiosk.service runs it"),
            (str(tmp_path / "Xwayland"), "xwayland", "Debian's cage exits at start without it"),
        ),
    )
    root = tmp_path / "root"
    root.mkdir()
    lines = []
    inst.install(
        root,
        prefix,
        perform=True,
        out=lines.append,
        runner=Runner(),
        user_exists=lambda name: True,
        group_exists=lambda name: True,
    )
    assert (
        f"note: {tmp_path}/Xwayland is missing: apt-get install xwayland (Debian's cage "
        "exits at start without it)" in lines
    )
    assert any(line.startswith(f"note: {tmp_path}/cage is missing") for line in lines)


def test_perform_refuses_a_venv_whose_python_the_service_cannot_reach(tmp_path, prefix):
    """A venv made from a Python under /root (pyenv) works for root and fails for the service
    (203/EXEC): the installer says how to remake it instead."""
    python = Path(prefix) / ".venv/bin/python"
    python.symlink_to("/root/.exhibit-test-pyenv/bin/python3")
    with pytest.raises(
        ExhibitError,
        match=r"is /root/\.exhibit-test-pyenv/bin/python3, which "
        r"the service cannot run .* PYTHON=/usr/bin/python3 ",
    ):
        inst.install(
            tmp_path,
            prefix,
            perform=True,
            out=lambda s: None,
            runner=Runner(),
            group_exists=lambda name: True,
        )
    assert not (tmp_path / "etc").exists()
    python.unlink()
    python.symlink_to("/usr/bin/python3")
    assert (
        inst.install(
            tmp_path,
            prefix,
            perform=True,
            out=lambda s: None,
            runner=Runner(),
            user_exists=lambda name: True,
            group_exists=lambda name: True,
        )
        == 0
    )
