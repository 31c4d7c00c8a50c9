"""`exhibit install [--root DIR] [--prefix DIR] [--dry-run]`: put the kiosk's systemd units, udev
rules, module list and kernel settings in place (docs/DEPLOYMENT.md).

The files come from systemd/ in this checkout with the install prefix (where the checkout and its
.venv live; /opt/exhibit by default) substituted. Run as root without --root it also does the
rest: creates the `exhibit` system user, loads the USB-serial modules, applies the kernel settings
(SysRq off), reloads udev and systemd, enables the units, and builds the mesh cache as the
service's user with the service's environment (`exhibit prepare`), so the first start draws at
once; it does not start the units, since the kiosk takes over tty1. With --root (staging an
image, or reviewing) or as another user it writes under DIR and prints the exact commands still
to run on the target. --dry-run writes and runs
nothing and says what it would do.

It never writes outside the root, nor over what is not a file: every target is checked before
anything is written, and a symlinked folder below the root (etc/ linked elsewhere), or a folder,
FIFO or device (or a link to one, such as a unit masked to /dev/null) at a target, stops it with
one line naming the path, having written nothing. "wrote PATH" is said once PATH is in place.

Why one module of this size: the install plan, its file table and its steps, which
docs/DEPLOYMENT.md and its test read as one."""

from __future__ import annotations

import argparse
import grp
import os
import pwd
import re
import shlex
import subprocess
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from exhibit.errors import ExhibitError
from exhibit.resources import shipped
from exhibit.schema.files import UnsafePath, check_target, read_regular, write_atomic

HELP = "install the kiosk's systemd units and udev rules (--root DIR to stage, --dry-run to look)"

DEFAULT_PREFIX = "/opt/exhibit"
USER = "exhibit"
HOME = "/var/lib/exhibit"
#: exhibit.service's CacheDirectory=, made for USER before `exhibit prepare` fills it
CACHE_ROOT = "/var/cache/exhibit"
#: Run by the venv's Python as USER: makes the speech cache's secret key in the state folder
#: (mode 0600) when there is none; exits 1 naming a key file it refuses.
SPEECH_KEY_MODULE = "exhibit.narration.make_cache_key"
#: exhibit.service's EnvironmentFile=, relative to the root
SITE_ENVIRONMENT = "etc/exhibit/environment"
#: the most the site's environment file may hold (a FIFO or a device there is refused)
MAX_ENVIRONMENT_BYTES = 1 << 16
#: the PATH systemd gives a service
SERVICE_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"
#: groups exhibit.service's SupplementaryGroups= names; a missing one stops the service (216/GROUP)
GROUPS = ("render", "video", "dialout")
SOURCE_DIR = shipped("systemd")
#: file in systemd/ -> where it goes, relative to the root
FILES = {
    "exhibit.service": "etc/systemd/system/exhibit.service",
    "exhibit-kiosk.service": "etc/systemd/system/exhibit-kiosk.service",
    "99-exhibit.rules": "etc/udev/rules.d/99-exhibit.rules",
    "exhibit-modules.conf": "etc/modules-load.d/exhibit.conf",
    "exhibit-sysctl.conf": "etc/sysctl.d/90-exhibit.conf",
    "exhibit-metrics.service": "etc/systemd/system/exhibit-metrics.service",
    "exhibit-metrics.timer": "etc/systemd/system/exhibit-metrics.timer",
}
#: The kiosk's two services (the display and the app).
UNITS = ("exhibit.service", "exhibit-kiosk.service")
START = "systemctl start exhibit.service exhibit-metrics.timer"
#: What `systemctl enable` gets: the kiosk, and the timer that refreshes its Prometheus metrics
#: (exhibit-metrics.service, run by the timer, is not enabled itself).
ENABLE = (*UNITS, "exhibit-metrics.timer")
# Folders the service cannot see (ProtectHome=, PrivateTmp=) or that do not survive a reboot.
_HIDDEN = ("/home", "/root", "/run/user", "/tmp", "/var/tmp", "/run")
_SAFE_PATH = re.compile(r"^/[A-Za-z0-9._+/-]*$")
#: What exhibit-kiosk.service needs on the machine: (program, Debian package, why).
_DISPLAY_PROGRAMS = (
    ("/usr/bin/cage", "cage", "exhibit-kiosk.service runs it"),
    ("/usr/bin/Xwayland", "xwayland", "Debian's cage exits at start without it"),
)


@dataclass
class Planned:
    """One file to write: where, what, and whether it is new, changed or already the same."""

    path: Path
    text: str
    state: str  # "new" | "changed" | "unchanged"


#: Set by `exhibit update` (and rollback) for the release's install: the cache was built before
#: the switch, so install builds it no second time, and the service is restarted next, so the
#: first install's "Start now" does not apply. An environment variable, not a flag: an older
#: release rolled back to does not know a new flag, and ignores the variable.
FOR_UPDATE_ENV = "EXHIBIT_INSTALL_FOR_UPDATE"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--root",
        metavar="DIR",
        help="write under this folder instead of / and only print the remaining "
        "steps (staging an image, or reviewing the files)",
    )
    parser.add_argument(
        "--prefix",
        default=DEFAULT_PREFIX,
        metavar="DIR",
        help=f"where the checkout and its .venv live on the kiosk (default "
        f"{DEFAULT_PREFIX}); ExecStart= is PREFIX/.venv/bin/exhibit run",
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="write and run nothing; show what would be written and run",
    )


def run(args: argparse.Namespace) -> int:
    prefix = check_prefix(args.prefix)
    if args.root == "":  # Path("") is ".": an empty variable in a script would stage into cwd
        raise ExhibitError(
            "--root '': give a folder to stage into, or leave --root out to install into /"
        )
    root = Path("/") if args.root is None else Path(args.root)
    if args.root is not None and not root.is_dir():
        raise ExhibitError(f"--root {root}: no such folder")
    perform = args.root is None and not args.dry_run
    if perform and os.geteuid() != 0:
        raise ExhibitError(
            f"installing into / needs root: sudo {prefix}/.venv/bin/exhibit "
            "install; or stage the files with --root DIR, or look with --dry-run"
        )
    return install(root, prefix, dry_run=args.dry_run, perform=perform)


def check_prefix(prefix: str) -> str:
    """The prefix as an absolute, normalised path the service can reach; ExhibitError if not."""
    text = str(prefix)
    if not text.startswith("/"):
        raise ExhibitError(f"--prefix {text!r}: must be an absolute path (e.g. {DEFAULT_PREFIX})")
    norm = os.path.normpath(text)
    if not _SAFE_PATH.match(norm):
        raise ExhibitError(
            f"--prefix {text!r}: use only letters, digits and . _ + - / (it is "
            "written into unit files unquoted)"
        )
    for hidden in _HIDDEN:
        if norm == hidden or norm.startswith(hidden + "/"):
            raise ExhibitError(
                f"--prefix {norm}: the service cannot use {hidden} (hidden by "
                f"its ProtectHome=/PrivateTmp=, or cleared at boot); use e.g. "
                f"{DEFAULT_PREFIX}"
            )
    if norm == "/":
        raise ExhibitError("--prefix /: give the folder of the checkout, e.g. /opt/exhibit")
    return norm


def render(text: str, prefix: str) -> str:
    """A shipped file with the default prefix replaced by ``prefix``."""
    return text.replace(DEFAULT_PREFIX, prefix)


def plan(root: Path, prefix: str, source: Path = SOURCE_DIR) -> list[Planned]:
    """The files to write under ``root``, rendered for ``prefix``, every target checked first:
    ExhibitError (nothing written) when any folder below the root is a symlink or not a folder,
    or when something at a target is not a regular file (a folder, FIFO, device, or a link to
    one: a unit masked by a link to /dev/null). Writing happens only when all of them can be."""
    planned, problems = [], []
    for name, dest in FILES.items():
        src = source / name
        try:
            text = render(src.read_text(encoding="utf-8"), prefix)
        except OSError as exc:
            raise ExhibitError(
                f"cannot read {src}: {exc.strerror or exc} (exhibit install works "
                "from a source checkout installed with pip install -e, as "
                "./bootstrap.sh does)"
            ) from None
        path = root / dest
        try:
            check_target(path, root=root)
        except UnsafePath as exc:
            problems.append(str(exc))
            continue
        except OSError as exc:
            problems.append(f"{path}: {exc.strerror or exc}")
            continue
        try:
            # a symlink there is replaced, not followed; a FIFO or device counts as changed
            old = read_regular(path, 1 << 20, follow=False)
        except FileNotFoundError:
            state = "new"
        except (OSError, ValueError):
            state = "changed"
        else:
            state = "unchanged" if old == text.encode("utf-8") else "changed"
        planned.append(Planned(path, text, state))
    if problems:
        unique = list(dict.fromkeys(problems))  # a symlinked etc/ is one problem, not seven
        more = f" (and {len(unique) - 1} more)" if len(unique) > 1 else ""
        raise ExhibitError(f"nothing written: {unique[0]}{more}")
    return planned


def write(
    planned: list[Planned], root: Path = Path("/"), out: Callable[[str], None] | None = None
) -> None:
    """Write each changed file atomically (mode 0644, fsynced) with
    :func:`exhibit.schema.files.write_atomic`, creating folders as needed but never following a
    symlink below ``root``; ``out`` hears "wrote PATH" once each file is in place."""
    done = 0
    for item in planned:
        if item.state == "unchanged":
            continue
        try:
            write_atomic(item.path, item.text, 0o644, root=root, make_folder=True)
        except OSError as exc:  # UnsafePath too: something changed since plan() looked
            why = str(exc) if isinstance(exc, UnsafePath) else exc.strerror or str(exc)
            written = f" ({done} file{'s' if done != 1 else ''} written before it)" if done else ""
            raise ExhibitError(f"cannot write {item.path}: {why}{written}") from None
        done += 1
        if out is not None:
            out(f"wrote {item.path} ({item.state})")


def unit_environment(text: str) -> list[str]:
    """The KEY=VALUE words of a unit's Environment= lines, in order."""
    words = []
    for line in text.splitlines():
        if line.startswith("Environment="):
            words += [w for w in shlex.split(line.split("=", 1)[1]) if "=" in w]
    return words


def environment_file(path: Path) -> list[str]:
    """The KEY=VALUE lines of a systemd EnvironmentFile (none when it does not exist, as the unit's
    ``-`` prefix allows); ExhibitError when it cannot be read: not UTF-8, over 64 KiB, or not a
    regular file (a FIFO would block the read forever, a device never end it)."""
    try:
        text = read_regular(path, MAX_ENVIRONMENT_BYTES).decode("utf-8")
    except FileNotFoundError:
        return []
    except (OSError, ValueError) as exc:  # NotAFile, TooLarge, UnicodeDecodeError
        raise ExhibitError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None
    words = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line[0] in "#;":
            continue
        try:
            word = " ".join(shlex.split(line))
        except ValueError:
            raise ExhibitError(f"{path}: cannot parse {line!r}") from None
        if "=" in word:
            words.append(word)
    return words


def service_environment(unit_text: str, site: list[str] | tuple = ()) -> list[str]:
    """The environment exhibit.service runs with: systemd's PATH, the user's HOME, the unit's
    Environment= and then the site's EnvironmentFile (later keys win, as in systemd)."""
    env = {"PATH": SERVICE_PATH, "HOME": HOME}
    for word in [*unit_environment(unit_text), *site]:
        key, _, value = word.partition("=")
        env[key] = value
    return [f"{key}={value}" for key, value in env.items()]


def as_service(exe: str, args: list[str], env: list[str]) -> list[str]:
    """``exe args`` as the service's user with exactly ``env`` (no trace of root's environment)."""
    return ["runuser", "-u", USER, "--", "env", "-i", *env, exe, *args]


def prepare_steps(exe: str, env: list[str]) -> list[list[str]]:
    """Build the mesh cache before a start: the cache folder for the user (systemd makes it only
    at the first start), everything already in it given to the user too (a check-config or an
    update run as root before the user existed left root's folders there, which the user could
    not write: "could not write the mesh cache ... Permission denied"; systemd's CacheDirectory=
    does the same at each start), then `exhibit prepare` as the user, with the service's
    environment."""
    return [
        ["install", "-d", "-o", USER, "-g", USER, "-m", "0755", CACHE_ROOT],
        ["chown", "-R", f"{USER}:{USER}", CACHE_ROOT],
        as_service(exe, ["prepare"], env),
    ]


def steps(
    need_user: bool = True,
    prefix: str = DEFAULT_PREFIX,
    site_env: list[str] | tuple = (),
    source: Path = SOURCE_DIR,
    prepare: bool = True,
    missing_groups: Sequence[str] = (),
) -> list[list[str]]:
    """The commands that finish an installation on the target, in order: first the groups of
    the unit's SupplementaryGroups= the machine lacks (as systemd-sysusers would make them: a
    minimal Debian without udev's rules has no `render`), the user; the last ones make the state
    folder and the speech cache's secret key in it (as the user, mode 0600, kept when there is
    one) and build the mesh cache, with ``site_env`` (the site's /etc/exhibit/environment) over
    the unit's (``prepare`` False: not, for an update that built it; a kiosk without a key
    makes one at its first narration)."""
    unit = render((source / "exhibit.service").read_text(encoding="utf-8"), prefix)
    env = service_environment(unit, site_env)
    commands: list[list[str]] = [["groupadd", "--system", group] for group in missing_groups]
    if need_user:
        commands.append(
            [
                "useradd",
                "--system",
                "--user-group",
                "--home-dir",
                HOME,
                "--no-create-home",
                "--shell",
                "/usr/sbin/nologin",
                "--comment",
                "exhibit kiosk",
                USER,
            ]
        )
    commands += [
        ["modprobe", "-a", "usbserial", "cdc_acm"],
        ["sysctl", "--system"],  # kernel.sysrq = 0 now; systemd-sysctl applies it at each boot
        ["udevadm", "control", "--reload"],
        [
            "udevadm",
            "trigger",
            "--action=add",
            "--subsystem-match=tty",
            "--subsystem-match=hidraw",
            "--subsystem-match=usb",
        ],
        ["systemctl", "daemon-reload"],
        ["systemctl", "enable", *ENABLE],
    ]
    if prepare:
        commands += [
            ["install", "-d", "-o", USER, "-g", USER, "-m", "0755", HOME],
            # a check-config or an update run as root before the user existed may have made
            # the key there as root: the service's user could not read it
            ["chown", "-R", f"{USER}:{USER}", HOME],
            as_service(f"{prefix}/.venv/bin/python", ["-I", "-m", SPEECH_KEY_MODULE], env),
            *prepare_steps(f"{prefix}/.venv/bin/exhibit", env),
        ]
    return commands


def _user_exists(name: str) -> bool:
    try:
        pwd.getpwnam(name)
    except KeyError:
        return False
    return True


def _group_exists(name: str) -> bool:
    try:
        grp.getgrnam(name)
    except KeyError:
        return False
    return True


def _run(command: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(command, capture_output=True, text=True)


def install(
    root: Path,
    prefix: str,
    dry_run: bool = False,
    perform: bool = False,
    out: Callable[[str], None] = print,
    runner: Callable = _run,
    user_exists: Callable[[str], bool] = _user_exists,
    group_exists: Callable[[str], bool] = _group_exists,
    source: Path = SOURCE_DIR,
    for_update: bool | None = None,
) -> int:
    """Write the files under ``root`` and, with ``perform``, run the remaining steps (the caller
    checks for root). Returns the exit code; ExhibitError for anything the user must fix.
    ``for_update`` (default: FOR_UPDATE_ENV set): no `exhibit prepare`, no start hint."""
    if for_update is None:
        for_update = os.environ.get(FOR_UPDATE_ENV) == "1"
    planned = plan(root, prefix, source)
    exe = Path(prefix) / ".venv" / "bin" / "exhibit"
    if perform:
        if not os.access(exe, os.X_OK):
            raise ExhibitError(
                f"{exe} does not exist: put the checkout at {prefix} and create "
                f"its venv first (cd {prefix} && PYTHON=/usr/bin/python3 "
                "./bootstrap.sh run --help), or give --prefix"
            )
        _check_interpreter(Path(prefix))
    for item in planned:
        if item.state == "unchanged":
            out(f"unchanged: {item.path}")
        elif dry_run:
            out(f"would write {item.path} ({item.state})")
    if not dry_run:
        write(planned, root, out)

    on_target = perform or root == Path("/")
    # Staging for another machine: whether its user exists cannot be known from here.
    todo = steps(
        need_user=not user_exists(USER) if on_target else True,
        missing_groups=[g for g in GROUPS if not group_exists(g)] if on_target else (),
        prefix=prefix,
        site_env=environment_file(root / SITE_ENVIRONMENT),
        source=source,
        prepare=not for_update,
    )
    if not perform:
        where = "as root" if on_target else "on the kiosk, as root"
        out(f"\n{'steps it would run' if dry_run and on_target else 'remaining steps'} ({where}):")
        for command in todo:
            out("  " + shlex.join(command))
        out(f"  {START}    # or reboot; takes over tty1")
        return 0

    for command in todo:
        out("$ " + shlex.join(command))
        try:
            result = runner(command)
        except OSError as exc:
            _failed(command, exc.strerror or str(exc), todo, out)
        if result.returncode != 0:
            lines = (result.stderr or result.stdout or "").strip().splitlines()
            _failed(command, lines[-1] if lines else f"exit code {result.returncode}", todo, out)
    for program, package, why in _DISPLAY_PROGRAMS:
        if not Path(program).exists():
            out(f"note: {program} is missing: apt-get install {package} ({why})")
    if for_update:
        out("installed (the mesh cache was built before the switch; the restart comes next)")
        return 0
    out(
        "\ninstalled and enabled. Start now (takes over tty1) or reboot:\n"
        f"  {START}\n"
        "then check: systemctl status exhibit; journalctl -u exhibit -b; exhibit status"
    )
    return 0


def _check_interpreter(prefix: Path) -> None:
    """ExhibitError when the venv's Python is a link into a folder the service cannot see: a venv
    made from an interpreter under /root or /home (pyenv, a hand-built Python) runs for root but
    not for the exhibit user (ProtectHome=, and /root is closed to other users): 203/EXEC."""
    python = prefix / ".venv" / "bin" / "python"
    real = os.path.realpath(python)
    if real.startswith(os.path.realpath(prefix) + "/"):
        return  # a copied interpreter (venv --copies), or none yet: nothing outside to reach
    for hidden in _HIDDEN:
        if real == hidden or real.startswith(hidden + "/"):
            raise ExhibitError(
                f"{python} is {real}, which the service cannot run ({hidden} is hidden from it "
                f"or not kept): make the venv from Debian's Python: rm -rf {prefix}/.venv && "
                f"cd {prefix} && PYTHON=/usr/bin/python3 ./bootstrap.sh run --help"
            )


def _failed(command: list[str], why: str, todo: list[list[str]], out) -> None:
    rest = todo[todo.index(command) :]
    out("the files are in place; run what is left by hand:")
    for c in rest:
        out("  " + shlex.join(c))
    raise ExhibitError(f"{shlex.join(command)} failed: {why}")
