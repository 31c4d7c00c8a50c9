"""Health that tells the truth (issue 40, item 4): a full or unwritable state folder is reported
as such (exit 5), not as a dead kiosk; exhibit_up follows the frames drawn; `exhibit status`
reads the service's file first and names the file, its owner and its age; the version and
release that run are in the file, the summary, --json and the metrics; skipped scenes are not
OK. The health file is written in place (exhibit.operations.health_file), so a full disk does
not stop it."""

from __future__ import annotations

import errno
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

import exhibit
from exhibit.cli import main
from exhibit.kiosk.frame_errors import FrameErrors, FrameStats
from exhibit.kiosk.reporting import Reporter
from exhibit.operations import health, health_file, prometheus, storage
from exhibit.operations.health import HealthError, read_health, write_health
from exhibit.schema import files
from tests.operations.support import fresh_fields

ROOT = Path(__file__).resolve().parents[2]


def sample(**changes) -> dict:
    data = {
        "time": time.time(),
        "pid": os.getpid(),
        "fps": 59.8,
        "mode": "attract",
        "scene": "hopf",
        "devices": [],
        "frames": 1000,
        "frame_errors": 0,
        "problems": [],
        "scenes_failed": [],
        **fresh_fields(),
    }
    data.update(changes)
    return data


def metrics_of(tmp_path: Path, path: Path) -> dict[tuple, float]:
    prom = tmp_path / "exhibit.prom"
    assert main(["status", "--file", str(path), "--prometheus", str(prom)]) == 0
    text = prom.read_text()
    if shutil.which("promtool"):
        checked = subprocess.run(
            ["promtool", "check", "metrics"], input=text, capture_output=True, text=True
        )
        assert checked.returncode == 0 and not checked.stdout.strip(), checked.stdout
    out = {}
    for line in text.splitlines():
        if line and not line.startswith("#"):
            key, value = line.rsplit(" ", 1)
            out[key] = float(value)
    return out


def report(reporter: Reporter, frames: int, sessions=None) -> None:
    reporter.report(
        time.monotonic(),
        stats=FrameStats(),
        frames=frames,
        errors=FrameErrors(),
        devices=[],
        state=None,
        problems=[],
        scenes_failed=[],
        language="en",
        sessions=sessions,
        governor=SimpleNamespace(health=lambda: {"quality": "direct"}),
    )


# ---------------------------------------------------------------------- the file, in place


def test_the_file_is_preallocated_json_with_a_checksum(tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample())
    info = path.stat()
    assert info.st_size >= health_file.MIN_FILE_BYTES
    assert info.st_blocks * 512 >= info.st_size  # every block allocated: not sparse
    raw = json.loads(path.read_text())  # still JSON, for jq
    assert set(raw) - set(sample()) == {"crc32"}
    assert not read_health(path).model_extra  # the checksum is the file's, not the data's


def test_a_full_disk_does_not_stop_the_health_file(tmp_path, monkeypatch):
    """Before: every write made a temporary file and renamed it, so on a full disk it failed
    (ENOSPC), the file went stale and status called the drawing kiosk dead."""
    path = tmp_path / "health.json"
    write_health(path, sample(scene="first"))
    inode = path.stat().st_ino

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files, "write_atomic", full)
    write_health(path, sample(scene="second", fps=12.5))
    assert read_health(path).scene == "second" and path.stat().st_ino == inode
    # Outgrown on a full disk: the numbers still fit, the long lists are left out.
    many = [f"scene s{i} skipped: {'x' * 300}" for i in range(200)]
    write_health(path, sample(scene="third", problems=many))
    data = read_health(path)
    assert data.scene == "third" and len(data.problems or []) == 5


def test_a_torn_read_is_read_again_and_a_damaged_file_is_broken(tmp_path, monkeypatch):
    path = tmp_path / "health.json"
    write_health(path, sample(scene="old"))
    old = path.read_bytes()
    write_health(path, sample(scene="new", fps=1.0))
    new = path.read_bytes()
    torn = new[:40] + old[40:]  # a reader caught the start of the new write
    reads = iter([torn, torn, new])
    monkeypatch.setattr(files, "read_regular", lambda p, limit: next(reads))
    assert read_health(path).scene == "new"
    monkeypatch.undo()
    damaged = bytearray(new)
    damaged[new.index(b"new")] = ord("N")  # valid JSON, wrong checksum
    path.write_bytes(bytes(damaged))
    with pytest.raises(HealthError, match="checksum does not match") as info:
        read_health(path)
    assert str(path) in str(info.value)


def test_a_file_without_a_checksum_is_read_as_before(tmp_path):
    path = tmp_path / "health.json"
    path.write_text('{"time": 5, "scene": "hopf"}')
    assert read_health(path).scene == "hopf"
    write_health(path, read_health(path))  # an older kiosk's small file: replaced, then in place
    assert path.stat().st_size >= health_file.MIN_FILE_BYTES


# ---------------------------------------------------------------------- a full state folder


def _full(real=os.statvfs):
    def statvfs(path):
        s = real(path)
        return os.statvfs_result(
            (s.f_bsize, s.f_frsize, s.f_blocks, 0, 0, s.f_files, s.f_ffree, 12, s.f_flag, 255)
        )

    return statvfs


def test_the_kiosk_reports_a_full_state_folder_and_status_exits_5(tmp_path, monkeypatch, capsys):
    """Before: STALE, exit 1, exhibit_up 0 while the kiosk drew; "No space left on device" only
    in the app's log."""
    path = tmp_path / "health.json"
    reporter = Reporter(None, path, time.monotonic())
    report(reporter, frames=10)
    monkeypatch.setattr(os, "statvfs", _full())
    writer = SimpleNamespace(errno="ENOSPC")
    sessions = SimpleNamespace(health=lambda: {"sessions": {"recording": True, "errno": "ENOSPC"}})
    assert writer.errno == "ENOSPC"
    report(reporter, frames=20, sessions=sessions)
    data = read_health(path)
    assert data.storage["problem"] == "full" and data.storage["errors"] == {"sessions": "ENOSPC"}
    assert main(["status", "--file", str(path)]) == 5
    out, err = capsys.readouterr()
    assert out.startswith("exhibit kiosk: STATE FOLDER FULL (updated ")
    assert err == (
        f"exhibit status: STATE FOLDER FULL: the state folder {tmp_path} is full (0 B free); "
        "failed writes: sessions (ENOSPC)\n"
    )
    assert f"storage   {tmp_path}: 0 B free, FULL; failed writes: sessions (ENOSPC)" in out
    got = metrics_of(tmp_path, path)
    assert got["exhibit_up"] == 1  # it draws
    assert got['exhibit_state_folder_problem{problem="full"}'] == 1
    assert got['exhibit_state_folder_problem{problem="read-only"}'] == 0
    assert got["exhibit_state_folder_free_bytes"] == 0


def test_a_failed_write_alone_says_which_problem():
    for name, problem in (("ENOSPC", "full"), ("EROFS", "read-only"), ("EACCES", "not writable")):
        found = storage.problem_in({"folder": "/s", "problem": None, "errors": {"sessions": name}})
        assert found == (
            problem,
            f"the state folder /s is {problem}; failed writes: sessions ({name})",
        )
    assert (
        storage.problem_in({"folder": "/s", "problem": None, "errors": {"journal": "EAGAIN"}})
        is None
    )
    full = sqlite3.OperationalError("database or disk is full")
    full.sqlite_errorcode = 13  # SQLITE_FULL
    assert storage.errno_name(storage.sqlite_errno(full)) == "ENOSPC"
    assert storage.sqlite_errno(OSError(errno.EROFS, "x")) == errno.EROFS


def test_a_stale_file_whose_kiosk_runs_on_a_read_only_disk_is_not_called_dead(
    tmp_path, monkeypatch, capsys
):
    """The kiosk cannot even update its file (EROFS): status sees its process run and the file
    system read-only, and says so with exit 5 instead of STALE."""
    path = tmp_path / "health.json"
    write_health(path, sample(time=time.time() - 300, last_frame=time.time() - 300))
    real = storage.check_folder

    def read_only(folder, writer=True):
        return {**real(folder, writer), "problem": "read-only"}

    monkeypatch.setattr(storage, "check_folder", read_only)
    assert main(["status", "--file", str(path)]) == 5
    err = capsys.readouterr().err
    assert err.startswith(f"exhibit status: STATE FOLDER READ-ONLY: the kiosk (pid {os.getpid()})")
    assert "cannot update its health file" in err and err.count("\n") == 1
    got = metrics_of(tmp_path, path)
    assert got['exhibit_health{status="unwritable"}'] == 1 and got["exhibit_up"] == 0
    assert got['exhibit_state_folder_problem{problem="read-only"}'] == 1
    # Its process gone: stale, as before, with the folder's state in the reason.
    write_health(path, sample(time=time.time() - 300, pid=2**22 + 12345))
    assert main(["status", "--file", str(path)]) == 1
    assert "STALE" in capsys.readouterr().err


def test_the_file_systems_own_read_only_state_comes_from_mountinfo():
    info = textwrap.dedent(
        """\
        22 1 8:1 / / rw,relatime shared:1 - ext4 /dev/sda1 rw,errors=remount-ro
        40 22 8:2 / /var/lib/exhibit rw,relatime shared:2 - ext4 /dev/sda2 ro,errors=remount-ro
        41 22 8:3 / /srv ro,relatime shared:3 - ext4 /dev/sda3 rw
        """
    )
    assert storage.filesystem_read_only("/var/lib/exhibit/x", info) is True
    assert storage.filesystem_read_only("/var/lib/exhibitx", info) is False
    assert storage.filesystem_read_only("/srv", info) is False  # a read-only view only


def test_a_really_full_tmpfs(tmp_path):
    """The same on a real full file system: a 1 MiB tmpfs in a mount namespace of its own
    (unshare -rm; skipped where that is not allowed), filled to the last block."""
    if shutil.which("unshare") is None:
        pytest.skip("no unshare")
    probe = subprocess.run(
        ["unshare", "-rm", "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {tmp_path}"],
        capture_output=True,
    )
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {probe.stderr.decode()[:200]}")
    script = tmp_path.parent / f"{tmp_path.name}-full.py"
    script.write_text(FULL_DISK_SCRIPT)
    state = tmp_path / "state"
    state.mkdir()
    result = subprocess.run(
        [
            "unshare",
            "-rm",
            "sh",
            "-c",
            'mount -t tmpfs -o size=1m tmpfs "$1" && exec "$2" "$3" "$1"',
            "sh",
            str(state),
            sys.executable,
            str(script),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    out = json.loads(result.stdout.splitlines()[-1])
    assert out["exit"] == 5, out
    assert out["stderr"].startswith(f"exhibit status: STATE FOLDER FULL: the state folder {state}")
    assert "sessions (ENOSPC)" in out["stderr"]
    assert out["frames"] == 2 and out["up"] is True
    # Nothing lost: the session the full disk refused waited, and was written once it emptied
    # (before: counted as failed and gone).
    assert out["waiting"] >= 1 and out["failed"] == 0, out
    assert out["left"] == 0 and out["written"] == out["submitted"], out


FULL_DISK_SCRIPT = """
import errno, json, os, subprocess, sys, time
from pathlib import Path
from types import SimpleNamespace
from exhibit.kiosk.frame_errors import FrameErrors, FrameStats
from exhibit.kiosk.reporting import Reporter
from exhibit.operations.sessions import SessionLog
from exhibit.operations.sessions.session import Session
from exhibit.operations.sessions.writer import SessionWriter

state = Path(sys.argv[1])
writer = SessionWriter(state / "sessions.db")
assert writer.ready.wait(60) and writer.usable, writer.reason
reporter = Reporter(None, state / "health.json", time.monotonic())

def report(frames):
    reporter.report(time.monotonic(), stats=FrameStats(), frames=frames, errors=FrameErrors(),
        devices=[], state=None, problems=[], scenes_failed=[], language="en",
        sessions=SessionLog(writer), governor=SimpleNamespace(health=lambda: {}))

report(1)
fd = os.open(state / "filler", os.O_WRONLY | os.O_CREAT)
try:
    while True:
        os.write(fd, b"x" * 4096)
except OSError as exc:
    assert exc.errno == errno.ENOSPC, exc
for i in range(50):  # until SQLite needs a page it cannot have
    now = time.time()
    writer.submit(Session(start=now, end=now, duration_s=1.0, active_s=1.0, utc_offset_s=0,
                          scenes=["hopf"] * 50, inputs=["knob"] * 50))
    for _ in range(600):
        if writer.written + writer.failed + len(writer.backlog) > i:
            break
        time.sleep(0.05)
    if writer.backlog:
        break
submitted = i + 1
report(2)
status = subprocess.run([sys.executable, "-m", "exhibit", "status", "--file",
                         str(state / "health.json"), "--json"], capture_output=True, text=True)
data = json.loads(status.stdout)
status_text = subprocess.run([sys.executable, "-m", "exhibit", "status", "--file",
                              str(state / "health.json")], capture_output=True, text=True)
waiting = len(writer.backlog)
os.close(fd)
os.unlink(state / "filler")  # the disk empties: the waiting sessions are written
for _ in range(600):
    if not writer.backlog:
        break
    time.sleep(0.05)
print(json.dumps({"exit": status.returncode, "stderr": status_text.stderr,
                  "frames": data["frames"], "up": data["up"], "failed": writer.failed,
                  "waiting": waiting, "submitted": submitted, "written": writer.written,
                  "left": len(writer.backlog)}))
"""


# ---------------------------------------------------------------------- frames drawn


def test_exhibit_up_follows_the_frames_drawn(tmp_path, capsys):
    """Before: exhibit_up 1 whenever the file was fresh, frames drawn or not."""
    path = tmp_path / "health.json"
    write_health(path, sample(last_frame=time.time() - 40))
    assert main(["status", "--file", str(path)]) == 1
    out, err = capsys.readouterr()
    assert out.startswith("exhibit kiosk: NOT DRAWING")
    assert err.startswith("exhibit status: NOT DRAWING: no frame drawn for 40")
    got = metrics_of(tmp_path, path)
    assert got["exhibit_up"] == 0 and got['exhibit_health{status="not_drawing"}'] == 1
    assert got["exhibit_frames_total"] == 1000  # the file is fresh: its numbers are current
    write_health(path, sample(last_frame=None))
    assert main(["status", "--file", str(path)]) == 1
    assert "no frame drawn since the kiosk started" in capsys.readouterr().err
    old = sample()
    del old["last_frame"]  # an older kiosk's file: by its freshness, as before
    write_health(path, old)
    assert metrics_of(tmp_path, path)["exhibit_up"] == 1


def test_the_kiosk_records_when_it_last_drew(tmp_path, monkeypatch):
    path = tmp_path / "health.json"
    reporter = Reporter(None, path, time.monotonic())
    clock = iter([1000.0, 1001.0, 1002.0])
    monkeypatch.setattr(time, "time", lambda: next(clock))
    report(reporter, frames=0)
    assert read_health(path).last_frame is None
    report(reporter, frames=5)
    assert read_health(path).last_frame == 1001.0
    report(reporter, frames=5)  # every frame failed since
    data = read_health(path)
    assert data.last_frame == 1001.0 and data.time == 1002.0


# ---------------------------------------------------------------------- which file, whose


def test_status_reads_the_services_file_before_its_own_and_names_both(
    tmp_path, monkeypatch, capsys
):
    """Before: root's own ~/.local/state/exhibit/health.json (a kiosk once run by hand) hid
    the service's /var/lib/exhibit/health.json."""
    service = tmp_path / "var-lib-exhibit"
    service.mkdir()
    write_health(service / "health.json", sample(scene="service"))
    home = tmp_path / "home"
    write_health(home / "exhibit" / "health.json", sample(scene="mine", time=time.time() - 1e6))
    monkeypatch.setattr(health, "SERVICE_STATE_DIR", service)
    monkeypatch.delenv("EXHIBIT_STATE_DIR", raising=False)
    monkeypatch.setenv("XDG_STATE_HOME", str(home))
    assert main(["status"]) == 0
    out = capsys.readouterr().out
    assert "scene     service" in out
    owner = __import__("pwd").getpwuid(os.getuid()).pw_name
    assert f"file      {service / 'health.json'} (owner {owner}, modified 0." in out
    assert f"also {home / 'exhibit' / 'health.json'} (read it with --file)" in out
    assert main(["status", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["path"] == str(service / "health.json") and data["owner"] == owner
    assert 0 <= data["file_age_s"] < 3600
    (service / "health.json").unlink()
    assert main(["status", "--max-age", "1e7"]) == 0  # no service file: the user's own
    assert "scene     mine" in capsys.readouterr().out


def test_a_broken_file_is_named_with_its_owner_and_age(tmp_path, capsys):
    path = tmp_path / "health.json"
    path.write_text("{")
    assert main(["status", "--file", str(path)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"exhibit status: BROKEN: {path}: not valid JSON")
    assert "(owner " in err and " ago)" in err and err.count("\n") == 1


# ---------------------------------------------------------------------- version and release


def test_the_version_and_release_are_reported_everywhere(tmp_path, capsys):
    path = tmp_path / "health.json"
    report(Reporter(None, path, time.monotonic()), frames=1)
    data = read_health(path)
    assert data.version == exhibit.__version__
    assert data.release == storage.build_info()["release"]
    write_health(path, sample())
    assert main(["status", "--file", str(path)]) == 0
    assert "version   0.1.0 (release 0.1.0-20250601T120000Z)" in capsys.readouterr().out
    assert main(["status", "--file", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["version"], data["release"]) == ("0.1.0", "0.1.0-20250601T120000Z")
    got = metrics_of(tmp_path, path)
    assert got['exhibit_build_info{release="0.1.0-20250601T120000Z",version="0.1.0"}'] == 1


@pytest.mark.parametrize("inside", ["exhibit", ".venv/lib/python3.11/site-packages/exhibit"])
def test_the_release_is_the_folder_the_prefix_links_to(tmp_path, monkeypatch, inside):
    release = tmp_path / "exhibit-releases" / "0.2.0-20250601T120000Z"
    (release / inside).mkdir(parents=True)
    (release / inside / "__init__.py").write_text("")
    (tmp_path / "exhibit").symlink_to("exhibit-releases/0.2.0-20250601T120000Z")
    monkeypatch.setattr(exhibit, "__file__", str(tmp_path / "exhibit" / inside / "__init__.py"))
    storage.build_info.cache_clear()
    try:
        assert storage.build_info() == {
            "version": exhibit.__version__,
            "release": "0.2.0-20250601T120000Z",
        }
        checkout = tmp_path / "checkout"
        (checkout / inside).mkdir(parents=True)
        monkeypatch.setattr(exhibit, "__file__", str(checkout / inside / "__init__.py"))
        storage.build_info.cache_clear()
        assert storage.build_info()["release"] == str(checkout)
    finally:
        monkeypatch.undo()
        storage.build_info.cache_clear()


def test_every_metrics_family_has_help_for_the_new_statuses():
    assert {"not_drawing", "unwritable"} <= set(prometheus.HEALTH_STATUSES)
    assert prometheus.FOLDER_PROBLEMS == ("full", "read-only", "not writable")
