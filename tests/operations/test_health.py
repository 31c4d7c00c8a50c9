"""The health file (atomic, world-readable, validated on read) and `exhibit status` exit codes."""

from __future__ import annotations

import json
import os
import re
import stat
import subprocess
import sys
import threading
import time

from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.operations import health
from exhibit.operations.health import HealthError, freshness, read_health, write_health


def sample(**changes) -> dict:
    data = {
        "time": time.time(),
        "pid": os.getpid(),
        "fps": 59.8,
        "frame_ms_p95": 16.9,
        "mode": "attract",
        "scene": "hopf",
        "devices": [
            {"url": "serial:///dev/exhibit-controller?baud=115200", "state": "connected"},
            {"url": "hidraw://2341:8037", "state": "waiting"},
        ],
        "uptime_s": 93784.2,
        "gl_errors": 0,
        "rss_kb": 187_392,
        "fds": 23,
    }
    data.update(changes)
    return data


# ---------------------------------------------------------------------- paths


@pytest.mark.parametrize(
    "env, expected",
    [
        (
            {"EXHIBIT_STATE_DIR": "/var/lib/exhibit", "XDG_STATE_HOME": "/x", "HOME": "/h"},
            "/var/lib/exhibit/health.json",
        ),
        ({"XDG_STATE_HOME": "/x", "HOME": "/h"}, "/x/exhibit/health.json"),
        ({"HOME": "/h"}, "/h/.local/state/exhibit/health.json"),
        (
            {"EXHIBIT_STATE_DIR": "", "XDG_STATE_HOME": "", "HOME": "/h"},
            "/h/.local/state/exhibit/health.json",
        ),
    ],
)
def test_default_path(env, expected):
    assert str(health.default_path(env)) == expected


def test_readers_look_at_the_service_state_dir_first_unless_told_where():
    """Root's own ~/.local/state/exhibit (a kiosk once run by hand) must not hide the
    service's file: the service's folder comes first, the user's own second."""
    assert [str(p) for p in health.candidate_paths({"HOME": "/h"})] == [
        "/var/lib/exhibit/health.json",
        "/h/.local/state/exhibit/health.json",
    ]
    assert [str(p) for p in health.candidate_paths({"EXHIBIT_STATE_DIR": "/s"})] == [
        "/s/health.json"
    ]


# ---------------------------------------------------------------------- writing and reading


def test_round_trip_creates_the_folder_and_is_world_readable_despite_umask(tmp_path):
    path = tmp_path / "state" / "exhibit" / "health.json"
    old = os.umask(0o077)
    try:
        write_health(path, sample())
    finally:
        os.umask(old)
    written = read_health(path)
    assert written.as_dict() == json.loads(json.dumps(sample(time=written.time)))
    assert stat.S_IMODE(path.stat().st_mode) == 0o644
    assert [p.name for p in path.parent.iterdir()] == ["health.json"]  # no temporary left


def test_non_finite_numbers_become_null(tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample(fps=float("nan"), frame_ms_p95=float("inf")))
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    data = read_health(path)
    assert data.fps is None and data.frame_ms_p95 is None


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample(scene="hopf"))
    with pytest.raises(TypeError):
        write_health(path, sample(scene=object()))
    assert read_health(path).scene == "hopf"
    assert [p.name for p in tmp_path.iterdir()] == ["health.json"]


def test_write_into_a_read_only_folder_raises_oserror(tmp_path):
    if os.geteuid() == 0:
        target = tmp_path / "file-not-folder"
        target.write_text("")
        path = target / "health.json"  # root ignores permissions; a file as folder does not
    else:
        folder = tmp_path / "ro"
        folder.mkdir(mode=0o500)
        path = folder / "health.json"
    with pytest.raises(OSError):
        write_health(path, sample())


def test_readers_never_see_a_partial_file(tmp_path):
    """A writer replacing the file as fast as it can; every read is a whole, valid file."""
    path = tmp_path / "health.json"
    write_health(path, sample())
    stop = threading.Event()

    def writer():
        i = 0
        while not stop.is_set():
            write_health(path, sample(scene="x" * (i % 3000), fps=float(i)))
            i += 1

    thread = threading.Thread(target=writer)
    thread.start()
    try:
        reads = [read_health(path) for _ in range(2000)]
    finally:
        stop.set()
        thread.join()
    assert len({r.fps for r in reads}) > 1  # the writer really was replacing it meanwhile


@pytest.mark.parametrize(
    "content, message",
    [
        (None, "no health file at"),
        ("", "not valid JSON (line 1 column 1"),
        ('{"time": 1, "fps": ', "not valid JSON"),
        ("[1, 2]", "expected a JSON object, got list"),
        ('{"fps": 60}', "key 'time': missing"),
        ('{"time": "now"}', "key 'time': expected a number (unix seconds), got 'now'"),
        ('{"time": null}', "key 'time': expected a number"),
        ('{"time": 1, "pid": true}', "key 'pid': expected a whole number, got True"),
        ('{"time": 1, "mode": "sleeping"}', "key 'mode': expected one of attract, visitor"),
        ('{"time": 1, "devices": {"url": "x"}}', "key 'devices': expected a list"),
        ('{"time": 1, "devices": [{"url": "x"}]}', "key 'devices[0]': expected"),
        ('{"time": 1, "fps": NaN}', "not valid JSON (NaN is not a JSON number)"),
        ('{"time": 1, "extra": -Infinity}', "not valid JSON (-Infinity is not a JSON number)"),
        ('{"time": 1e400}', "not valid JSON (1e400 is too large)"),
        ('{"time": 1, "extra": [1e999]}', "not valid JSON (1e999 is too large)"),
        ('{"time": 1, "extra": ' + "9" * 5000 + "}", "not valid JSON (Exceeds the limit"),
        ("[" * 100_000 + "]" * 100_000, "not valid JSON (nested too deep)"),
        ('{"time": ' + "9" * 400 + "}", "key 'time': out of range"),
        ('{"time": 1, "rss_kb": 100000000000000000000}', "key 'rss_kb': out of range"),
        ('{"time": -1e300}', "key 'time': out of range"),
        ('{"time": 1, "pid": 1.5}', "key 'pid': expected a whole number, got 1.5"),
        ('{"time": 1, "devices": [{"url": "x", "state": 3}]}', "key 'devices[0]': expected"),
        ('{"time": 1, "devices": ["x"]}', "key 'devices[0]': expected"),
        (b"\xff\xfe", "not UTF-8 text"),
        (
            b" " * (health.MAX_HEALTH_BYTES + 1),
            "more than the 1048576 bytes a health file may have",
        ),
    ],
)
def test_read_errors_name_the_file_and_the_problem(tmp_path, content, message):
    path = tmp_path / "health.json"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    with pytest.raises(HealthError) as info:
        read_health(path)
    assert str(path) in str(info.value) and message in str(info.value)
    assert info.value.missing is (content is None)


def test_unknown_keys_and_nulls_are_kept(tmp_path):
    path = tmp_path / "health.json"
    path.write_text('{"time": 5, "fps": null, "brightness": 0.7}')
    assert read_health(path).as_dict() == {"time": 5, "fps": None, "brightness": 0.7}


# ---------------------------------------------------------------------- freshness


def test_freshness():
    now = 1_000_000.0
    assert freshness({"time": now - 3}, 10, now=now) == (True, 3.0, None)
    fresh, age, reason = freshness({"time": now - 12.5}, 10, now=now)
    assert (fresh, age) == (False, 12.5) and "12.5 s ago (more than 10 s)" in reason
    fresh, _, reason = freshness({"time": now + 60}, 10, now=now)
    assert not fresh and "in the future" in reason
    assert freshness({"time": now + 2}, 10, now=now)[0]  # a small clock step is not an alarm


def test_a_dead_pid_is_stale_at_once():
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    fresh, _, reason = freshness({"time": time.time(), "pid": child.pid}, 10)
    assert not fresh and f"process {child.pid} is not running" in reason
    assert freshness({"time": time.time(), "pid": child.pid}, 10, check_pid=False)[0]
    assert freshness({"time": time.time(), "pid": os.getpid()}, 10)[0]


@pytest.mark.parametrize(
    "seconds, text",
    [(3.25, "3.2 s"), (250, "4 min 10 s"), (7500, "2 h 5 min"), (93784.2, "1 d 2 h")],
)
def test_durations_read_as_staff_say_them(seconds, text):
    assert health.format_duration(seconds) == text


# ---------------------------------------------------------------------- exhibit status


@pytest.fixture
def cli(capsys):
    """`exhibit ARGS...` in this process (the CLI's own entry point, without a 0.8 s start-up per
    call); returns an object with returncode, stdout and stderr like subprocess.run's."""
    from exhibit.cli import main

    def run(*args):
        code = main(list(args))
        out, err = capsys.readouterr()
        return subprocess.CompletedProcess(args, code, out, err)

    return run


def status(cli, path, *args):
    return cli("status", "--file", str(path), *args)


def test_status_fresh_prints_a_summary_and_exits_0(tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample())
    result = subprocess.run(
        [sys.executable, "-m", "exhibit", "status", "--file", str(path)],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert out.startswith("exhibit kiosk: OK (updated ")
    for text in (
        "attract",
        "hopf",
        "59.8",
        "16.9 ms",
        "1 d 2 h",
        "hidraw://2341:8037",
        "waiting",
        "connected",
        "0 GL errors, 183 MB resident, 23 open files",
        str(path),
    ):
        assert text in out
    assert result.stderr == ""


def test_status_stale_exits_1_with_one_line_reason(cli, tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample(time=time.time() - 60))
    result = status(cli, path, "--max-age", "30")
    assert result.returncode == 1
    assert "exhibit kiosk: STALE" in result.stdout
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("exhibit status: STALE:")
    assert "more than 30 s" in result.stderr


def test_status_missing_exits_1(cli, tmp_path):
    result = status(cli, tmp_path / "nothing.json")
    assert result.returncode == 1 and result.stdout == ""
    assert result.stderr.startswith("exhibit status: MISSING: no health file at ")
    assert result.stderr.count("\n") == 1


def test_status_missing_names_every_place_it_looked(cli, tmp_path, monkeypatch):
    monkeypatch.delenv("EXHIBIT_STATE_DIR", raising=False)
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path))
    if (health.SERVICE_STATE_DIR / "health.json").exists():
        pytest.skip("this machine runs the kiosk service")
    result = cli("status")
    assert result.returncode == 1
    assert str(tmp_path / "exhibit" / "health.json") in result.stderr
    assert "/var/lib/exhibit/health.json" in result.stderr


def test_status_reads_exhibit_state_dir(cli, tmp_path, monkeypatch):
    write_health(tmp_path / "health.json", sample())
    monkeypatch.setenv("EXHIBIT_STATE_DIR", str(tmp_path))
    assert cli("status").returncode == 0


def test_status_broken_file_exits_1(cli, tmp_path):
    path = tmp_path / "health.json"
    path.write_text("{")
    result = status(cli, path)
    assert result.returncode == 1 and "BROKEN" in result.stderr and str(path) in result.stderr


def test_status_json(cli, tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample(time=time.time() - 100))
    result = status(cli, path, "--json")
    assert result.returncode == 1
    data = json.loads(result.stdout)
    assert data["fresh"] is False and data["path"] == str(path) and data["age_s"] >= 100
    assert data["scene"] == "hopf" and "more than 10 s" in data["reason"]
    missing = json.loads(status(cli, tmp_path / "none.json", "--json").stdout)
    assert missing["fresh"] is False and "no health file" in missing["reason"]


@pytest.mark.parametrize("option", ["--max-age", "--max-lost"])
@pytest.mark.parametrize("text", ["-1", "nan", "inf", "1e999", "1e9", "x", "", "0x10"])
def test_status_bad_numbers_are_a_usage_error(capsys, tmp_path, option, text):
    with pytest.raises(SystemExit) as info:
        main(["status", "--file", str(tmp_path / "health.json"), f"{option}={text}"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"exhibit status: error: argument {option}: ")


def test_status_max_age_zero_is_refused_and_max_lost_zero_is_not(capsys, tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample())
    with pytest.raises(SystemExit):
        main(["status", "--file", str(path), "--max-age", "0"])
    assert main(["status", "--file", str(path), "--max-lost", "0"]) == 0  # no durations: old file


# ---------------------------------------------------------------------- devices missing


def devices(*entries) -> list[dict]:
    return [dict(zip(("name", "url", "state", "state_s", "missing_s"), e)) for e in entries]


CONTROLLER = "serial:///dev/exhibit-controller?baud=115200"


def test_status_exits_3_when_a_device_is_lost_for_longer_than_max_lost(cli, tmp_path):
    path = tmp_path / "health.json"
    write_health(
        path,
        sample(
            devices=devices(
                ("controller", CONTROLLER, "lost", 125.0, 125.0),
                ("kb", "keyboard://", "connected", 9.0, None),
            )
        ),
    )
    result = status(cli, path)
    assert result.returncode == 3
    assert result.stdout.startswith("exhibit kiosk: DEVICE MISSING (updated ")
    assert f"{CONTROLLER}  lost for 2 min 5 s" in result.stdout
    assert "keyboard://" in result.stdout and "connected\n" in result.stdout
    assert result.stderr == (
        f"exhibit status: DEVICE MISSING: controller ({CONTROLLER}) lost "
        "for 2 min 5 s (more than 60 s)\n"
    )
    assert status(cli, path, "--max-lost", "200").returncode == 0
    assert status(cli, path, "--max-lost", "124").returncode == 3


def test_status_tells_waiting_from_lost(cli, tmp_path):
    path = tmp_path / "health.json"
    write_health(
        path,
        sample(
            devices=devices(
                ("controller", CONTROLLER, "lost", 1.5, 61.5),
                ("knobs", "hidraw://2341:8037", "waiting", 3700.0, 3700.0),
            )
        ),
    )
    result = status(cli, path)
    assert result.returncode == 3
    assert re.search(
        r"hidraw://2341:8037 +waiting for 1 h 1 min \(never connected\)\n", result.stdout
    )
    assert re.search(r"controller\?baud=115200 +lost for 1 min 1 s\n", result.stdout)
    assert result.stderr.count("\n") == 1
    assert f"controller ({CONTROLLER}) lost for 1 min 1 s (more than 60 s); " in result.stderr
    assert (
        "knobs (hidraw://2341:8037) waiting (never connected since the start) for 1 h 1 min"
        in result.stderr
    )
    data = json.loads(status(cli, path, "--json").stdout)
    assert [(m["device"], m["state"]) for m in data["devices_missing"]] == [
        ("controller", "lost"),
        ("knobs", "waiting"),
    ]


def test_the_file_age_counts_towards_the_time_missing(cli, tmp_path):
    path = tmp_path / "health.json"
    write_health(
        path, sample(time=time.time() - 5, devices=devices(("c", CONTROLLER, "lost", 57.0, 57.0)))
    )
    assert status(cli, path).returncode == 3  # 57 s as written, 62 s by now


def test_a_short_loss_and_a_reconnect_in_progress(cli, tmp_path):
    path = tmp_path / "health.json"
    write_health(path, sample(devices=devices(("c", CONTROLLER, "reconnecting", 0.4, 30.0))))
    result = status(cli, path)
    assert result.returncode == 0 and "reconnecting for 30.0 s" in result.stdout
    assert status(cli, path, "--max-lost", "10").returncode == 3


def test_stale_wins_over_a_missing_device(cli, tmp_path):
    path = tmp_path / "health.json"
    write_health(
        path,
        sample(time=time.time() - 60, devices=devices(("c", CONTROLLER, "lost", 500.0, 500.0))),
    )
    result = status(cli, path)
    assert result.returncode == 1 and "STALE" in result.stderr and "DEVICE" not in result.stderr


def test_an_older_kiosks_file_without_durations_is_read_as_before(cli, tmp_path):
    """Files written before state_s / missing_s: states shown, never exit 3 (how long is
    unknown)."""
    path = tmp_path / "health.json"
    write_health(path, sample(devices=[{"url": CONTROLLER, "state": "lost"}]))
    result = status(cli, path, "--max-lost", "0")
    assert result.returncode == 0 and f"{CONTROLLER}  lost\n" in result.stdout


@pytest.mark.parametrize(
    "device, message",
    [
        (
            {"url": "x", "state": "lost", "missing_s": "long"},
            "devices[0].missing_s': expected a num",
        ),
        ({"url": "x", "state": "lost", "missing_s": -1}, "devices[0].missing_s': expected seconds"),
        ({"url": "x", "state": "lost", "state_s": 1e300}, "devices[0].state_s': expected seconds"),
        ({"url": "x", "state": "lost", "state_s": True}, "devices[0].state_s': expected a number"),
        ({"url": "x", "state": "lost", "name": 7}, "devices[0].name': expected a string"),
    ],
)
def test_device_durations_are_checked_on_read(tmp_path, device, message):
    path = tmp_path / "health.json"
    path.write_text(json.dumps({"time": 1, "devices": [device]}))
    with pytest.raises(HealthError, match=re.escape(message)):
        read_health(path)


# ---------------------------------------------------------------------- hostile health files


def test_status_strips_terminal_escapes_from_the_file(cli, tmp_path):
    """Escape sequences in the scene or a device name (set the title, clear the screen, a
    hyperlink, 8-bit CSI, bidi override) reach the staff terminal as plain text only."""
    path = tmp_path / "health.json"
    hostile = sample(
        scene="\x1b]0;pwned\x07hopf\x1b[2J\x1b[H",
        devices=[
            {
                "url": "serial://\x1b]8;;http://x\x1b\\dev\x1b]8;;\x1b\\",
                "state": "conn\x9b31mected\r\nFAKE: ok\u202e\x7f\x00",
            }
        ],
    )
    write_health(path, hostile)
    result = status(cli, path)
    assert result.returncode == 0, result.stderr
    assert "hopf" in result.stdout and "serial://dev  connected  FAKE: ok" in result.stdout
    for line in result.stdout.splitlines():
        assert all(c.isprintable() for c in line), repr(line)
    # --json keeps the exact strings, escaped: valid JSON, nothing raw for the terminal.
    result = status(cli, path, "--json")
    assert result.stdout.isascii() and all(c.isprintable() or c == "\n" for c in result.stdout)
    data = json.loads(result.stdout)
    assert data["scene"] == hostile["scene"] and data["devices"] == hostile["devices"]


def test_status_strips_escapes_from_paths_and_reasons(cli, tmp_path):
    path = tmp_path / "h\x1b[31m\x07ealth.json"
    write_health(path, sample(time=time.time() - 60))
    result = status(cli, path)
    assert result.returncode == 1 and "\x1b" not in result.stdout + result.stderr
    assert "h[31mealth.json" not in result.stdout and "health.json" in result.stdout
    path.write_text("{")
    result = status(cli, path)
    assert result.returncode == 1 and result.stderr.startswith("exhibit status: BROKEN: ")
    assert "\x1b" not in result.stderr and "\x07" not in result.stderr
    assert result.stderr.count("\n") == 1


@pytest.mark.parametrize("kind", ["fifo", "dev/zero", "symlink to dev/zero", "socket"])
def test_status_refuses_a_non_regular_file_without_hanging(tmp_path, kind):
    path = tmp_path / "health.json"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "socket":
        import socket

        with socket.socket(socket.AF_UNIX) as server:
            server.bind(str(path))  # the socket file stays after close
    elif kind == "symlink to dev/zero":
        path.symlink_to("/dev/zero")
    else:
        path = "/dev/zero"
    result = subprocess.run(
        [sys.executable, "-m", "exhibit", "status", "--file", str(path)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert result.returncode == 1 and result.stdout == ""
    why = "No such device or address" if kind == "socket" else "not a regular file"
    assert result.stderr.startswith(f"exhibit status: BROKEN: cannot read {path}: {why}")
    assert result.stderr.count("\n") == 1


def test_status_survives_extreme_but_valid_numbers(cli, tmp_path):
    """The largest accepted values, negative ones and huge unknown keys print, not crash."""
    path = tmp_path / "health.json"
    big = float(health.MAX_NUMBER)
    write_health(
        path,
        sample(
            fps=big,
            frame_ms_p95=-big,
            uptime_s=big,
            rss_kb=2**53,
            gl_errors=-(2**53),
            fds=0,
            pid=2**53,
            extra=10**4000,
        ),
    )
    result = status(cli, path)
    assert result.returncode == 1  # pid 2**53 is not running
    assert "exhibit kiosk: STALE" in result.stdout and "STALE" in result.stderr
    assert json.loads(status(cli, path, "--json").stdout)["extra"] == 10**4000


def test_status_is_not_ok_while_scenes_are_skipped(tmp_path, capsys):
    """Issue 40: a kiosk skipping scenes was "OK", exit 0. Now WARN, exit 6, the reason on
    stderr; the exit code is documented in README and docs/DEPLOYMENT.md."""
    path = tmp_path / "health.json"
    write_health(path, sample(scenes_failed=[{"scene": "hopf", "reason": "boom"}], problems=[]))
    assert main(["status", "--file", str(path)]) == 6
    out, err = capsys.readouterr()
    assert out.startswith("exhibit kiosk: WARN (updated ")
    assert err == "exhibit status: WARN: 1 scene(s) skipped: hopf\n"
    assert main(["status", "--file", str(path), "--json"]) == 6
    data = json.loads(capsys.readouterr().out)
    assert data["exit"] == 6 and data["up"] is True and data["health"] == "ok"
    assert data["issues"] == [{"exit": 6, "head": "WARN", "text": "1 scene(s) skipped: hopf"}]


def test_status_shows_skipped_scenes_and_problems_safely(tmp_path, capsys):
    path = tmp_path / "health.json"
    write_health(
        path,
        sample(
            scenes_failed=[{"scene": "hopf", "reason": "boom"}],
            problems=["scene hopf skipped: \x1b[2Jboom"],
            frames=120,
            frame_errors=3,
        ),
    )
    assert main(["status", "--file", str(path)]) == 6  # WARN: scenes skipped
    out, err = capsys.readouterr()
    assert "scene hopf skipped: boom" in out and "\x1b" not in out + err
    assert err == "exhibit status: WARN: scene hopf skipped: boom\n"
    assert "120 drawn, 3 failed" in out


def test_the_health_file_is_not_written_through_a_planted_link(tmp_path):
    path = tmp_path / "health.json"
    victim = tmp_path / "victim"
    victim.write_text("keep")
    victim.chmod(0o600)
    (tmp_path / f".health.json.{os.getpid()}.tmp").symlink_to(victim)
    write_health(path, sample())
    assert victim.read_text() == "keep" and (victim.stat().st_mode & 0o777) == 0o600
    assert read_health(path).scene == sample()["scene"]


def test_status_shows_the_quality_level(tmp_path, capsys):
    path = tmp_path / "health.json"
    write_health(
        path,
        sample(
            quality="scale-50",
            frame_ms=19.1,
            target_ms=16.67,
            quality_detail={
                "antialiasing": "fxaa",
                "mesh": 2,
                "effects": "lean",
                "render_scale": 0.5,
                "level": 6,
                "levels": 6,
                "pinned": False,
            },
        ),
    )
    assert main(["status", "--file", str(path), "--max-lost", "1e6"]) in (0, 3)
    assert (
        "quality   scale-50 (level 6 of 6, auto; fxaa, mesh x0.5, lean, scale 0.5), "
        "frames 19.1 ms for a 16.7 ms target"
    ) in capsys.readouterr().out


def test_status_survives_an_odd_quality_detail(tmp_path, capsys):
    path = tmp_path / "health.json"
    write_health(path, sample(quality="x\x1b[2J", quality_detail=[1], frame_ms="fast"))
    main(["status", "--file", str(path)])
    out = capsys.readouterr().out
    assert "quality   x (level ? of ?, auto; ?, mesh x?, ?, scale ?), frames ? ms" in out


# ---------------------------------------------------------------------- targets never replaced


@pytest.mark.parametrize("target", ["", "/", ".", "..", "some/folder/"])
def test_status_prometheus_refuses_a_name_that_is_no_file(capsys, tmp_path, target):
    with pytest.raises(SystemExit) as stop:  # a usage error, from argparse
        main(["status", "--file", str(tmp_path / "health.json"), "--prometheus", target])
    err = capsys.readouterr().err
    assert stop.value.code == 2
    assert "internal error" not in err and "--prometheus" in err
    assert "names a folder" in err or "empty file name" in err
    assert len(err.strip().splitlines()) == 1


def _special_targets(tmp_path):
    fifo = tmp_path / "metrics.fifo"
    os.mkfifo(fifo)
    folder = tmp_path / "metrics.prom"
    folder.mkdir()
    link = tmp_path / "link.prom"
    link.symlink_to(fifo)
    targets = {
        "fifo": (fifo, stat.S_ISFIFO),
        "folder": (folder, stat.S_ISDIR),
        "link to a fifo": (link, stat.S_ISFIFO),
    }
    if os.geteuid() == 0:  # only root could replace a device node; it must not
        targets["/dev/null"] = (Path("/dev/null"), stat.S_ISCHR)
        targets["/dev/full"] = (Path("/dev/full"), stat.S_ISCHR)
    return targets


def test_status_prometheus_never_replaces_a_fifo_folder_or_device(cli, tmp_path):
    write_health(tmp_path / "health.json", sample())
    for what, (target, kind) in _special_targets(tmp_path).items():
        result = status(cli, tmp_path / "health.json", "--prometheus", str(target))
        assert result.returncode == 2, what
        assert str(target) in result.stderr and "internal error" not in result.stderr, what
        assert kind(os.stat(target).st_mode), what
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_write_health_never_replaces_a_fifo_folder_or_device(tmp_path):
    for what, (target, kind) in _special_targets(tmp_path).items():
        with pytest.raises(OSError, match="refusing"):
            write_health(target, sample())
        assert kind(os.stat(target).st_mode), what
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


# ---------------------------------------------------------------------- uptime


def test_process_uptime_counts_from_the_process_start():
    """exhibit_uptime_seconds is "seconds since the kiosk process started": the kernel's start
    time of the process, so its start-up counts too."""
    child = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import time; time.sleep(1.5); "
            "from exhibit.operations.health import process_uptime; "
            "print(process_uptime())",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    time.sleep(0.5)
    seen = health.process_uptime(child.pid)
    out, _ = child.communicate(timeout=60)
    assert seen is not None and 0.4 <= seen < 30
    assert 1.5 <= float(out) < 60  # its own start-up (the sleep, the imports) included
    assert health.process_uptime() > 0
    assert health.process_uptime(2**22 + 12345) is None  # no such process


def test_the_kiosk_reports_uptime_since_its_process_started(tmp_path, monkeypatch):
    """The kiosk once measured uptime from a clock read in Kiosk.__init__, missing everything
    before (imports, the window, the first meshes): 24 s after 45 s of running."""
    from tests.kiosk.support import kiosk

    k, _ = kiosk(tmp_path, monkeypatch)
    before = health.process_uptime()
    k.run(max_frames=30)
    data = read_health(tmp_path / "health.json")
    # This process (pytest) started long before the kiosk object and its fake clock.
    assert data.uptime_s >= round(before, 1) - 0.1
    monkeypatch.setattr(health, "process_uptime", lambda pid=None: 4321.04)
    k.run(max_frames=30)
    assert read_health(tmp_path / "health.json").uptime_s == 4321.0


def test_the_kiosk_writes_what_the_model_reads(tmp_path, monkeypatch):
    """One schema: every key the kiosk writes is a field of Health (none lands in the extras)."""
    from tests.kiosk.support import kiosk

    k, _ = kiosk(tmp_path, monkeypatch)
    k.run(max_frames=30)
    data = read_health(tmp_path / "health.json")
    assert not data.model_extra, sorted(data.model_extra)
    assert data.model_fields_set >= {
        "time",
        "pid",
        "fps",
        "devices",
        "uptime_s",
        "frames",
        "quality",
        "target_ms",
        "language",
    }
