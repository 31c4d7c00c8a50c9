"""The display stack of docs/DEPLOYMENT.md, end to end: cage and `exhibit run` as an unprivileged
user, each under its unit's sandbox as far as it can be applied without systemd, the picture on
cage's output watched from READY=1 on, and cage stopped as `systemctl stop` stops it.

What runs is taken from the unit files as `exhibit install --root` writes them: cage's ExecStart=
(with Xwayland installed, as Debian's cage 0.1.4 refuses to start without it), the app's
Environment= (the native Wayland build of GLFW), the socket wait of its ExecStartPre=, cage's
ExecStop=, and the sandbox settings that are seccomp filters (SystemCallFilter=,
SystemCallErrorNumber=, RestrictAddressFamilies=, RestrictRealtime=, NoNewPrivileges=, via
sandbox_exec.py), PrivateUsers= (a user namespace through `unshare`, where the kernel allows it)
and UMask=; for the app also its file system and identity (ProtectSystem=strict with its
writable folders, PrivateTmp=, ProtectHome=, User=, SupplementaryGroups=, WorkingDirectory=, via
unit_mounts.py), with narration on, played to the null device. What
differs from a museum PC: cage uses wlroots' headless backend and pixman renderer (no GPU, no seat
here), with its output turned by 180 degrees while the exhibit is watched (CI_TURN: on the
headless output grim cannot see a directly scanned-out client frame; cage_client.py shows it, and
docs/DEPLOYMENT.md, "Display", explains it), and the paths under /run, /var/lib and /var/cache
are in a temporary folder.

Needs root (to make the user) and the packages in bootstrap.sh's apt_test list: cage, xwayland,
grim, the Wayland client libraries; skipped without them (a failure under CI=true, where
bootstrap.sh installed them).
"""

from __future__ import annotations

import contextlib
import ctypes.util
import hashlib
import io
import json
import os
import pwd
import secrets
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.deploy.unit_mounts import can_confine, confined
from tests.deploy.unitfile import environment, sandbox_options, units, yes

# Seconds of a real compositor and kiosk, with timing checks on the screen: CI runs them, alone.
pytestmark = [pytest.mark.slow, pytest.mark.serial]

REPO = Path(__file__).resolve().parents[2]
SANDBOX = Path(__file__).with_name("sandbox_exec.py")
PROGRAMS = {
    "cage": "cage",
    "Xwayland": "xwayland",
    "grim": "grim",
    "unshare": "util-linux",
    "useradd": "passwd",
    "userdel": "passwd",
    "systemd-analyze": "systemd",
}
LIBRARIES = {
    "wayland-client": "libwayland-client0",
    "wayland-egl": "libwayland-egl1",
    "wayland-cursor": "libwayland-cursor0",
    "xkbcommon": "libxkbcommon0",
    "seccomp": "libseccomp2",
}
CLIENT = Path(__file__).with_name("cage_client.py")
#: How long the kiosk runs after its start-up (it exits by itself, as with --duration).
RUN_S = 10
#: Output size of wlroots' headless backend.
OUTPUT = (1280, 720)
#: How long the screen is watched from READY=1 on (within RUN_S), and how often it is grabbed.
WATCH_S = 5
GRAB_EVERY_S = 0.1
#: The picture must be on the screen this soon after READY=1, and change at least this often in
#: attract mode (seconds).
VISIBLE_WITHIN_S = 1.0
CHANGES_WITHIN_S = 1.0
#: cage's options that turn its output by 180 degrees (`-r` twice), for CI only. cage 0.1.4 shows
#: a fullscreen client's buffer directly (scan-out) where the output accepts it, and the headless
#: output accepts any buffer; grim's screencopy request stops the scan-out for one frame, and that
#: frame is composited from wlroots 0.15's damage, which missed every frame scanned out since the
#: last grab: grim gets an old picture, black at first. A turned output cannot show the client's
#: buffer as it is, so cage composites every frame and grim sees each one. grim turns the picture
#: back. test_grim_sees_an_old_frame_... below shows both with cage_client.py.
CI_TURN = ["-r", "-r"]
#: The colours cage_client.py is asked to show, one after another.
COLOURS = [(200, 40, 40), (40, 160, 60), (50, 70, 220)]


def unavailable(reason: str):
    """Skip, except under CI=true, where bootstrap.sh installed what this test needs."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: this test must run)")
    pytest.skip(reason)


def check_prerequisites() -> None:
    if os.geteuid() != 0:
        pytest.skip("needs root: it creates a temporary system user to run cage and the kiosk")
    missing = sorted(
        {pkg for exe, pkg in PROGRAMS.items() if shutil.which(exe) is None}
        | {pkg for lib, pkg in LIBRARIES.items() if ctypes.util.find_library(lib) is None}
    )
    if missing:
        unavailable(
            f"missing Debian packages: {' '.join(missing)} "
            f"(apt-get install {' '.join(missing)}, or ./bootstrap.sh test)"
        )


@contextlib.contextmanager
def system_user():
    """A temporary system user like `exhibit install` makes; removed afterwards."""
    name = f"exhibit-ci-{secrets.token_hex(4)}"
    subprocess.run(
        [
            "useradd",
            "--system",
            "--user-group",
            "--no-create-home",
            "--home-dir",
            "/nonexistent",
            "--shell",
            "/usr/sbin/nologin",
            name,
        ],
        check=True,
        capture_output=True,
        text=True,
        timeout=30,
    )
    try:
        yield pwd.getpwnam(name)
    finally:
        subprocess.run(["userdel", name], capture_output=True, timeout=30)


class AsUser:
    """Popen arguments that run a command as ``user`` (no supplementary groups) in a new session,
    so that it and everything it starts can be stopped as one process group."""

    def __init__(self, user: pwd.struct_passwd, env: dict[str, str]):
        self.user, self.env = user, env

    def kwargs(self, umask: int = 0o022, env: dict[str, str] | None = None) -> dict:
        return {
            "user": self.user.pw_uid,
            "group": self.user.pw_gid,
            "extra_groups": [],
            "umask": umask,
            "env": dict(self.env, **(env or {})),
            "cwd": "/",
            "start_new_session": True,
        }

    def run(self, argv: list[str], timeout: float = 60, **kw) -> subprocess.CompletedProcess:
        return subprocess.run(
            argv, capture_output=True, text=True, timeout=timeout, **self.kwargs(**kw)
        )


def python_for(user: AsUser) -> tuple[list[str], dict[str, str]]:
    """An interpreter that ``user`` can run with this checkout and its packages: this one if the
    user can reach it (a venv made from Debian's python3, as on the kiosk), else the system
    Python of the same version with the venv's packages on PYTHONPATH (a venv made from an
    interpreter under /root, which is closed to other users)."""
    probe = ["-c", "import exhibit, glfw, moderngl, numpy, PIL"]
    candidates = [([sys.executable], {})]
    system = Path(f"/usr/bin/python{sys.version_info.major}.{sys.version_info.minor}")
    if system.exists():
        paths = [str(REPO), sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]]
        candidates.append(([str(system)], {"PYTHONPATH": os.pathsep.join(dict.fromkeys(paths))}))
    reasons = []
    for argv, env in candidates:
        try:
            result = user.run(argv + probe, env=env)
        except OSError as exc:  # the interpreter itself is out of reach
            reasons.append(f"{argv[0]}: {exc.strerror}")
            continue
        if result.returncode == 0:
            return argv, env
        reasons.append(f"{argv[0]}: {result.stderr.strip().splitlines()[-1:]}")
    pytest.fail(
        "no Python the test user can run with this checkout (is it world-readable?): "
        + "; ".join(reasons)
    )


def user_namespace(user: AsUser) -> list[str]:
    """`unshare` arguments for PrivateUsers=yes (only the user itself mapped inside), or [] with
    a note where the kernel refuses unprivileged user namespaces."""
    argv = ["unshare", "--user", "--map-current-user", "--"]
    result = user.run(argv + ["true"])
    if result.returncode != 0:
        print(f"note: no user namespace for PrivateUsers=yes here: {result.stderr.strip()}")
        return []
    return argv


def sandbox(python: list[str], service: dict[str, list[str]], folder: Path, name: str) -> list[str]:
    """sandbox_exec.py arguments for the unit's seccomp settings."""
    return python + [str(SANDBOX), *sandbox_options(service, folder, name), "--"]


def stop(process: subprocess.Popen | None) -> None:
    """End a process this test started, and its process group (it was made a session leader)."""
    if process is None or process.poll() is not None:
        return
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGTERM)
    try:
        process.wait(5)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(5)


def wait_for(condition, timeout: float, step: float = 0.1):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(step)
    return None


def programs_of(uid: int) -> set[str]:
    """The names of the running processes of ``uid``."""
    names = set()
    for status in Path("/proc").glob("[0-9]*/status"):
        try:
            fields = dict(
                line.split(":", 1) for line in status.read_text().splitlines() if ":" in line
            )
        except OSError:
            continue
        if fields.get("Uid", "").split()[:1] == [str(uid)]:
            names.add(fields["Name"].strip())
    return names


def read_health(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


@pytest.fixture(scope="module")
def staged(tmp_path_factory):
    """The unit files as `exhibit install --root` writes them."""
    from exhibit.cli import main

    root = tmp_path_factory.mktemp("root")
    with open(os.devnull, "w") as devnull, contextlib.redirect_stdout(devnull):
        assert main(["install", "--root", str(root)]) == 0
    system = root / "etc/systemd/system"
    return (
        units(system / "exhibit-kiosk.service")["Service"],
        units(system / "exhibit.service")["Service"],
    )


def shell_of(command: str) -> str:
    """The script of a unit's `/bin/sh -c '...'` command line, with systemd's $$ undone."""
    assert command.startswith("/bin/sh -c '") and command.endswith("'"), command
    return command[len("/bin/sh -c '") : -1].replace("$$", "$")


def ppm(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def uniform(picture: np.ndarray) -> bool:
    """One colour all over: cage's empty (black) output, or cage_client.py's flat colour."""
    return not (picture != picture[0, 0]).any()


class Stage:
    """A temporary system user with its folders under ``base``, a Python it can run with this
    checkout, and what it runs: cage as exhibit-kiosk.service runs it, clients, grim. Everything
    started here is stopped when the stage is left (see stage())."""

    def __init__(
        self,
        user: pwd.struct_passwd,
        base: Path,
        kiosk_unit: dict,
        processes: list,
        logs: contextlib.ExitStack,
    ):
        self.user, self.base, self.kiosk_unit = user, base, kiosk_unit
        self.processes, self.logs = processes, logs
        self.folders = {}
        for name, mode in (("run", 0o700), ("state", 0o755), ("cache", 0o755), ("home", 0o700)):
            self.folders[name] = base / name
            self.folders[name].mkdir(mode=mode)
            os.chown(self.folders[name], user.pw_uid, user.pw_gid)
        self.as_user = AsUser(
            user,
            {
                "PATH": "/usr/sbin:/usr/bin:/sbin:/bin",
                "LANG": "C.UTF-8",
                "HOME": str(self.folders["home"]),
            },
        )
        self.python, self.python_env = python_for(self.as_user)
        self.display_env = {
            "XDG_RUNTIME_DIR": str(self.folders["run"]),
            "WAYLAND_DISPLAY": "wayland-0",
        }

    def start_cage(self, turned: bool) -> tuple[subprocess.Popen, list[str]]:
        """cage from the unit's ExecStart= with its runtime folder moved here, under the unit's
        seccomp settings; ``turned``: with CI_TURN."""
        unit = self.kiosk_unit
        runtime = "/run/" + unit["RuntimeDirectory"][0]
        words = shlex.split(unit["ExecStart"][0].replace(runtime, str(self.folders["run"])))
        if turned:
            at = words.index("/usr/bin/cage") + 1
            words[at:at] = CI_TURN
        env = dict(
            environment(unit),
            WLR_BACKENDS="headless",
            WLR_RENDERER="pixman",
            XDG_RUNTIME_DIR=str(self.folders["run"]),
            **self.python_env,
        )
        argv = sandbox(self.python, unit, self.base, "kiosk") + words
        if yes(unit, "PrivateUsers"):
            argv = user_namespace(self.as_user) + argv
        log = self.logs.enter_context(
            open(self.base / f"cage-{len(self.processes)}.log", "w+")  # noqa: SIM115 - an ExitStack's
        )
        cage = subprocess.Popen(
            argv,
            stdout=log,
            stderr=subprocess.STDOUT,
            **self.as_user.kwargs(umask=int(unit["UMask"][0], 8), env=env),
        )
        cage.log = log
        self.processes.append(cage)
        return cage, argv

    def grab(self) -> tuple[float, np.ndarray | None, str]:
        """grim's picture of the output (wlr-screencopy), and when it came (time.monotonic())."""
        result = subprocess.run(
            ["grim", "-t", "ppm", "-"],
            capture_output=True,
            timeout=30,
            **self.as_user.kwargs(env=self.display_env),
        )
        done = time.monotonic()
        if result.returncode != 0:
            return done, None, result.stderr.decode(errors="replace")
        return done, ppm(result.stdout), ""

    def stop_cage(self, cage: subprocess.Popen) -> dict:
        """As `systemctl stop exhibit-kiosk` does once exhibit.service (ordered after it, so
        stopped first) is gone: the unit's ExecStop= (under the unit's seccomp settings, with
        $MAINPID), and then SIGTERM to whatever is left (KillMode=control-group). This test
        reaps cage as systemd would, which ExecStop='s wait for /proc/$MAINPID to go needs."""
        unit = self.kiosk_unit
        argv = sandbox(self.python, unit, self.base, "kiosk") + [
            "/bin/sh",
            "-c",
            shell_of(unit["ExecStop"][0]),
        ]
        started = time.monotonic()
        stopper = subprocess.Popen(
            argv,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            **self.as_user.kwargs(
                umask=int(unit["UMask"][0], 8), env=dict(self.python_env, MAINPID=str(cage.pid))
            ),
        )
        self.processes.append(stopper)
        try:
            code = cage.wait(10)
        except subprocess.TimeoutExpired:
            code = None
        took = time.monotonic() - started
        output = stopper.communicate(timeout=15)[0]
        stop(cage)  # what systemd's SIGTERM would then reach (nothing, if ExecStop= worked)
        cage.log.seek(0)
        return {
            "code": code if code is not None else cage.returncode,
            "by_exec_stop": code is not None,
            "exec_stop": stopper.returncode,
            "output": output,
            "took": took,
            "log": cage.log.read(),
        }


@contextlib.contextmanager
def stage(kiosk_unit: dict):
    check_prerequisites()
    # Not under /tmp: the app's PrivateTmp= gives it an empty /tmp of its own.
    base = Path(tempfile.mkdtemp(prefix="exhibit-cage-", dir="/var/lib"))
    base.chmod(0o755)  # the test user reads its configs and the seccomp lists here
    processes: list[subprocess.Popen] = []
    try:
        with system_user() as user, contextlib.ExitStack() as logs:
            # Leaving this block (even by a failed assertion) stops what runs as the user
            # before the user is removed.
            logs.callback(lambda: [stop(p) for p in reversed(processes)])
            yield Stage(user, base, kiosk_unit, processes, logs)
    finally:
        shutil.rmtree(base, ignore_errors=True)


def watch(stage_: Stage, since: float, seconds: float, alive) -> dict:
    """Grab the screen every GRAB_EVERY_S for ``seconds`` (while ``alive()``). ``seen``: for
    each grab, when it came (seconds after ``since``), a digest of its picture ("" when grim
    failed) and whether the picture is one colour; ``first``: the first picture that is not;
    ``error``: grim's last complaint."""
    seen: list[tuple[float, str, bool]] = []
    first = error = None
    while time.monotonic() - since < seconds and alive():
        began = time.monotonic()
        done, picture, complaint = stage_.grab()
        if picture is None:
            error = complaint
            seen.append((done - since, "", True))
        else:
            flat = uniform(picture)
            if not flat and first is None:
                first = picture
            seen.append((done - since, hashlib.sha1(picture.tobytes()).hexdigest(), flat))
        time.sleep(max(0.0, GRAB_EVERY_S - (time.monotonic() - began)))
    return {"seen": seen, "first": first, "error": error}


def changes(seen: list[tuple[float, str, bool]]) -> dict:
    """From watch(): when the first picture that is not one colour came, and the longest time
    from it without a changed picture (up to the last grab)."""
    shown = [(t, digest) for t, digest, flat in seen if digest and not flat]
    if not shown:
        return {"first": None, "longest": None, "changes": 0, "grabs": len(seen)}
    times = [shown[0][0]] + [t for (t, d), (_, before) in zip(shown[1:], shown) if d != before]
    ends = times + [seen[-1][0]]
    return {
        "first": shown[0][0],
        "longest": max(b - a for a, b in zip(ends, ends[1:])),
        "changes": len(times) - 1,
        "grabs": len(seen),
    }


@pytest.fixture(scope="module")
def kiosk_on_cage(staged):
    """cage and the kiosk as in the units, the screen watched from READY=1 on, and cage stopped
    as systemd stops it; yields what was observed."""
    kiosk_unit, app_unit = staged
    with stage(kiosk_unit) as st:
        base, folders, as_user = st.base, st.folders, st.as_user
        python, python_env = st.python, st.python_env
        # The site config: only the keys it changes (docs/DEPLOYMENT.md), here fewer scenes and
        # one attract timeline so that a cold mesh cache builds in seconds.
        (base / "attract").mkdir()
        shutil.copy(REPO / "configs/attract/01-hypersphere.toml", base / "attract")
        site = base / "kiosk.toml"
        # Narration on in attract mode, to the null device (no sound card here): the player's
        # tap in the health file shows what the device took.
        site.write_text(
            '[content]\nscenes = ["hopf", "clifford-torus"]\n'
            'start_scene = "hopf"\n\n[attract]\ntimelines = "attract"\n\n'
            '[narration]\nattract = true\nbackend = "null"\n'
        )
        for path in (site, *base.joinpath("attract").iterdir()):
            path.chmod(0o644)
        base.joinpath("attract").chmod(0o755)
        check = as_user.run(python + ["-m", "exhibit", "check-config", str(site)], env=python_env)
        assert check.returncode == 0, check.stdout + check.stderr

        t0 = time.monotonic()
        cage, cage_argv = st.start_cage(turned=True)

        # The app: its Environment= with the folders moved here, after its ExecStartPre=.
        env = environment(app_unit)
        env.update(
            XDG_RUNTIME_DIR=str(folders["run"]),
            EXHIBIT_STATE_DIR=str(folders["state"]),
            EXHIBIT_CACHE_DIR=str(folders["cache"] / "meshes"),
            XDG_CACHE_HOME=str(folders["cache"]),
            EXHIBIT_CONFIG=str(site),
            **python_env,
        )
        assert env["WAYLAND_DISPLAY"] == st.display_env["WAYLAND_DISPLAY"]
        waited = as_user.run(
            ["/bin/sh", "-c", shell_of(app_unit["ExecStartPre"][0])], timeout=30, env=env
        )
        t_socket = time.monotonic() - t0
        cage.log.seek(0)
        assert waited.returncode == 0, (waited.stderr, cage.log.read())

        notify = st.logs.enter_context(socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM))
        notify.bind(str(base / "notify"))
        os.chmod(base / "notify", 0o777)
        notify.settimeout(0.2)
        env["NOTIFY_SOCKET"] = str(base / "notify")
        assert app_unit["ExecStart"][0].endswith("/.venv/bin/exhibit run")
        app_argv = (
            sandbox(python, app_unit, base, "app")
            + python
            + ["-m", "exhibit", "run", "--duration", str(RUN_S)]
        )
        if yes(app_unit, "PrivateUsers"):
            app_argv = user_namespace(as_user) + app_argv
        # The unit's file system and identity (ProtectSystem=strict with its writable folders,
        # PrivateTmp=, ProtectHome=, User=, SupplementaryGroups=, UMask=, WorkingDirectory=),
        # entered as root as systemd does; without root's mount namespace, as the user only.
        why_not = can_confine()
        if why_not:
            unavailable(f"cannot apply the unit's file-system sandbox: {why_not}")
        writable = [folders["state"], folders["cache"], folders["run"]]
        confine, note = confined(
            app_unit, st.user.pw_uid, st.user.pw_gid, writable, folders["state"]
        )
        if note:
            print(f"note: {note}")
        app_argv = confine + app_argv
        app_log = st.logs.enter_context(open(base / "app.log", "w+"))  # noqa: SIM115 - ExitStack
        t1 = time.monotonic()
        app = subprocess.Popen(
            app_argv,
            stdout=app_log,
            stderr=subprocess.STDOUT,
            env=dict(as_user.env, **env),
            start_new_session=True,
        )
        st.processes.append(app)

        messages: list[str] = []

        def ready():
            with contextlib.suppress(TimeoutError):
                messages.extend(notify.recv(4096).decode().splitlines())
            return "READY=1" in messages or app.poll() is not None

        wait_for(ready, 60, step=0)
        t_ready = time.monotonic()
        # The screen from READY=1 on, as a visitor would see it.
        watched = watch(st, t_ready, WATCH_S, lambda: app.poll() is None)
        seen = watched["seen"]
        health_file = folders["state"] / "health.json"
        health = wait_for(lambda: (h := read_health(health_file)) and h.get("frames") and h, 10)
        running = programs_of(st.user.pw_uid)
        code = app.wait(RUN_S + 60)
        after_exit = programs_of(st.user.pw_uid)
        with contextlib.suppress(TimeoutError):
            while True:
                messages.extend(notify.recv(4096).decode().splitlines())
        last_health = read_health(health_file)
        cage_alive = cage.poll() is None
        # systemctl stop: exhibit.service first (the app has ended by itself here), then cage.
        stopped = st.stop_cage(cage)
        app_log.seek(0)
        observed = {
            "code": code,
            "log": app_log.read(),
            "cage_log": stopped["log"],
            "cage_alive": cage_alive,
            "messages": messages,
            "health": health,
            "last_health": last_health,
            "grim_error": watched["error"],
            "picture": watched["first"],
            "seen": seen,
            "screen": changes(seen),
            "stopped": stopped,
            "t_socket": t_socket,
            "t_ready": t_ready - t1,
            "pid": app.pid,
            "running": running,
            "after_exit": after_exit,
            "sandboxed": {"app": app_argv, "cage": cage_argv},
        }
    summary = {k: (last_health or {}).get(k) for k in ("fps", "frames", "frame_ms_p95")}
    screen = observed["screen"]
    print(
        f"\ncage's socket after {t_socket:.2f} s; the kiosk's READY=1 (first frame) "
        f"{t_ready - t1:.2f} s after its start; health: {json.dumps(summary)}"
    )
    print(
        f"the screen from READY=1 on, grabbed {screen['grabs']} times in {WATCH_S} s: the "
        f"exhibit first after {fmt(screen['first'])} s, {screen['changes']} changes, at most "
        f"{fmt(screen['longest'])} s without one; cage stopped by ExecStop= in "
        f"{stopped['took']:.2f} s, exit status {stopped['code']}"
    )
    yield observed


def fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


@pytest.fixture(scope="module")
def client_on_cage(staged):
    """cage_client.py on cage, once as the unit runs cage and once with CI_TURN: the colours
    asked for and, after each was shown, what grim saw (the middle pixel, and whether the
    whole picture is that one colour)."""
    kiosk_unit, _ = staged
    observed = {}
    with stage(kiosk_unit) as st:
        for turned in (False, True):  # one after the other, on the same socket
            socket_path = st.folders["run"] / st.display_env["WAYLAND_DISPLAY"]
            assert not socket_path.exists(), "left behind by the cage before"
            cage, _ = st.start_cage(turned)
            assert wait_for(socket_path.exists, 20), cage.log.name
            env = dict(
                st.display_env,
                XDG_SESSION_TYPE="wayland",
                PYGLFW_LIBRARY_VARIANT="wayland",
                **st.python_env,
            )
            client = subprocess.Popen(
                st.python + [str(CLIENT)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                **st.as_user.kwargs(env=env),
            )
            st.processes.append(client)
            assert client.stdout.readline().startswith("ready"), client.stderr.read()
            grabs = []
            for colour in COLOURS:
                client.stdin.write("{} {} {}\n".format(*colour))
                client.stdin.flush()
                assert client.stdout.readline().split() == ["shown", *map(str, colour)]
                _, picture, error = st.grab()
                assert picture is not None, error
                middle = picture[picture.shape[0] // 2, picture.shape[1] // 2]
                grabs.append((colour, tuple(int(v) for v in middle), uniform(picture)))
            _, errors = client.communicate(timeout=30)  # its stdin closed: it exits
            client_code = client.returncode
            observed[turned] = {
                "grabs": grabs,
                "client": client_code,
                "errors": errors,
                "stopped": st.stop_cage(cage),
            }
    for turned, label in ((False, "as the unit runs it"), (True, "turned (CI_TURN)")):
        seen = ", ".join(f"{asked} -> {got}" for asked, got, _ in observed[turned]["grabs"])
        print(f"\ncage_client.py on cage {label}: asked for -> grim saw: {seen}")
    yield observed


def test_the_kiosk_starts_on_cage_and_reports_ready(kiosk_on_cage):
    seen = kiosk_on_cage
    assert seen["code"] == 0, seen["log"][-3000:]
    assert "READY=1" in seen["messages"], seen["log"][-3000:]
    assert seen["cage_alive"], seen["cage_log"][-2000:]
    assert seen["t_ready"] < 45
    status = [m for m in seen["messages"] if m.startswith("STATUS=")]
    assert status and " fps, attract, hopf" in status[0]  # ", preparing ..." may follow
    # Natively on Wayland: cage starts Xwayland only for an X client, and none came.
    assert "cannot start GLFW" not in seen["log"]
    assert "cage" in seen["running"] and "Xwayland" not in seen["running"], seen["running"]


def test_the_health_file_says_attract_and_counts_frames(kiosk_on_cage):
    for health in (kiosk_on_cage["health"], kiosk_on_cage["last_health"]):
        assert health, kiosk_on_cage["log"][-3000:]
        assert health["mode"] == "attract" and health["scene"] == "hopf"
        assert health["frames"] > 0 and health["fps"] > 0
        assert health["gl_errors"] == 0 and health["frame_errors"] == 0
        assert health["scenes_failed"] == [] and health["problems"] == []
        assert health["pid"] == kiosk_on_cage["pid"]
    assert kiosk_on_cage["last_health"]["frames"] > kiosk_on_cage["health"]["frames"]


def test_the_compositor_shows_the_exhibit(kiosk_on_cage):
    """grim reads the frame back from cage (wlr-screencopy): the exhibit's picture fills the
    output, upright, with its background gradient (lighter at the top) and many colours."""
    picture = kiosk_on_cage["picture"]
    assert picture is not None, (kiosk_on_cage["grim_error"], kiosk_on_cage["seen"][:5])
    assert picture.shape == (OUTPUT[1], OUTPUT[0], 3)
    colours = len(np.unique(picture.astype(np.uint32) @ np.array([1 << 16, 1 << 8, 1], np.uint32)))
    assert colours > 500, f"only {colours} colours: not the exhibit's picture"
    top = picture[:4, :8].astype(float).mean()
    bottom = picture[-4:, :8].astype(float).mean()
    assert top > bottom + 10 and top > 20, (top, bottom)  # the gradient, and not black


def test_the_picture_is_on_the_screen_at_ready(kiosk_on_cage):
    """READY=1 means the first frame is on the screen: grim sees the exhibit at once."""
    screen = kiosk_on_cage["screen"]
    assert screen["first"] is not None, kiosk_on_cage["seen"]
    assert screen["first"] <= VISIBLE_WITHIN_S, kiosk_on_cage["seen"][:20]


def test_the_picture_keeps_changing_in_attract_mode(kiosk_on_cage):
    """Attract mode moves all the time: from the first picture to the end of the watch, never
    a second without a changed picture on the screen."""
    screen, seen = kiosk_on_cage["screen"], kiosk_on_cage["seen"]
    assert seen and seen[-1][0] >= WATCH_S - 1, seen  # the app ran through the watch
    assert screen["longest"] is not None and screen["longest"] <= CHANGES_WITHIN_S, seen


def test_cage_stops_cleanly(kiosk_on_cage):
    """ExecStop= ends cage through its own client, so cage exits 0 before systemd's SIGTERM
    (which makes cage 0.1.4 abort: `wl_display_terminate: Assertion ... failed`, a core dump)."""
    stopped = kiosk_on_cage["stopped"]
    assert stopped["by_exec_stop"] and stopped["code"] == 0, stopped
    assert stopped["exec_stop"] == 0, stopped["output"]
    assert "Assertion" not in stopped["log"] and "Aborted" not in stopped["log"], stopped["log"]


def test_grim_sees_an_old_frame_of_a_scanned_out_client(client_on_cage):
    """Why CI turns cage's output: on the headless output, as the unit runs cage, a client's
    fullscreen frames are scanned out and grim gets an older, composited picture (black before
    the first composited frame); on the turned output every frame is composited and grim sees
    each one. If grim ever sees every colour without CI_TURN, cage or wlroots changed: CI_TURN
    and the note in docs/DEPLOYMENT.md ("Display") can go."""
    plain, turned = client_on_cage[False], client_on_cage[True]
    for run in (plain, turned):
        assert run["client"] == 0, run["errors"]
        assert run["stopped"]["by_exec_stop"] and run["stopped"]["code"] == 0, run["stopped"]
    for asked, got, flat in turned["grabs"]:
        assert flat and np.abs(np.subtract(asked, got)).max() <= 2, turned["grabs"]
    assert any(np.abs(np.subtract(asked, got)).max() > 2 for asked, got, _ in plain["grabs"]), (
        plain["grabs"]
    )


def test_it_ran_under_the_units_sandbox(kiosk_on_cage, staged):
    """The commands above really were wrapped: each unit's seccomp settings (RestrictRealtime=
    too), the app's file system and identity, and PrivateUsers= where the kernel allows it."""
    app, cage = kiosk_on_cage["sandboxed"]["app"], kiosk_on_cage["sandboxed"]["cage"]
    assert "--syscalls" in app and "--families" in app and "--syscalls" in cage
    assert "--no-realtime" in app
    assert app[:2] == ["unshare", "--mount"] and any(w.startswith("--reuid=") for w in app)
    assert app[app.index("--errno") + 1] == "EPERM"
    assert "/usr/bin/cage" in cage


def test_narration_sounds_under_the_units_sandbox(kiosk_on_cage):
    """Attract mode speaks (narration on, to the null device): under the unit's sandbox the
    player opened its device, and the device's own thread took the sound (the tap); no speech
    engine outlives the kiosk."""
    narration = (kiosk_on_cage["last_health"] or {}).get("narration") or {}
    player = narration.get("player") or {}
    assert player.get("state") == "ok", (narration, kiosk_on_cage["log"][-3000:])
    assert player["sounds_begun"] >= 1 and player["played_s"] > 0.5, narration
    assert narration["failed"] == [], narration
    assert "espeak-ng" not in kiosk_on_cage["after_exit"], kiosk_on_cage["after_exit"]


def test_the_worker_prepared_the_other_scenes_under_the_sandbox(kiosk_on_cage):
    """The scenes after the first came from the worker process (exhibit.preparing.preparing),
    spawned by the app as the unprivileged user under the unit's system call filter."""
    log = kiosk_on_cage["log"]
    assert "scene clifford-torus prepared" in log, log[-3000:]
    assert "every scene is prepared" in log, log[-3000:]
    assert "preparing process died" not in log and "Traceback" not in log, log[-3000:]
