"""A museum day, end to end (slow, serial; CI runs it alone): the exhibit proven as it is
deployed and used, not feature by feature.

On a disposable copy of this Debian 12 root file system with the network cut and no `exhibit`
user (tests/deploy/machine.py), as one day in this order:

1. **Install.** A bundle (`./bootstrap.sh bundle`) at /media/usb/exhibit-bundle; the site files
   a technician writes (/etc/exhibit); then DEPLOYMENT.md's "A new machine from a bundle" lines,
   read from the doc and run as they stand, as root.
2. **Opening.** The units as installed: cage (exhibit-kiosk.service's command line) and the app
   (`/opt/exhibit/.venv/bin/exhibit run`) under the app unit's sandbox (file system, identity,
   seccomp: tests/deploy/unit_mounts.py, sandbox_exec.py), narration to the null device.
3. **Visitors.** A simulated controller (a pty, the real serial protocol): a visitor takes over,
   turns, presses next and listen, walks away; another comes, and leaves while the state disk is
   full. The preparing worker is killed.
4. **The state disk fills and empties**: `exhibit status` says so (exit 5) while the kiosk draws,
   and OK again after.
5. **A technician updates**: `./bootstrap.sh update` killed at a random step after the switch;
   `exhibit status` names what is owed and the command that finishes it, which is run; then
   `exhibit rollback`, twice.
6. **Closing.** The app stopped as systemd stops it.

At the end: /opt/exhibit is a complete, working release and `exhibit status` names it; every
owed step was done; the health file was honest at every step; every visitor session is in the
SQLite log; narration played (the player's tap); nothing of the exhibit user outlives it.

What differs from a museum PC: systemd is not PID 1 (the test starts and restarts the units as
the stand-in systemctl is asked to), cage uses wlroots' headless output, and there is no seat.
"""

from __future__ import annotations

import json
import os
import random
import re
import shlex
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

from tests.deploy.bundles import make_bundle
from tests.deploy.machine import Machine, machine, why_not
from tests.deploy.unit_mounts import confined
from tests.deploy.unitfile import environment, sandbox_options, units, yes
from tests.processes import alive

pytestmark = [pytest.mark.slow, pytest.mark.serial]

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs/DEPLOYMENT.md"
SANDBOX = Path(__file__).with_name("sandbox_exec.py")
#: Where the doc's commands expect the bundle.
USB = "/media/usb/exhibit-bundle"
#: Seconds a visitor's session takes to end after the last touch (the site's idle_timeout_s).
IDLE_S = 5
#: The visitors of the day, on the controller's clock (seconds after the kiosk opens it): the
#: first one at 8 s, the second at 40 s, who leaves while the state disk is full (50-70 s).
VISITORS = """\
wait 8
axes 0.8 0 0 0 0 0
wait 1.5
axes 0 0 0 0 0 0
buttons 2
wait 0.3
buttons
wait 1
buttons 5
wait 0.3
buttons
axes 0 0 0.6 0 0 0
wait 2
axes 0 0 0 0 0 0
wait 28
axes 0 0.7 0 0 0 0
wait 2
axes 0 0 0 0 0 0
wait 100000
"""
#: The visitors' script once the day's two have been: nobody (a restart replays the script).
NOBODY = "wait 100000\n"


def unavailable(reason: str):
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: this test must run)")
    pytest.skip(reason)


def say(text: str) -> None:
    """The day's log: what happened, as the CI log shows it."""
    print(f"[museum day {time.strftime('%H:%M:%S')}] {text}", flush=True)


def doc_block(marker: str) -> list[str]:
    """The command lines of the first ```sh block after ``marker`` in DEPLOYMENT.md, without
    their comments."""
    text = DOC.read_text()
    at = text.index(marker)
    block = re.search(r"```sh\n(.*?)```", text[at:], re.S)
    assert block, f"DEPLOYMENT.md: no sh block after {marker!r}"
    lines = []
    for line in block.group(1).splitlines():
        words = shlex.split(line, comments=True)
        if words:
            lines.append(shlex.join(words))
    return lines


# ------------------------------------------------------------------ the site's files


def write_site(m: Machine) -> None:
    """What the technician writes before the install (DEPLOYMENT.md, step 4): the site config
    with two scenes, one attract timeline, the controller on the visitors' simulated pty, a
    short idle timeout, narration to the null device (no sound card here)."""
    site = m.path("/etc/exhibit")
    (site / "attract").mkdir(parents=True)
    shutil.copy(REPO / "configs/attract/01-hypersphere.toml", site / "attract")
    devices = (REPO / "configs/devices/default.toml").read_text()
    devices = re.sub(
        r'url = "serial://[^"]*"', 'url = "sim://controller?script=/etc/exhibit/visitors"', devices
    )
    devices = re.sub(r'url = "hidraw://[^"]*"', 'url = "keyboard://"', devices)
    (site / "devices.toml").write_text(devices)
    (site / "visitors").write_text(VISITORS)
    (site / "kiosk.toml").write_text(
        '[content]\nscenes = ["hopf", "clifford-torus"]\nstart_scene = "hopf"\n\n'
        f'[devices]\nconfig = "devices.toml"\n\n[attract]\ntimelines = "attract"\n'
        f"idle_timeout_s = {IDLE_S}\n\n"
        '[narration]\nbackend = "null"\n'
    )
    for path in site.rglob("*"):
        path.chmod(0o755 if path.is_dir() else 0o644)


# ------------------------------------------------------------------ systemd's part


class Units:
    """exhibit-kiosk.service and exhibit.service as systemd would run them, from the unit files
    as installed in the machine; the stand-in systemctl's start, restart and stop requests are
    carried out (watch())."""

    def __init__(self, m: Machine, logs: Path):
        self.m, self.logs = m, logs
        self.cage: subprocess.Popen | None = None
        self.app: subprocess.Popen | None = None
        self.starts = 0
        self.seen = 0
        self.lock = threading.Lock()
        self.stop_watching = threading.Event()
        self.watcher: threading.Thread | None = None
        self.files: list = []

    def unit(self, name: str) -> dict[str, list[str]]:
        return units(self.m.path(f"/etc/systemd/system/{name}"))["Service"]

    def ids(self) -> tuple[int, int]:
        for line in self.m.path("/etc/passwd").read_text().splitlines():
            fields = line.split(":")
            if fields[0] == "exhibit":
                return int(fields[2]), int(fields[3])
        raise AssertionError("no exhibit user in the machine")

    def seccomp(self, service: dict, name: str) -> list[str]:
        """sandbox_exec.py's command line inside the machine for ``service``."""
        outside = str(self.m.path("/"))
        options = sandbox_options(service, self.m.path("/var/log/exhibit-day"), name)
        inside = [o.replace(outside, "") for o in options]
        return ["/usr/bin/python3", str(SANDBOX), *inside, "--"]

    def directories(self, uid: int, gid: int) -> None:
        """StateDirectory=, CacheDirectory= and the display's RuntimeDirectory=, as systemd
        makes them at a start: the user's."""
        for inside, mode in (
            ("/var/lib/exhibit", 0o755),
            ("/var/cache/exhibit", 0o755),
            ("/run/exhibit-display", 0o700),
        ):
            path = self.m.path(inside)
            path.mkdir(parents=True, exist_ok=True)
            os.chown(path, uid, gid)
            path.chmod(mode)

    def spawn(self, argv: list[str], env: dict[str, str], log_name: str) -> subprocess.Popen:
        """``argv`` started in the machine in a process group of its own, its output appended
        to the day's log ``log_name``."""
        log = open(self.logs / log_name, "a")  # noqa: SIM115 - closed in stop_all()
        self.files.append(log)
        return subprocess.Popen(
            self.m.argv(argv, env),
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )

    def start_cage(self) -> None:
        uid, gid = self.ids()
        self.directories(uid, gid)
        service = self.unit("exhibit-kiosk.service")
        words = shlex.split(service["ExecStart"][0])
        env = dict(environment(service), WLR_BACKENDS="headless", WLR_RENDERER="pixman")
        env["XDG_RUNTIME_DIR"] = "/run/exhibit-display"
        argv = ["setpriv", f"--reuid={uid}", f"--regid={gid}", "--init-groups", "--"]
        argv += self.seccomp(service, "kiosk") + words
        self.cage = self.spawn(argv, env, "cage.log")
        socket_path = self.m.path("/run/exhibit-display/wayland-0")
        deadline = time.monotonic() + 30
        while not socket_path.exists():
            assert self.cage.poll() is None, (self.logs / "cage.log").read_text()[-2000:]
            assert time.monotonic() < deadline, "cage opened no Wayland socket in 30 s"
            time.sleep(0.1)

    def start_app(self) -> None:
        """exhibit.service: its Environment= and EnvironmentFile=, its sandbox, its ExecStart=."""
        uid, gid = self.ids()
        self.directories(uid, gid)
        service = self.unit("exhibit.service")
        env = environment(service)
        site_env = self.m.path("/etc/exhibit/environment")
        if site_env.exists():
            env.update(
                line.split("=", 1) for line in site_env.read_text().splitlines() if "=" in line
            )
        writable = [self.m.path(p) for p in ("/var/lib/exhibit", "/var/cache/exhibit")]
        confine, _ = confined(service, uid, gid, writable, writable[0])
        outside = str(self.m.path("/"))
        confine = [w.replace(outside, "") for w in confine]
        argv = confine
        if yes(service, "PrivateUsers"):
            argv += ["unshare", "--user", "--map-current-user", "--"]
        argv += self.seccomp(service, "app") + shlex.split(service["ExecStart"][0])
        self.app = self.spawn(argv, env, "app.log")
        self.starts += 1

    def stop_app(self) -> int | None:
        """As systemctl stop: SIGTERM, TimeoutStopSec=, then SIGKILL; the exit code."""
        app, self.app = self.app, None
        if app is None or app.poll() is not None:
            return None if app is None else app.returncode
        os.killpg(app.pid, signal.SIGTERM)
        try:
            return app.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(app.pid, signal.SIGKILL)
            return app.wait(10)

    def stop_all(self) -> None:
        self.stop_watching.set()
        if self.watcher is not None:
            self.watcher.join(10)
        with self.lock:
            self.stop_app()
            if self.cage is not None and self.cage.poll() is None:
                os.killpg(self.cage.pid, signal.SIGTERM)
                self.cage.wait(10)
        for file in self.files:
            file.close()

    def carry_out(self, line: str) -> None:
        words = line.split()[1:]
        if "exhibit.service" not in words:
            return
        with self.lock:
            if words[0] == "start" and (self.app is None or self.app.poll() is not None):
                if self.cage is None or self.cage.poll() is not None:
                    self.start_cage()
                self.start_app()
            elif words[0] in ("restart", "try-restart") and self.app is not None:
                self.stop_app()
                self.start_app()
            elif words[0] == "stop":
                self.stop_app()

    def watch(self) -> None:
        def loop():
            while not self.stop_watching.is_set():
                calls = self.m.calls("systemctl")
                for line in calls[self.seen :]:
                    say(f"systemd: {line}")
                    self.carry_out(line)
                self.seen = len(calls)
                time.sleep(0.2)

        self.watcher = threading.Thread(target=loop, daemon=True)
        self.watcher.start()


# ------------------------------------------------------------------ looking at the kiosk


def health(m: Machine) -> dict:
    try:
        return json.loads(m.path("/var/lib/exhibit/health.json").read_text())
    except (OSError, ValueError):
        return {}


def status(m: Machine, *args: str) -> subprocess.CompletedProcess:
    return m.run(["/opt/exhibit/.venv/bin/exhibit", "status", *args], timeout=120)


def wait_for(what: str, condition, timeout: float, step: float = 0.5):
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"waited {timeout:g} s for {what}")
        time.sleep(step)


def drawing(m: Machine, since_frames: int = 0):
    h = health(m)
    return h if h.get("frames", 0) > since_frames and h.get("pid") else None


def processes_of(uid: int) -> dict[int, str]:
    """The running processes of ``uid`` (zombies, already ended, left out) and their command
    lines."""
    found = {}
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            if entry.stat().st_uid != uid:
                continue
            if not alive(int(entry.name)):
                continue
            found[int(entry.name)] = (
                (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            )
        except OSError:
            continue
    return found


def release_of(m: Machine) -> str:
    return os.readlink(m.path("/opt/exhibit"))


# ------------------------------------------------------------------ the day


@pytest.fixture(scope="module")
def day(tmp_path_factory):
    why = why_not()
    if why:
        unavailable(f"no disposable machine here: {why}")
    bundle = make_bundle(tmp_path_factory.mktemp("bundle") / "exhibit-bundle")
    logs = tmp_path_factory.mktemp("day-logs")
    seen: dict = {"statuses": []}
    seed = int(os.environ.get("EXHIBIT_DAY_SEED", str(random.SystemRandom().randrange(1 << 16))))
    rng = random.Random(seed)
    say(f"seed {seed} (EXHIBIT_DAY_SEED={seed} replays this day)")
    with machine(state_disk="8m") as m:
        units_ = Units(m, logs)
        try:
            run_the_day(m, units_, bundle, rng, seen)
        finally:
            units_.stop_all()
            for name in ("app.log", "cage.log"):
                text = (logs / name).read_text(errors="replace") if (logs / name).exists() else ""
                seen[name] = text
    yield seen


def run_the_day(m: Machine, units_: Units, bundle: Path, rng: random.Random, seen: dict) -> None:
    # -------------------------------------------------------------- 1. install
    m.install_fakes()
    usb = m.path(USB)
    usb.parent.mkdir(parents=True)
    shutil.copytree(bundle, usb, symlinks=True)
    assert m.run(["id", "exhibit"]).returncode != 0, "the machine has an exhibit user already"
    write_site(m)
    cut = m.run(
        ["/usr/bin/python3", "-c", "import socket; socket.create_connection(('1.1.1.1', 53), 3)"]
    )
    assert "Network is unreachable" in cut.stderr, cut.stderr  # really offline
    say("install: a new machine, offline, no exhibit user; the doc's lines:")
    commands = doc_block("**A new machine from a bundle, all of it**")
    seen["doc_commands"] = commands
    cwd = "/"
    for line in commands:
        words = shlex.split(line)
        if words[0] == "cd":
            cwd = words[1]
            continue
        if words[-1] == "status":
            continue  # step 6: once the kiosk draws (below)
        started = time.monotonic()
        result = m.shell(line, cwd=cwd, timeout=1800)
        say(f"  $ {line}  -> exit {result.returncode} in {time.monotonic() - started:.0f} s")
        assert result.returncode == 0, (line, result.stdout[-3000:], result.stderr[-3000:])
        if words[0] == "systemctl":
            units_.watch()  # systemd carries out what the stand-in was asked from here on
    seen["groups"] = {
        g: m.run(["getent", "group", g]).returncode == 0 for g in ("render", "video", "dialout")
    }
    cache_owners = m.run(["find", "/var/cache/exhibit", "!", "-user", "exhibit"])
    seen["cache_not_the_users"] = cache_owners.stdout.split()
    seen["first_release"] = release_of(m)

    # -------------------------------------------------------------- 2. opening
    opened = wait_for("the first frames", lambda: drawing(m, 10), 180)
    say(f"opening: the kiosk draws ({opened.get('fps')} fps, scene {opened.get('scene')})")
    step6 = next(line for line in commands if line.endswith(" status"))
    result = m.shell(step6)
    say(f"  $ {step6}  -> exit {result.returncode}")
    seen["statuses"].append(("opening", result.returncode, result.stdout, result.stderr))

    # -------------------------------------------------------------- 3. visitors, the worker
    uid, _ = units_.ids()
    workers = [pid for pid, cmd in processes_of(uid).items() if "multiprocessing" in cmd]
    for pid in workers:
        os.kill(pid, signal.SIGKILL)
    seen["workers_killed"] = len(workers)
    say(f"the preparing worker killed ({len(workers)} process(es))")
    wait_for(
        "the first visitor's takeover",
        lambda: health(m).get("mode") not in (None, "attract"),
        60,
    )
    say(f"a visitor takes over: {health(m).get('mode')}, scene {health(m).get('scene')}")
    wait_for("the visitor to walk away", lambda: health(m).get("mode") == "attract", 60)
    say("the visitor walked away: attract mode again")

    # -------------------------------------------------------------- 4. the state disk fills
    fill = m.run(["dd", "if=/dev/zero", "of=/var/lib/exhibit/fill", "bs=64k"])
    say(f"the state disk fills: {fill.stderr.strip().splitlines()[-1:]}")
    wait_for(
        "status to say the disk is full",
        lambda: status(m).returncode == 5,
        30,
        step=1,
    )
    full = status(m)
    say(f"  exhibit status -> exit {full.returncode}: {full.stderr.strip()}")
    seen["statuses"].append(("disk full", full.returncode, full.stdout, full.stderr))
    frames = health(m).get("frames", 0)
    time.sleep(2)
    seen["drawing_while_full"] = health(m).get("frames", 0) > frames
    wait_for(
        "the second visitor's takeover", lambda: health(m).get("mode") not in ("attract", None), 90
    )
    say("a second visitor takes over, and leaves while the disk is full")
    wait_for("the second visitor to walk away", lambda: health(m).get("mode") == "attract", 60)
    time.sleep(2)  # the session's end is written (and fails) within a report
    m.run(["rm", "-f", "/var/lib/exhibit/fill"])
    wait_for("status OK after the disk emptied", lambda: status(m).returncode == 0, 30, step=1)
    emptied = status(m)
    say(f"the disk empties: exhibit status -> exit {emptied.returncode}")
    seen["statuses"].append(("emptied", emptied.returncode, emptied.stdout, emptied.stderr))
    m.path("/etc/exhibit/visitors").write_text(NOBODY)  # the day's visitors have been
    seen["narration"] = (health(m).get("narration") or {}).get("player")

    # -------------------------------------------------------------- 5. the technician
    step = rng.choice(["daemon-reload", "try-restart"])  # inside the install / the restart
    m.plant_kill(step)
    say(f"the technician updates; the update is killed at `systemctl {step}`")
    killed = m.shell("./bootstrap.sh update", cwd=USB, timeout=1800)
    seen["killed_update"] = (killed.returncode, killed.stderr[-2000:])
    seen["kills"] = m.kills()
    say(f"  $ ./bootstrap.sh update -> exit {killed.returncode}; {m.kills()}")
    owed = status(m)
    seen["statuses"].append(("update killed", owed.returncode, owed.stdout, owed.stderr))
    say(f"  exhibit status -> exit {owed.returncode}: {owed.stderr.strip()[:400]}")
    finish = re.search(r"finish it with: (\S+ update [^\s;]+)", owed.stderr)
    assert finish, owed.stderr
    again = m.shell(finish.group(1), timeout=1800)
    said = again.stdout.strip().splitlines()[-1:] or [again.stderr.strip()[-300:]]
    say(f"  $ {finish.group(1)} -> exit {again.returncode}: {said[0]}")
    seen["finished"] = (again.returncode, again.stdout, again.stderr)
    seen["second_release"] = release_of(m)
    wait_for(
        "the kiosk to run the new release",
        lambda: seen["second_release"].rsplit("/", 1)[-1] in str(health(m).get("release")),
        120,
    )
    wait_for("status OK after the update", lambda: status(m).returncode == 0, 60, step=1)
    seen["owed_after"] = status(m)
    for n in (1, 2):
        back = m.shell("/opt/exhibit/.venv/bin/exhibit rollback", timeout=1800)
        said = back.stdout.strip().splitlines()[-1:] or [back.stderr.strip()[-200:]]
        say(f"  $ /opt/exhibit/.venv/bin/exhibit rollback -> exit {back.returncode}: {said[0]}")
        seen[f"rollback_{n}"] = (back.returncode, release_of(m), back.stdout, back.stderr)
        target = release_of(m).rsplit("/", 1)[-1]
        wait_for(
            f"the kiosk to run {target}",
            lambda t=target: t in str(health(m).get("release")) and drawing(m),
            120,
        )
    named = status(m, "--json")
    seen["final_status"] = (named.returncode, named.stdout, named.stderr)
    seen["version"] = m.run(["/opt/exhibit/.venv/bin/exhibit", "--version"]).stdout.strip()
    seen["last_health"] = health(m)

    # -------------------------------------------------------------- 6. closing
    with units_.lock:
        seen["app_exit"] = units_.stop_app()
    time.sleep(1)
    seen["left_running"] = {
        pid: cmd
        for pid, cmd in processes_of(uid).items()
        if "cage" not in cmd and "sleep" not in cmd
    }
    seen["starts"] = units_.starts
    db, query = "/var/lib/exhibit/sessions.db", "select count(*) from sessions"
    count = f"import sqlite3; print(sqlite3.connect({db!r}).execute({query!r}).fetchone()[0])"
    counted = m.run(["/usr/bin/python3", "-c", count])
    assert counted.returncode == 0, counted.stderr
    seen["sessions"] = int(counted.stdout)
    say(f"closing: {seen['sessions']} visitor sessions logged, {units_.starts} app starts")


# ------------------------------------------------------------------ what the day shows


def test_the_doc_installed_a_new_machine_offline(day):
    assert any(line.startswith("./bootstrap.sh update") for line in day["doc_commands"])
    assert all(day["groups"].values()), day["groups"]  # the unit's groups, made if missing
    assert day["cache_not_the_users"] == [], day["cache_not_the_users"]
    assert day["first_release"].startswith("exhibit-releases/"), day["first_release"]


def test_the_kiosk_spoke_under_its_sandbox(day):
    player = day["narration"] or {}
    assert player.get("state") == "ok", (player, day["app.log"][-2000:])
    assert player.get("sounds_begun", 0) >= 1 and player.get("played_s", 0) > 0.5, player


def test_the_health_was_honest_at_every_step(day):
    codes = {label: code for label, code, _out, _err in day["statuses"]}
    assert codes == {
        "opening": 0,
        "disk full": 5,
        "emptied": 0,
        "update killed": 6,
    }, day["statuses"]
    assert day["drawing_while_full"], "the kiosk stopped drawing while the disk was full"


def test_every_owed_step_was_done_by_the_re_run(day):
    assert day["kills"] and day["kills"][0].startswith("killed at:"), day["kills"]
    code, out, err = day["finished"]
    assert code == 0, (out, err)
    assert "the update that stopped is done" in out, out
    assert day["owed_after"].returncode == 0, day["owed_after"].stderr
    assert day["second_release"] != day["first_release"]


def test_a_rollback_twice_ends_where_it_began(day):
    first, second = day["rollback_1"], day["rollback_2"]
    assert first[0] == 0 and second[0] == 0, (first, second)
    assert first[1] == day["first_release"], first
    assert second[1] == day["second_release"], second


def test_the_end_is_a_complete_working_release_that_status_names(day):
    code, out, err = day["final_status"]
    assert code == 0, err
    report = json.loads(out)
    assert report["release"] and report["release"] in day["second_release"], report["release"]
    assert day["version"].startswith("exhibit "), day["version"]
    assert day["app_exit"] == 0, day["app.log"][-2000:]


def test_every_visitor_session_is_in_the_log(day):
    assert day["sessions"] == 2, day["sessions"]


def test_nothing_outlives_the_kiosk(day):
    assert day["left_running"] == {}, day["left_running"]
