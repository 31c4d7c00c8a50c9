"""The display stack of docs/DEPLOYMENT.md, end to end: cage and `exhibit run` as an unprivileged
user, each under its unit's sandbox as far as it can be applied without systemd, and a frame
captured from the compositor.

What runs is taken from the unit files as `exhibit install --root` writes them: cage's ExecStart=
(with Xwayland installed, as Debian's cage 0.1.4 refuses to start without it), the app's
Environment= (the native Wayland build of GLFW), the socket wait of its ExecStartPre=, and the
sandbox settings that are seccomp filters (SystemCallFilter=, SystemCallErrorNumber=,
RestrictAddressFamilies=, NoNewPrivileges=, via sandbox_exec.py), PrivateUsers= (a user namespace
through `unshare`, where the kernel allows it) and UMask=. What differs from a museum PC: cage uses
wlroots' headless backend and pixman renderer (no GPU, no seat here), and the paths under
/run, /var/lib and /var/cache are in a temporary folder.

Needs root (to make the user) and the packages in bootstrap.sh's apt_test list: cage, xwayland,
grim, the Wayland client libraries; skipped without them (a failure under CI=true, where
bootstrap.sh installed them).
"""

from __future__ import annotations

import contextlib
import ctypes.util
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

from tests.deploy.unitfile import allowed_syscalls, environment, units, yes

REPO = Path(__file__).resolve().parents[2]
SANDBOX = Path(__file__).with_name("sandbox_exec.py")
PROGRAMS = {"cage": "cage", "Xwayland": "xwayland", "grim": "grim", "unshare": "util-linux",
            "useradd": "passwd", "userdel": "passwd", "systemd-analyze": "systemd"}
LIBRARIES = {"wayland-client": "libwayland-client0", "wayland-egl": "libwayland-egl1",
             "wayland-cursor": "libwayland-cursor0", "xkbcommon": "libxkbcommon0",
             "seccomp": "libseccomp2"}
#: How long the kiosk runs (it exits by itself, as with --duration).
RUN_S = 10
#: Output size of wlroots' headless backend.
OUTPUT = (1280, 720)


def unavailable(reason: str):
    """Skip, except under CI=true, where bootstrap.sh installed what this test needs."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: this test must run)")
    pytest.skip(reason)


def check_prerequisites() -> None:
    if os.geteuid() != 0:
        pytest.skip("needs root: it creates a temporary system user to run cage and the kiosk")
    missing = sorted({pkg for exe, pkg in PROGRAMS.items() if shutil.which(exe) is None}
                     | {pkg for lib, pkg in LIBRARIES.items()
                        if ctypes.util.find_library(lib) is None})
    if missing:
        unavailable(f"missing Debian packages: {' '.join(missing)} "
                    f"(apt-get install {' '.join(missing)}, or ./bootstrap.sh test)")


@contextlib.contextmanager
def system_user():
    """A temporary system user like `exhibit install` makes; removed afterwards."""
    name = f"exhibit-ci-{secrets.token_hex(4)}"
    subprocess.run(["useradd", "--system", "--user-group", "--no-create-home", "--home-dir",
                    "/nonexistent", "--shell", "/usr/sbin/nologin", name], check=True,
                   capture_output=True, text=True, timeout=30)
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
        return {"user": self.user.pw_uid, "group": self.user.pw_gid, "extra_groups": [],
                "umask": umask, "env": dict(self.env, **(env or {})), "cwd": "/",
                "start_new_session": True}

    def run(self, argv: list[str], timeout: float = 60, **kw) -> subprocess.CompletedProcess:
        return subprocess.run(argv, capture_output=True, text=True, timeout=timeout,
                              **self.kwargs(**kw))


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
    pytest.fail("no Python the test user can run with this checkout (is it world-readable?): "
                + "; ".join(reasons))


def user_namespace(user: AsUser) -> list[str]:
    """`unshare` arguments for PrivateUsers=yes (only the user itself mapped inside), or [] with
    a note where the kernel refuses unprivileged user namespaces."""
    argv = ["unshare", "--user", "--map-current-user", "--"]
    result = user.run(argv + ["true"])
    if result.returncode != 0:
        print(f"note: no user namespace for PrivateUsers=yes here: {result.stderr.strip()}")
        return []
    return argv


def sandbox(python: list[str], service: dict[str, list[str]], folder: Path, name: str
            ) -> list[str]:
    """sandbox_exec.py arguments for the unit's seccomp settings."""
    argv = python + [str(SANDBOX)]
    calls = allowed_syscalls(service)
    if calls is not None:
        listing = folder / f"{name}.syscalls"
        listing.write_text("\n".join(sorted(calls)) + "\n")
        listing.chmod(0o644)
        errno_name = service.get("SystemCallErrorNumber", ["kill"])[-1]
        argv += ["--syscalls", str(listing), "--errno", errno_name]
    families = service.get("RestrictAddressFamilies", [""])[-1].split()
    if families:
        argv += ["--families", ",".join(families)]
    if yes(service, "MemoryDenyWriteExecute"):
        argv += ["--mdwe"]
    return argv + ["--"]


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
            fields = dict(line.split(":", 1) for line in status.read_text().splitlines()
                          if ":" in line)
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
    return (units(system / "exhibit-kiosk.service")["Service"],
            units(system / "exhibit.service")["Service"])


@pytest.fixture(scope="module")
def kiosk_on_cage(staged):
    """cage and the kiosk as in the units; yields what was observed."""
    check_prerequisites()
    kiosk_unit, app_unit = staged
    base = Path(tempfile.mkdtemp(prefix="exhibit-cage-", dir="/tmp"))
    base.chmod(0o755)  # the test user reads its configs and the seccomp lists here
    processes: list[subprocess.Popen] = []
    try:
        with system_user() as user, contextlib.ExitStack() as logs:
            # Leaving this block (even by a failed assertion) stops what runs as the user
            # before the user is removed.
            logs.callback(lambda: [stop(p) for p in reversed(processes)])
            folders = {}
            for name, mode in (("run", 0o700), ("state", 0o755), ("cache", 0o755),
                               ("home", 0o700)):
                folders[name] = base / name
                folders[name].mkdir(mode=mode)
                os.chown(folders[name], user.pw_uid, user.pw_gid)
            as_user = AsUser(user, {"PATH": "/usr/sbin:/usr/bin:/sbin:/bin", "LANG": "C.UTF-8",
                                    "HOME": str(folders["home"])})
            python, python_env = python_for(as_user)
            # The site config: only the keys it changes (docs/DEPLOYMENT.md), here fewer scenes
            # and one attract timeline so that a cold mesh cache builds in seconds.
            (base / "attract").mkdir()
            shutil.copy(REPO / "configs/attract/01-hypersphere.toml", base / "attract")
            site = base / "kiosk.toml"
            site.write_text('[content]\nscenes = ["hopf", "clifford-torus"]\n'
                            'start_scene = "hopf"\n\n[attract]\ntimelines = "attract"\n')
            for path in (site, *base.joinpath("attract").iterdir()):
                path.chmod(0o644)
            base.joinpath("attract").chmod(0o755)
            check = as_user.run(python + ["-m", "exhibit", "check-config", str(site)],
                                env=python_env)
            assert check.returncode == 0, check.stdout + check.stderr

            # The display: the unit's ExecStart= with its runtime folder moved here.
            runtime = "/run/" + kiosk_unit["RuntimeDirectory"][0]
            exec_start = kiosk_unit["ExecStart"][0].replace(runtime, str(folders["run"]))
            cage_env = dict(environment(kiosk_unit), WLR_BACKENDS="headless",
                            WLR_RENDERER="pixman", XDG_RUNTIME_DIR=str(folders["run"]))
            cage_argv = (sandbox(python, kiosk_unit, base, "kiosk")
                         + shlex.split(exec_start))
            if yes(kiosk_unit, "PrivateUsers"):
                cage_argv = user_namespace(as_user) + cage_argv
            cage_log = logs.enter_context(open(base / "cage.log", "w+"))
            t0 = time.monotonic()
            cage = subprocess.Popen(cage_argv, stdout=cage_log, stderr=subprocess.STDOUT,
                                    **as_user.kwargs(umask=int(kiosk_unit["UMask"][0], 8),
                                                     env=dict(cage_env, **python_env)))
            processes.append(cage)

            # The app: its Environment= with the folders moved here, after its ExecStartPre=.
            env = environment(app_unit)
            env.update(XDG_RUNTIME_DIR=str(folders["run"]),
                       EXHIBIT_STATE_DIR=str(folders["state"]),
                       EXHIBIT_CACHE_DIR=str(folders["cache"] / "meshes"),
                       XDG_CACHE_HOME=str(folders["cache"]), EXHIBIT_CONFIG=str(site),
                       **python_env)
            wait = app_unit["ExecStartPre"][0]
            assert wait.startswith("/bin/sh -c '") and wait.endswith("'")
            waited = as_user.run(["/bin/sh", "-c", wait[len("/bin/sh -c '"):-1]
                                  .replace("$$", "$")], timeout=30, env=env)
            t_socket = time.monotonic() - t0
            assert waited.returncode == 0, (waited.stderr, Path(base / "cage.log").read_text())

            notify = logs.enter_context(socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM))
            notify.bind(str(base / "notify"))
            os.chmod(base / "notify", 0o777)
            notify.settimeout(0.2)
            env["NOTIFY_SOCKET"] = str(base / "notify")
            assert app_unit["ExecStart"][0].endswith("/.venv/bin/exhibit run")
            app_argv = sandbox(python, app_unit, base, "app") + python + [
                "-m", "exhibit", "run", "--duration", str(RUN_S)]
            if yes(app_unit, "PrivateUsers"):
                app_argv = user_namespace(as_user) + app_argv
            app_log = logs.enter_context(open(base / "app.log", "w+"))
            t1 = time.monotonic()
            app = subprocess.Popen(app_argv, stdout=app_log, stderr=subprocess.STDOUT,
                                   **as_user.kwargs(umask=int(app_unit["UMask"][0], 8), env=env))
            processes.append(app)

            messages: list[str] = []

            def ready():
                with contextlib.suppress(TimeoutError):
                    messages.extend(notify.recv(4096).decode().splitlines())
                return "READY=1" in messages or app.poll() is not None
            wait_for(ready, 60, step=0)
            t_ready = time.monotonic() - t1
            health_file = folders["state"] / "health.json"
            health = wait_for(lambda: (h := read_health(health_file)) and h.get("frames")
                              and h, 10)
            # The first frame the compositor shows: grab until the output is not uniform.
            shot = folders["home"] / "frame.png"
            grim_env = {"XDG_RUNTIME_DIR": str(folders["run"]),
                        "WAYLAND_DISPLAY": env["WAYLAND_DISPLAY"]}

            last: dict = {}

            def grab() -> bool:
                last["grim"] = as_user.run(["grim", str(shot)], timeout=30, env=grim_env)
                if last["grim"].returncode != 0:
                    return True
                last["picture"] = np.asarray(Image.open(shot).convert("RGB"))
                return bool((last["picture"] != last["picture"][0, 0]).any()
                            or app.poll() is not None)
            wait_for(grab, RUN_S - 2, step=0.2)
            grabbed, picture = last["grim"], last.get("picture")
            t_visible = time.monotonic() - t1
            running = programs_of(user.pw_uid)
            code = app.wait(RUN_S + 60)
            with contextlib.suppress(TimeoutError):
                while True:
                    messages.extend(notify.recv(4096).decode().splitlines())
            last_health = read_health(health_file)
            app_log.seek(0)
            cage_log.seek(0)
            observed = {
                "code": code, "log": app_log.read(), "cage_log": cage_log.read(),
                "cage_alive": cage.poll() is None, "messages": messages, "health": health,
                "last_health": last_health, "grim": grabbed, "picture": picture,
                "t_socket": t_socket, "t_ready": t_ready, "t_visible": t_visible,
                "pid": app.pid, "running": running,
                "sandboxed": {"app": app_argv, "cage": cage_argv},
            }
            stop(cage)
        summary = {k: (last_health or {}).get(k) for k in ("fps", "frames", "frame_ms_p95")}
        print(f"\ncage's socket after {t_socket:.2f} s; the kiosk's READY=1 (first frame) "
              f"{t_ready:.2f} s after its start, on the screen after {t_visible:.2f} s; "
              f"health: {json.dumps(summary)}")
        yield observed
    finally:
        shutil.rmtree(base, ignore_errors=True)


def test_the_kiosk_starts_on_cage_and_reports_ready(kiosk_on_cage):
    seen = kiosk_on_cage
    assert seen["code"] == 0, seen["log"][-3000:]
    assert "READY=1" in seen["messages"], seen["log"][-3000:]
    assert seen["cage_alive"], seen["cage_log"][-2000:]
    assert seen["t_ready"] < 45
    status = [m for m in seen["messages"] if m.startswith("STATUS=")]
    assert status and " fps, attract, hopf; " in status[0]
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
    output, with its background gradient (lighter at the top) and many colours."""
    grabbed, picture = kiosk_on_cage["grim"], kiosk_on_cage["picture"]
    assert grabbed.returncode == 0, grabbed.stderr
    assert picture.shape == (OUTPUT[1], OUTPUT[0], 3)
    colours = len(np.unique(picture.reshape(-1, 3), axis=0))
    assert colours > 500, f"only {colours} colours: not the exhibit's picture"
    top = picture[:4, :8].astype(float).mean()
    bottom = picture[-4:, :8].astype(float).mean()
    assert top > bottom + 10 and top > 20, (top, bottom)  # the gradient, and not black


def test_it_ran_under_the_units_sandbox(kiosk_on_cage, staged):
    """The commands above really were wrapped: each unit's seccomp settings, and PrivateUsers=
    for the app where the kernel allows it."""
    app, cage = kiosk_on_cage["sandboxed"]["app"], kiosk_on_cage["sandboxed"]["cage"]
    assert "--syscalls" in app and "--families" in app and "--syscalls" in cage
    assert app[app.index("--errno") + 1] == "EPERM"
    assert "/usr/bin/cage" in cage
