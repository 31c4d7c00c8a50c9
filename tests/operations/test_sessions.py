"""What visitors do (exhibit.operations.sessions, `exhibit stats`): a visitor session recorded
through the kiosk's state machine and its frame loop and reported by `exhibit stats --json`; the
database surviving SIGKILL in the middle of writes; rotation; broken files moved aside; the
writer never blocking a frame; the stats arithmetic against hand-computed values; the plot."""

from __future__ import annotations

import json
import logging
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.devices.base import Event, Kind
from exhibit.devices.config import parse_config
from exhibit.devices.mapping import Mapper
from exhibit.operations import sessions as sessions_module
from exhibit.operations.sessions import store as sessions_store, writer as sessions_writer
from exhibit.timelines.playlist import Playlist
from exhibit.kiosk.config import ConfigError, load_kiosk_config
from exhibit.operations.sessions import (
    Session,
    SessionLog,
    SessionStore,
    SessionWriter,
    input_name,
    read_sessions,
)
from exhibit.kiosk.state import ATTRACT, VISITOR, KioskState
from tests.kiosk.support import DEVICES, TIMELINE, edit, numbered

ROOT = Path(__file__).resolve().parents[2]
#: 2026-11-30 10:00:00 UTC
NOON_ISH = 1796032800.0


def report(capsys, db: Path, *more: str) -> dict:
    capsys.readouterr()
    assert main(["stats", "--db", str(db), "--json", *more]) == 0
    return json.loads(capsys.readouterr().out)


def session(
    start: float,
    duration: float,
    scenes=("hopf",),
    inputs=("knobs.knob",),
    offset: int = 0,
    active: float | None = None,
    language: str = "en",
) -> Session:
    return Session(
        start,
        start + duration,
        duration,
        duration / 2 if active is None else active,
        offset,
        language,
        list(scenes),
        list(inputs),
    )


# ---------------------------------------------------------------------- a visitor, end to end


@pytest.fixture
def state(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text(TIMELINE)
    from exhibit import scenes
    from exhibit.timelines.file import load_timeline

    config = parse_config(tomllib.loads(DEVICES), "<test>")
    return KioskState(
        Playlist([load_timeline(path, scenes.get)]),
        Mapper(config.mapping),
        ("hopf", "collision"),
        idle_timeout_s=30.0,
        blend_s=2.0,
        now=0.0,
    )


def test_a_visitor_session_through_the_state_machine_is_reported_by_stats(tmp_path, state, capsys):
    """Attract, a knob takes over, a button to the next scene, a stick too small to count,
    then 30 s idle: one session, 100 s to 135.5 s on the kiosk clock, active until 105 s."""
    db = tmp_path / "sessions.db"
    wall = [NOON_ISH]
    writer = SessionWriter(db, wall=lambda: wall[0])
    recorder = SessionLog(writer, wall=lambda: wall[0])
    script = {
        100.0: [Event(100.0, "knobs", Kind.REL, 0, 1.0)],
        102.0: [Event(102.0, "knobs", Kind.BUTTON, 5, 1.0)],
        103.0: [
            Event(103.0, "knobs", Kind.BUTTON, 5, 0.0),
            Event(103.0, "controller", Kind.ABS, 0, 0.1),
        ],
        105.0: [Event(105.0, "knobs", Kind.REL, 0, -2.0)],
    }
    modes = []
    for i in range(0, 1400):
        now = i * 0.1
        wall[0] = NOON_ISH + now
        events = script.get(round(now, 1), [])
        frame = state.update(events, now)
        recorder.observe(frame.mode, frame.scene, events, now)
        if not modes or modes[-1] != frame.mode:
            modes.append(frame.mode)
    assert modes == [ATTRACT, VISITOR, ATTRACT]
    writer.close()
    assert writer.written == 1 and writer.dropped == writer.failed == 0

    out = report(capsys, db)
    assert out["sessions"] == 1
    assert out["median_s"] == pytest.approx(35.1, abs=0.11)  # idle return 30 s after 105 s
    assert out["median_active_s"] == pytest.approx(5.0)
    assert [s["name"] for s in out["scenes"]] == ["collision", "hopf"]
    assert {i["name"] for i in out["inputs"]} == {"knobs.knob", "knobs.button"}
    assert out["languages"] == [{"name": "en", "sessions": 1}]
    stored = read_sessions(db)[0]
    assert stored.scenes == ["hopf", "collision"]  # in the order shown
    assert stored.start == pytest.approx(NOON_ISH + 100.0)
    offset = time.localtime(NOON_ISH + 100).tm_gmtoff
    assert out["per_hour"][int((NOON_ISH + 100 + offset) // 3600) % 24] == 1


def test_the_kiosk_frame_loop_records_sessions(tmp_path, monkeypatch, capsys):
    """The real Kiosk (fake window and clock, as in test_survival): keys take over, n switches
    scene, the idle return (5 s) ends the session; a second visitor still there when the loop
    stops has their session ended then."""
    from tests.kiosk.support import kiosk

    k, _ = kiosk(tmp_path, monkeypatch)
    db = tmp_path / "state" / "sessions.db"
    writer = SessionWriter(db)
    k.sessions = SessionLog(writer)
    keyboard = k.devices.keyboard

    def frames(n):
        for _ in range(n):
            assert k.tick(k.clock())

    frames(10)
    assert k.state.mode == ATTRACT and k.sessions.current is None
    keyboard.key("q", True)
    frames(5)
    assert k.state.mode == VISITOR and k.sessions.current is not None
    keyboard.key("q", False)
    keyboard.key("n", True)
    frames(2)
    keyboard.key("n", False)
    frames(60)  # 0.2 s a frame: 12 s, past the 5 s idle timeout
    assert k.state.mode == ATTRACT and k.sessions.current is None
    keyboard.key("w", True)  # a second visitor
    assert k.run(max_frames=3) == 0  # run() ends: so does the session; the writer finishes
    assert writer.written == 2
    rows = read_sessions(db)
    assert rows[0].scenes == ["hopf", "clifford-torus"]
    assert rows[0].inputs == [f"{keyboard.name}.stick", f"{keyboard.name}.button"]
    assert 5.0 <= rows[0].duration_s <= 8.0 and rows[0].active_s < 3.0
    assert rows[1].duration_s < 2.0  # 3 frames of the fake clock
    assert report(capsys, db)["sessions"] == 2


@pytest.mark.slow
def test_a_real_kiosk_run_is_reported_by_stats(tmp_path, cli):
    """`exhibit run` in a window under Xvfb, the simulated controller's stick pushed for 1.5 s
    after 2 s of attract mode, the idle return 5 s later; then `exhibit stats --json` on the
    database the kiosk wrote in its state folder."""
    from tests.kiosk.support import make_config
    from tests.xvfb import unavailable, xvfb

    kiosk = make_config(tmp_path, "wait 2\naxes 0.9 0 0 0 0 0\nwait 1.5\naxes 0 0 0 0 0 0\n")
    state = tmp_path / "state"
    with xvfb("320x240x24") as display:
        env = dict(
            os.environ,
            DISPLAY=display,
            EXHIBIT_CACHE_DIR=str(tmp_path / "cache"),
            EXHIBIT_STATE_DIR=str(state),
        )
        env.pop("NOTIFY_SOCKET", None)
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "exhibit",
                "run",
                "--config",
                str(kiosk),
                "--windowed",
                "--duration",
                "12",
            ],
            env=env,
            capture_output=True,
            text=True,
            timeout=240,
            cwd=ROOT,
        )
    if result.returncode != 0 and "cannot start GLFW" in result.stderr:
        unavailable("no GLFW window on Xvfb")
    assert result.returncode == 0, result.stderr[-3000:]
    out = cli("stats", "--db", str(state / "sessions.db"), "--json")
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert report["sessions"] == 1
    assert report["scenes"] == [{"name": "hopf", "sessions": 1}]
    assert report["inputs"] == [{"name": "controller.stick", "sessions": 1}]
    assert 5.0 <= report["median_s"] <= 9.0 and report["median_active_s"] < 3.0


def test_input_names_count_real_use_only():
    assert input_name(Event(0, "knobs", Kind.REL, 0, 2.0)) == "knobs.knob"
    assert input_name(Event(0, "knobs", Kind.REL, 0, 0.0)) is None
    assert input_name(Event(0, "controller", Kind.BUTTON, 1, 1.0)) == "controller.button"
    assert input_name(Event(0, "controller", Kind.BUTTON, 1, 0.0)) is None  # a release
    assert input_name(Event(0, "controller", Kind.ABS, 2, -0.8)) == "controller.stick"
    assert input_name(Event(0, "controller", Kind.ABS, 2, 0.3)) is None  # noise, drift


def test_the_stored_columns_hold_no_personal_data(tmp_path):
    store = SessionStore(tmp_path / "s.db").open()
    columns = [r[1] for r in store.db.execute("PRAGMA table_info(sessions)")]
    store.close()
    assert columns == [
        "id",
        "start",
        "end",
        "duration_s",
        "active_s",
        "utc_offset_s",
        "language",
        "scenes",
        "inputs",
    ]


# ---------------------------------------------------------------------- off the frame path


def test_a_stalled_disk_never_blocks_a_frame(tmp_path, monkeypatch, caplog):
    """The writer hangs inside its first write: the frame thread's calls still return at once,
    the queue fills, and the overflow is dropped and counted (a few log lines, not one each)."""
    entered, release = threading.Event(), threading.Event()
    real_add = SessionStore.add

    def stuck(self, s):
        entered.set()
        release.wait(120)  # longer than the frames are given below
        return real_add(self, s)

    monkeypatch.setattr(SessionStore, "add", stuck)
    writer = SessionWriter(tmp_path / "s.db", queue_size=8)
    assert writer.ready.wait(5) and writer.usable
    recorder = SessionLog(writer)
    recorder.observe(VISITOR, "hopf", [], 0.0)
    recorder.observe(ATTRACT, "hopf", [], 0.5)
    assert entered.wait(5)  # the writer is inside its first write, and stays there

    def frames():
        for i in range(1, 200):
            recorder.observe(VISITOR, "hopf", [Event(i, "knobs", Kind.REL, 0, 1.0)], float(i))
            recorder.observe(ATTRACT, "hopf", [], i + 0.5)

    # The frames run to the end while the write is still stuck: not one of them waited for it
    # (one that did would wait for `release`, which comes only after this check).
    with caplog.at_level(logging.WARNING, logger="exhibit.operations.sessions"):
        loop = threading.Thread(target=frames, daemon=True)
        loop.start()
        loop.join(timeout=30)
    if loop.is_alive():
        release.set()
        pytest.fail("a frame waited for the stuck write")
    assert writer.dropped == 200 - 8 - 1  # 8 queued, 1 inside the stuck write
    assert len(caplog.records) == 8  # the 1st, 2nd, 4th, ... 128th dropped
    release.set()
    writer.close()
    assert writer.written == 9 and SessionStore(tmp_path / "s.db").open().count() == 9


def test_a_recorder_bug_is_logged_once_and_never_reaches_the_frame(caplog):
    class Broken:
        def submit(self, s):
            raise RuntimeError("bug")

    recorder = SessionLog(Broken())
    with caplog.at_level(logging.ERROR, logger="exhibit.operations.sessions"):
        for i in range(10):
            recorder.observe(VISITOR, "hopf", [], float(i))
            recorder.observe(ATTRACT, "hopf", [], i + 0.5)
    assert caplog.text.count("the recorder failed") == 1


def test_an_unwritable_place_turns_recording_off_with_one_line(tmp_path, caplog):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with caplog.at_level(logging.WARNING, logger="exhibit.operations.sessions"):
        writer = SessionWriter(blocker / "sessions.db")
        recorder = SessionLog(writer)
        recorder.observe(VISITOR, "hopf", [], 0.0)
        recorder.close(1.0)
    assert not writer.usable and writer.failed == 1
    assert caplog.text.count("cannot open") == 1 and "not recorded" in caplog.text


# ---------------------------------------------------------------------- survives SIGKILL

CHILD = r"""
import sys, time
from exhibit.operations.sessions import Session, SessionLog, SessionWriter
from tests.kiosk.support import numbered

def committed(session, row):
    sys.stdout.write(f"{row} {session.start:.0f}\n")
    sys.stdout.flush()

writer = SessionWriter(sys.argv[1], on_commit=committed, queue_size=64)
i, base = int(sys.argv[2]), float(sys.argv[3])
while True:
    if writer.submit(numbered(i, base)):
        i += 1
    else:
        time.sleep(0.0005)
"""


def test_the_database_survives_sigkill_in_the_middle_of_writes(tmp_path):
    """Two rounds: a child writes sessions as fast as it can and is killed with SIGKILL after
    an uneven number of commits (past the 1000-page WAL checkpoint in the second round); each
    time the file passes integrity_check and every session the child saw committed is there,
    intact."""
    db = tmp_path / "sessions.db"
    seen: dict[int, int] = {}
    start, base = 0, float(int(time.time()) - 86400)
    for kill_after in (337, 1789):
        child = subprocess.Popen(
            [sys.executable, "-c", CHILD, str(db), str(start), str(base)],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            text=True,
        )
        watchdog = threading.Timer(60, child.kill)  # a child that hangs fails, not blocks
        watchdog.start()
        try:
            for _ in range(kill_after):
                line = child.stdout.readline()
                assert line, "the child stopped writing"
                row, start_s = line.split()
                seen[int(row)] = int(start_s)
        finally:
            os.kill(child.pid, signal.SIGKILL)
            child.wait(10)
            watchdog.cancel()
            child.stdout.close()
        assert child.returncode == -signal.SIGKILL
        with sqlite3.connect(db) as con:
            assert con.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
            rows = {
                r[0]: r[1:]
                for r in con.execute(
                    "SELECT id, start, end, duration_s, active_s, utc_offset_s, language, scenes, "
                    "inputs FROM sessions"
                )
            }
        con.close()
        for row, start_s in seen.items():
            expected = numbered(int(start_s - base), base).row()
            assert rows.get(row) == expected, f"committed session {row} lost or changed"
        start = max(int(s - base) for s in seen.values()) + 1
    assert len(seen) == 337 + 1789


# ---------------------------------------------------------------------- rotation


def test_rotation_by_age_and_by_count_at_open(tmp_path):
    db = tmp_path / "s.db"
    now = NOON_ISH
    store = SessionStore(db, keep_days=30, max_sessions=1000, wall=lambda: now).open()
    for day in range(60):  # one session a day for 60 days, the oldest first
        store.add(session(now - (59 - day) * 86400 - 60, 30))
    assert store.rotate() == 30  # older than 30 days: those 30..59 days (and a minute) ago
    assert store.count() == 30
    store.close()
    store = SessionStore(db, keep_days=30, max_sessions=10, wall=lambda: now).open()
    assert store.count() == 10  # at open: the newest 10
    newest = [s.start for s in read_sessions(db)]
    assert newest == sorted(newest) and newest[-1] == now - 60
    store.close()


def test_rotation_shrinks_the_file_and_runs_while_writing(tmp_path, monkeypatch):
    """Sessions beyond max_sessions go every ROTATE_EVERY writes, and the file gives the space
    back (incremental auto-vacuum): it is bounded, not just reused."""
    monkeypatch.setattr(sessions_writer, "ROTATE_EVERY", 500)
    db = tmp_path / "s.db"
    store = SessionStore(db, max_sessions=10_000_000).open()
    for i in range(5000):
        store.add(numbered(i))
    store.db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    big = db.stat().st_size
    store.close()
    writer = SessionWriter(db, max_sessions=100)
    for i in range(5000, 6200):
        while not writer.submit(numbered(i)):
            time.sleep(0.001)
    writer.close()
    with sqlite3.connect(db) as con:
        count = con.execute("SELECT count(*) FROM sessions").fetchone()[0]
    con.close()
    assert count == 300  # 100 after the open, again after 500 and 1000 writes, then 200 more
    assert db.stat().st_size < big / 4, (big, db.stat().st_size)


# ---------------------------------------------------------------------- broken files


def test_a_file_that_is_no_database_is_moved_aside_and_a_fresh_one_started(tmp_path, caplog):
    db = tmp_path / "sessions.db"
    db.write_bytes(b"this is not SQLite" * 100)
    with caplog.at_level(logging.WARNING, logger="exhibit.operations.sessions"):
        writer = SessionWriter(db)
        writer.submit(session(NOON_ISH, 10))
        writer.close()
    assert writer.written == 1 and len(caplog.records) == 1
    assert "moved aside" in caplog.text
    aside = list(tmp_path.glob("sessions.db.corrupt-*"))
    assert len(aside) == 1 and aside[0].read_bytes() == b"this is not SQLite" * 100
    assert len(read_sessions(db)) == 1


def test_a_database_with_damaged_pages_is_moved_aside(tmp_path):
    db = tmp_path / "sessions.db"
    store = SessionStore(db).open()
    for i in range(2000):
        store.add(numbered(i))
    store.db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    store.close()
    with open(db, "r+b") as f:  # scribble over pages in the middle of the table
        f.seek(20 * 4096)
        f.write(os.urandom(8 * 4096))
    store = SessionStore(db).open()
    assert len(store.moved_aside) == 1 and store.count() == 0
    store.add(numbered(1))
    store.close()


@pytest.mark.parametrize("kind", ["fifo", "folder", "newer", "other"])
def test_other_unusable_files_are_moved_aside_without_hanging(tmp_path, kind):
    db = tmp_path / "sessions.db"
    if kind == "fifo":
        os.mkfifo(db)
    elif kind == "folder":
        db.mkdir()
    else:
        with sqlite3.connect(db) as con:
            if kind == "newer":
                con.executescript("CREATE TABLE sessions (x); PRAGMA user_version = 99;")
            else:
                con.execute("CREATE TABLE photos (face BLOB)")
        con.close()
    store = SessionStore(db).open()
    assert len(store.moved_aside) == 1 and store.count() == 0
    store.close()


def test_only_the_last_few_moved_aside_files_are_kept(tmp_path):
    db = tmp_path / "sessions.db"
    for i in range(6):
        db.write_bytes(b"garbage %d" % i)
        store = SessionStore(db, wall=lambda i=i: NOON_ISH + i).open()
        store.close()
    assert len(list(tmp_path.glob("sessions.db.corrupt-*"))) == sessions_store.KEEP_ASIDE


# ---------------------------------------------------------------------- the arithmetic


def test_stats_arithmetic_against_hand_computed_values(tmp_path, capsys):
    """Four sessions, hand-placed: lengths 10, 20, 30 and 400 s (median 25 s); local hours and
    days from each session's own UTC offset."""
    day = 1796083200.0  # 2026-12-01 00:00 UTC
    db = tmp_path / "s.db"
    store = SessionStore(db, wall=lambda: day + 86400).open()
    for s in [
        session(day - 1800, 10, ("hopf",), ("knobs.knob",), offset=3600),  # 12-01 00:30 local
        session(day + 9 * 3600, 20, ("hopf", "collision"), ("controller.stick",)),  # 09:00
        session(day + 9 * 3600 + 3599, 30, ("collision",), ("controller.stick",)),  # 09:59
        session(
            day + 2 * 86400 + 17 * 3600,
            400,
            ("veronese", "hopf"),
            ("controller.stick", "knobs.knob"),
            active=100,
            language="de",
        ),  # 12-03 17:00
    ]:
        store.add(s)
    store.close()
    out = report(capsys, db)
    assert out["sessions"] == 4
    assert out["median_s"] == 25.0
    assert out["median_active_s"] == 12.5  # of 5, 10, 15 and 100
    assert out["per_day"] == [
        {"date": "2026-12-01", "sessions": 3},
        {"date": "2026-12-02", "sessions": 0},
        {"date": "2026-12-03", "sessions": 1},
    ]
    expected = [0] * 24
    expected[0], expected[9], expected[17] = 1, 2, 1
    assert out["per_hour"] == expected
    assert out["scenes"] == [
        {"name": "hopf", "sessions": 3},
        {"name": "collision", "sessions": 2},
        {"name": "veronese", "sessions": 1},
    ]
    assert out["inputs"][0] == {"name": "controller.stick", "sessions": 3}
    assert out["languages"] == [{"name": "en", "sessions": 3}, {"name": "de", "sessions": 1}]
    later = report(capsys, db, "--since", "2026-12-02")
    assert later["sessions"] == 1 and later["since"] == "2026-12-02"
    assert later["median_s"] == 400.0


def test_no_sessions_is_a_report_too(tmp_path, capsys):
    SessionStore(tmp_path / "s.db").open().close()
    out = report(capsys, tmp_path / "s.db")
    assert out["sessions"] == 0 and out["median_s"] is None and out["per_hour"] == [0] * 24
    assert main(["stats", "--db", str(tmp_path / "s.db")]) == 0
    assert "0 visitor sessions" in capsys.readouterr().out


def test_the_plot_is_a_png(tmp_path, capsys):
    from PIL import Image

    db = tmp_path / "s.db"
    store = SessionStore(db, wall=lambda: NOON_ISH).open()
    for i in range(40):
        store.add(session(NOON_ISH - i * 3 * 3600, 60 + i))
    store.close()
    png = tmp_path / "report.png"
    assert main(["stats", "--db", str(db), "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(png) as image:
        assert image.format == "PNG" and image.size == (1000, 700)
        assert len(image.convert("L").getcolors(1 << 16)) > 2  # bars drawn, not blank


def test_matplotlib_is_not_imported_without_plot(tmp_path):
    SessionStore(tmp_path / "s.db").open().close()
    code = (
        "import sys; from exhibit.cli import main; main(['stats', '--db', sys.argv[1], "
        "'--json']); assert 'matplotlib' not in sys.modules"
    )
    result = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "s.db")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr


# ---------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "setup, args, message",
    [
        (None, ["--since", "2026-02-30"], "argument --since: '2026-02-30' is not a date"),
        (None, ["--since", "yesterday"], "is not a date (YYYY-MM-DD)"),
        ("fifo", [], "is not a regular file"),
        ("folder", [], "is a folder"),
        ("text", [], "not a sessions database"),
        ("other-db", [], "not a sessions database"),
        ("missing", [], "no sessions database at"),
        (None, ["--plot", "report.pdf"], "must end in .png"),
        (None, ["--plot", "nowhere/report.png"], "does not exist"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, cli, setup, args, message):
    db = tmp_path / "s.db"
    if setup is None:
        SessionStore(db).open().close()
    elif setup == "fifo":
        os.mkfifo(db)
    elif setup == "folder":
        db.mkdir()
    elif setup == "text":
        db.write_text("hello")
    elif setup == "other-db":
        with sqlite3.connect(db) as con:
            con.execute("CREATE TABLE t (x)")
        con.close()
    args = [str(tmp_path / a) if a.endswith((".pdf", ".png")) else a for a in args]
    result = cli("stats", "--db", str(db), *args)
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and message in result.stderr
    assert "Traceback" not in result.stderr and result.stdout == ""


# ---------------------------------------------------------------------- [sessions] in kiosk.toml


@pytest.fixture
def tree(tmp_path):
    import shutil

    shutil.copytree(ROOT / "configs", tmp_path / "configs")
    return tmp_path / "configs"


@pytest.mark.parametrize(
    "old, new, key, reason",
    [
        ('path = ""', 'path = "sessions.db"', "sessions.path", "must be an absolute path"),
        ('path = ""', 'path = "/var/lib/exhibit/"', "sessions.path", "must name a file"),
        ("keep_days = 400", "keep_days = 0", "sessions.keep_days", "must lie in [1, 3650]"),
        ("max_sessions = 200000", "max_sessions = 2000.5", "sessions.max_sessions", "whole number"),
        ("enabled = true", 'enabled = "yes"', "sessions.enabled", "true or false"),
        ("enabled = true", "enabled = true\nretention = 3", "sessions.retention", "unknown key"),
    ],
)
def test_sessions_config_mistakes_are_named(tree, old, new, key, reason):
    kiosk = tree / "kiosk.toml"
    edit(kiosk, old, new)
    with pytest.raises(ConfigError) as info:
        load_kiosk_config(kiosk)
    assert any(p.startswith(f"{kiosk}: {key}: ") and reason in p for p in info.value.problems), (
        info.value.problems
    )


def test_sessions_config_reaches_the_kiosk(tree, monkeypatch, tmp_path):
    kiosk = tree / "kiosk.toml"
    config = load_kiosk_config(kiosk).sessions
    assert config.enabled and config.path is None and config.keep_days == 400
    monkeypatch.setenv("EXHIBIT_STATE_DIR", str(tmp_path / "state"))
    assert config.resolved() == tmp_path / "state" / "sessions.db"
    edit(kiosk, 'path = ""', f'path = "{tmp_path / "elsewhere.db"}"')
    edit(kiosk, "enabled = true", "enabled = false")
    config = load_kiosk_config(kiosk).sessions
    assert config.resolved() == tmp_path / "elsewhere.db" and not config.enabled
    assert sessions_module.open_session_log(config) is None


def test_the_database_is_readable_by_staff_whatever_the_umask(tmp_path):
    """The service runs with UMask=0077; staff run `exhibit stats` without sudo."""
    old = os.umask(0o077)
    try:
        store = SessionStore(tmp_path / "s.db").open()
        store.add(numbered(1))
        modes = {p.name: p.stat().st_mode & 0o777 for p in tmp_path.iterdir()}
        store.close()
    finally:
        os.umask(old)
    assert modes == {"s.db": 0o644, "s.db-wal": 0o644, "s.db-shm": 0o644}


def test_stats_finds_the_database_the_config_names(tmp_path, capsys, monkeypatch):
    db = tmp_path / "museum" / "visits.db"
    store = SessionStore(db).open()
    store.add(numbered(1))
    store.close()
    site = tmp_path / "site.toml"
    site.write_text(f'[sessions]\npath = "{db}"\n')
    assert main(["stats", "--config", str(site), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["db"] == str(db) and out["sessions"] == 1
    monkeypatch.setenv("EXHIBIT_STATE_DIR", str(tmp_path / "museum"))
    site.write_text("[sessions]\nkeep_days = 30\n")  # no path: the state folder's sessions.db
    (tmp_path / "museum" / "sessions.db").write_bytes(db.read_bytes())
    assert main(["stats", "--config", str(site), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["db"] == str(tmp_path / "museum" / "sessions.db")


def test_a_file_found_broken_while_writing_is_moved_aside_and_the_write_retried(
    tmp_path, monkeypatch, caplog
):
    real_add, calls = SessionStore.add, []

    def add(self, s):
        calls.append(s)
        if len(calls) == 1:
            raise sqlite3.DatabaseError("database disk image is malformed")
        return real_add(self, s)

    monkeypatch.setattr(SessionStore, "add", add)
    with caplog.at_level(logging.WARNING, logger="exhibit.operations.sessions"):
        writer = SessionWriter(tmp_path / "s.db")
        writer.submit(numbered(1))
        writer.close()
    assert writer.written == 1 and writer.failed == 0 and len(calls) == 2
    assert len(writer.store.moved_aside) == 1 and caplog.text.count("moved aside") == 1
    assert len(read_sessions(tmp_path / "s.db")) == 1


# ---------------------------------------------------------------------- hostile rows


def _plant(db: Path, rows: list[tuple]) -> None:
    """Rows put in with sqlite3 directly, as a hand or a broken kiosk could."""
    SessionStore(db, wall=lambda: NOON_ISH).open().close()
    with sqlite3.connect(db) as c:
        c.executemany(
            "INSERT INTO sessions (start, end, duration_s, active_s, utc_offset_s, "
            "language, scenes, inputs) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            rows,
        )
    c.close()


def _row(
    start=NOON_ISH,
    duration=60.0,
    active=30.0,
    offset=0,
    language="en",
    scenes='["hopf"]',
    inputs='["knobs.knob"]',
):
    return (
        start,
        start + duration if isinstance(start, float) and isinstance(duration, float) else start,
        duration,
        active,
        offset,
        language,
        scenes,
        inputs,
    )


DEEP = "[" * 100_000 + "]" * 100_000
HOSTILE_ROWS = {
    "year 33658": _row(start=1e12),
    "before 1970": _row(start=-1e12),
    "1e300": _row(start=1e300),
    "first day": _row(start=-62135596800.0),  # 0001-01-01
    "last day": _row(start=253402214400.0),  # 9999-12-31
    "last day, offset": _row(start=253402300799.0, offset=86400),
    "huge duration": _row(duration=1.7e308, active=1.7e308),
    "negative duration": _row(duration=-5.0),
    "infinite duration": _row(duration=float("inf")),
    "deep scenes": _row(scenes=DEEP),
    "deep inputs": _row(inputs=DEEP),
    "text start": _row(start="tomorrow"),
    "huge offset": _row(offset=2**62),
    "long scenes": _row(scenes=json.dumps(["x" * 100] * 2000)),
}


@pytest.mark.parametrize("what", sorted(HOSTILE_ROWS))
def test_stats_skips_a_hostile_row_and_says_so(tmp_path, capsys, what):
    db = tmp_path / "s.db"
    _plant(db, [_row(), HOSTILE_ROWS[what], HOSTILE_ROWS[what], _row(start=NOON_ISH + 86400)])
    out = report(capsys, db)
    assert out["sessions"] == 2 and out["skipped"] == 2, what
    assert out["median_s"] == 60.0 and out["first"] == "2026-11-30"
    assert main(["stats", "--db", str(db)]) == 0
    text = capsys.readouterr().out
    assert "\nskipped 2 rows: " in text and "2 visitor sessions" in text
    assert main(["stats", "--db", str(db), "--plot", str(tmp_path / "r.png")]) == 0
    assert (tmp_path / "r.png").read_bytes()[:4] == b"\x89PNG"


def test_stats_survives_every_hostile_row_at_once(tmp_path, capsys):
    db = tmp_path / "s.db"
    _plant(db, list(HOSTILE_ROWS.values()) * 2)
    out = report(capsys, db)
    assert out["sessions"] == 0 and out["skipped"] == 2 * len(HOSTILE_ROWS)
    assert sum(r["rows"] for r in out["skipped_reasons"]) == out["skipped"]
    assert main(["stats", "--db", str(db), "--since", "2026-01-01"]) == 0
    assert main(["stats", "--db", str(db), "--plot", str(tmp_path / "r.png")]) == 0
    err = capsys.readouterr().err
    assert "internal error" not in err and "Error" not in err


def test_read_sessions_bounds_every_value():
    from exhibit.operations.sessions.reading import _session_from_row

    ok = _session_from_row(*_row())
    assert ok.scenes == ["hopf"] and ok.duration_s == 60.0
    for row in HOSTILE_ROWS.values():
        with pytest.raises(ValueError):
            _session_from_row(*row)


def test_the_health_file_says_sessions_are_not_recorded_when_the_database_cannot_open(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    writer = SessionWriter(blocker / "sessions.db")
    recorder = SessionLog(writer)
    assert writer.ready.wait(5.0)
    state = recorder.health()["sessions"]
    assert state["recording"] is False
    assert "cannot open" in state["reason"] and str(blocker / "sessions.db") in state["reason"]
    recorder.close(0.0, 1.0)
    good = SessionWriter(tmp_path / "sessions.db")
    recorder = SessionLog(good)
    assert good.ready.wait(5.0)
    state = recorder.health()["sessions"]
    assert state["recording"] is True and "reason" not in state
    recorder.close(0.0, 1.0)


def test_sessions_the_disk_refuses_wait_and_are_written_in_order(tmp_path, monkeypatch):
    """A full state disk refuses writes for a while: the sessions that came meanwhile wait in
    the writer's backlog and are written, oldest first, once it takes writes again (before:
    counted as failed and lost)."""
    monkeypatch.setattr(sessions_writer, "RETRY_S", 0.05)
    writer = SessionWriter(tmp_path / "sessions.db")
    assert writer.ready.wait(30) and writer.usable
    real_add, full = writer.store.add, threading.Event()
    full.set()

    def add(session):
        if full.is_set():
            error = sqlite3.OperationalError("database or disk is full")
            error.sqlite_errorcode = sqlite3.SQLITE_FULL  # as SQLite sets it
            raise error
        return real_add(session)

    monkeypatch.setattr(writer.store, "add", add)
    now = time.time()
    for n in range(3):
        writer.submit(
            Session(
                start=now + n,
                end=now + n + 1,
                duration_s=1.0,
                active_s=1.0,
                utc_offset_s=0,
                scenes=["hopf"],
                inputs=["knob"],
            )
        )
    deadline = time.monotonic() + 30
    while len(writer.backlog) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert (len(writer.backlog), writer.failed, writer.written) == (3, 0, 0)
    assert writer.errno == "ENOSPC"
    full.clear()  # the disk empties; no new session needs to come for the backlog to go
    while writer.backlog and time.monotonic() < deadline:
        time.sleep(0.01)
    writer.close()
    assert (len(writer.backlog), writer.failed, writer.written) == (0, 0, 3)
    with sqlite3.connect(tmp_path / "sessions.db") as con:
        starts = [row[0] for row in con.execute("select start from sessions order by id")]
    assert starts == [now, now + 1, now + 2]


def test_stats_reads_the_services_log_before_this_users_own(tmp_path, monkeypatch):
    """As `exhibit status` does for the health file: on a kiosk machine, root's own old log
    (a kiosk once run by hand) must not hide the service's."""
    from exhibit.operations.sessions import config as sessions_config

    service, own = tmp_path / "var-lib-exhibit", tmp_path / "xdg"
    monkeypatch.setattr(sessions_config, "SERVICE_STATE_DIR", service)
    monkeypatch.delenv("EXHIBIT_STATE_DIR", raising=False)
    monkeypatch.setenv("XDG_STATE_HOME", str(own))
    assert sessions_config.candidate_paths() == [
        service / "sessions.db",
        own / "exhibit" / "sessions.db",
    ]
    monkeypatch.setenv("EXHIBIT_STATE_DIR", str(tmp_path / "set"))
    assert sessions_config.candidate_paths() == [tmp_path / "set" / "sessions.db"]
