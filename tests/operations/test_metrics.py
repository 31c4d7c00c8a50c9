"""`exhibit status --prometheus FILE`: the health file as Prometheus text-format metrics for
node_exporter's textfile collector, written atomically whatever the kiosk's health; and the
exhibit-metrics.service / .timer units that run it (systemd-analyze verify and security, the
unit's seccomp filter applied without systemd).

The output is checked by this file's strict reader everywhere, by `promtool check metrics`
(Debian: prometheus) when installed, and by the Python client's parser (prometheus_client) when
installed; the last two skip cleanly without their tool."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from exhibit.cli import main
from exhibit.devices.base import State
from exhibit.operations import prometheus as metrics
from exhibit.operations.health import write_health
from tests.hypothesis_profiles import examples
from tests.operations.support import fresh_fields

REPO = Path(__file__).resolve().parents[2]
SYSTEMD = REPO / "systemd"
UNITS = ("exhibit-metrics.service", "exhibit-metrics.timer")


def sample(**changes) -> dict:
    data = {
        "time": time.time(),
        "pid": os.getpid(),
        "fps": 59.8,
        "frame_ms_p95": 16.9,
        "mode": "attract",
        "scene": "hopf",
        "devices": [
            {
                "name": "controller",
                "url": "serial:///dev/exhibit-controller?baud=115200",
                "state": "lost",
                "state_s": 12.5,
                "missing_s": 125.0,
            },
            {
                "name": "knobs",
                "url": "hidraw://2341:8037",
                "state": "waiting",
                "state_s": 1.5,
                "missing_s": 3600.0,
            },
            {
                "name": "keyboard",
                "url": "keyboard://",
                "state": "connected",
                "state_s": 3600.0,
                "missing_s": None,
            },
        ],
        "uptime_s": 3600.2,
        "gl_errors": 1,
        "rss_kb": 187_392,
        "fds": 23,
        "frames": 216_000,
        "frame_errors": 2,
        "problems": ["scene veronese skipped: boom"],
        "scenes_failed": [{"scene": "veronese", "reason": "boom"}],
        **fresh_fields(),
        "frame_passes": {
            "level": "direct",
            "age_s": 3.0,
            "total_ms": 12.0,
            "passes_ms": {"background": 3.0, "surfaces": 5.5, "hud": 2.5},
            "other_ms": 1.0,
        },
    }
    data.update(changes)
    return data


def parse(text: str) -> dict[tuple[str, tuple], float]:
    """A small, strict reader of what render() writes: {(name, sorted labels): value}; every
    sample belongs to the family of the HELP and TYPE lines just before it."""
    out, family = {}, None
    label = r'([a-zA-Z_][a-zA-Z0-9_]*)="((?:[^"\\\n]|\\[\\"n])*)"'
    for line in text.splitlines():
        if line.startswith("# HELP "):
            family = line.split()[2]
            continue
        if line.startswith("# TYPE "):
            assert line.split()[2] == family and line.split()[3] in ("gauge", "counter")
            continue
        m = re.fullmatch(r"([a-zA-Z_:][a-zA-Z0-9_:]*)(?:\{(.*)\})? (\S+)", line)
        assert m and m.group(1) == family, line
        labels = tuple(
            sorted(
                (k, re.sub(r"\\(.)", lambda e: {"n": "\n"}.get(e.group(1), e.group(1)), v))
                for k, v in re.findall(label, m.group(2) or "")
            )
        )
        assert ",".join(f'{k}="{v}"' for k, v in re.findall(label, m.group(2) or "")) == (
            m.group(2) or ""
        ), line
        key = (family, labels)
        assert key not in out, f"duplicate series {key}"
        out[key] = float(m.group(3))
    return out


def promtool(text: str) -> None:
    """`promtool check metrics` on ``text``, when promtool is installed (else nothing: the
    strict parse() still runs, and test_promtool_is_there says it was skipped)."""
    tool = shutil.which("promtool")
    if tool is None:
        return
    result = subprocess.run(
        [tool, "check", "metrics"], input=text, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0 and not result.stdout.strip(), result.stdout + result.stderr


def client_parse(text: str) -> dict:
    """prometheus_client's own parser, when installed: {family name: [samples]}."""
    parser = pytest.importorskip("prometheus_client.parser")
    return {f.name: f.samples for f in parser.text_string_to_metric_families(text)}


# ---------------------------------------------------------------------- rendering


def test_promtool_is_there():
    """The other tests run `promtool check metrics` on what they render when it is installed;
    this one says so when it is not."""
    if shutil.which("promtool") is None:
        pytest.skip(
            "promtool is not installed (Debian: apt-get install prometheus); the "
            "metrics are checked by the test's own reader only"
        )
    promtool("# HELP x y\n# TYPE x gauge\nx 1\n")
    with pytest.raises(AssertionError):
        promtool('x{a="b} 1\n')  # the check can fail


def at(got: dict, name: str, **labels) -> float:
    return got[(name, tuple(sorted(labels.items())))]


def test_a_fresh_file_gives_every_family():
    text = metrics.render(sample(), "ok", 0.4, {"problem": None, "free_bytes": 5 << 30})
    promtool(text)
    got = parse(text)
    assert {name for name, _ in got} == set(metrics.FAMILIES)
    assert at(got, "exhibit_up") == 1
    assert at(got, "exhibit_health", status="ok") == 1
    assert at(got, "exhibit_health", status="stale") == 0
    assert at(got, "exhibit_fps") == 59.8
    assert at(got, "exhibit_frame_pass_seconds", **{"pass": "surfaces"}) == 0.0055
    assert at(got, "exhibit_frame_time_p95_seconds") == pytest.approx(0.0169)
    assert at(got, "exhibit_mode", mode="attract") == 1
    assert at(got, "exhibit_mode", mode="visitor") == 0
    assert at(got, "exhibit_scene_info", scene="hopf") == 1
    controller = {"device": "controller", "url": "serial:///dev/exhibit-controller?baud=115200"}
    assert at(got, "exhibit_device_state", **controller, state="lost") == 1
    assert at(got, "exhibit_device_state", **controller, state="connected") == 0
    assert at(got, "exhibit_device_state_seconds", **controller) == 12.5
    assert at(got, "exhibit_device_missing_seconds", **controller) == 125.0
    knobs = {"device": "knobs", "url": "hidraw://2341:8037"}
    assert at(got, "exhibit_device_state", **knobs, state="waiting") == 1
    assert at(got, "exhibit_device_state", **knobs, state="lost") == 0
    keyboard = {"device": "keyboard", "url": "keyboard://"}
    assert at(got, "exhibit_device_missing_seconds", **keyboard) == 0
    # A full state set per device: an alert can test == 1 on any state.
    assert [at(got, "exhibit_device_state", **keyboard, state=s.value) for s in State] == [
        int(s is State.CONNECTED) for s in State
    ]
    assert at(got, "exhibit_uptime_seconds") == 3600.2
    assert at(got, "exhibit_frames_total") == 216_000
    assert at(got, "exhibit_frame_errors_total") == 2
    assert at(got, "exhibit_gl_errors_total") == 1
    assert at(got, "exhibit_scenes_failed") == 1 and at(got, "exhibit_problems") == 1
    assert at(got, "exhibit_resident_memory_bytes") == 187_392 * 1024
    assert at(got, "exhibit_open_fds") == 23
    assert at(got, "exhibit_health_age_seconds") == 0.4
    build = {"version": "0.1.0", "release": "0.1.0-20250601T120000Z"}
    assert at(got, "exhibit_build_info", **build) == 1
    assert [
        at(got, "exhibit_state_folder_problem", problem=p) for p in metrics.FOLDER_PROBLEMS
    ] == [
        0,
        0,
        0,
    ]
    assert at(got, "exhibit_state_folder_free_bytes") == 5 << 30
    assert at(got, "exhibit_last_frame_timestamp_seconds") > 1e9
    assert text.endswith("\n") and "\r" not in text
    families = client_parse(text)
    assert families["exhibit_frames"][0].name == "exhibit_frames_total"  # a real counter


@pytest.mark.parametrize("status", ["missing", "broken", "stale"])
def test_without_a_fresh_file_up_is_0_and_the_status_says_why(status):
    data = sample(time=time.time() - 600) if status == "stale" else None
    text = metrics.render(data, status, 600.0 if data else None)
    promtool(text)
    got = parse(text)
    assert at(got, "exhibit_up") == 0
    assert {s: at(got, "exhibit_health", status=s) for s in metrics.HEALTH_STATUSES} == {
        s: int(s == status) for s in metrics.HEALTH_STATUSES
    }
    # A dead kiosk's numbers are not current: only when it was last heard of.
    names = {name for name, _ in got}
    expected = {"exhibit_up", "exhibit_health"}
    if status == "stale":
        expected |= {"exhibit_health_age_seconds", "exhibit_last_update_timestamp_seconds"}
    assert names == expected


def test_no_scene_is_the_notice_mode_and_no_scene_label():
    got = parse(metrics.render(sample(mode=None, scene=None), "ok", 0.1))
    assert at(got, "exhibit_mode", mode="notice") == 1
    assert at(got, "exhibit_mode", mode="attract") == 0
    assert not any(name == "exhibit_scene_info" for name, _ in got)


def test_an_older_kiosks_file_gives_states_without_durations():
    old = sample(
        devices=[
            {"url": "serial:///dev/x", "state": "lost"},
            {"url": "keyboard://", "state": "connected"},
        ],
        frames=None,
    )
    text = metrics.render(old, "ok", 1.0)
    promtool(text)
    got = parse(text)
    assert (
        at(
            got,
            "exhibit_device_state",
            device="serial:///dev/x",
            url="serial:///dev/x",
            state="lost",
        )
        == 1
    )
    assert not any(
        name
        in (
            "exhibit_device_state_seconds",
            "exhibit_device_missing_seconds",
            "exhibit_frames_total",
        )
        for name, _ in got
    )


HOSTILE = [
    'ho"pf',
    "back\\slash",
    "new\nline",
    "\x1b]0;title\x07esc",
    "tab\there",
    "\x00nul\x7fdel\x85nel\x9bcsi",
    "bidi\u202eoverride",
    "lone\ud800surrogate",
    "émoji 🌀 ünïcode",
    "",
    "x" * 1000,
    "trailing\\",
    '\\"',
    "\\n",
]


@pytest.mark.parametrize("text", HOSTILE)
def test_label_values_are_escaped_and_cleaned(text):
    data = sample(
        scene=text,
        devices=[{"name": text, "url": text, "state": text, "state_s": 1, "missing_s": 1}],
    )
    out = metrics.render(data, "ok", 0.0)
    out.encode("utf-8")  # valid UTF-8 (a lone surrogate would not encode)
    promtool(out)
    got = parse(out)
    scene = next(dict(labels)["scene"] for name, labels in got if name == "exhibit_scene_info")
    assert scene == metrics._clean(text) and len(scene) <= metrics.MAX_LABEL_CHARS
    assert all(c.isprintable() for c in scene)
    families = client_parse(out)
    assert families["exhibit_scene_info"][0].labels["scene"] == scene
    states = {s.labels["state"] for s in families["exhibit_device_state"] if s.value == 1}
    assert states == {metrics._clean(text)}


@settings(
    max_examples=examples(200),
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(names=st.lists(st.text(max_size=30), min_size=1, max_size=5), scene=st.text(max_size=40))
def test_any_strings_give_a_parseable_file_without_duplicate_series(names, scene):
    devices = [
        {"name": n, "url": "x", "state": "connected", "state_s": 1.0, "missing_s": None}
        for n in names
    ]
    out = metrics.render(sample(scene=scene, devices=devices), "ok", 0.0)
    got = parse(out)  # raises on a duplicate series or a malformed line
    assert sum(1 for name, _ in got if name == "exhibit_device_state_seconds") == len(names)


def test_extreme_values_are_written_as_numbers():
    big = float(2**53)
    out = metrics.render(
        sample(fps=big, frame_ms_p95=-big, uptime_s=0, rss_kb=-1, fds=-1, frames=2**53, devices=[]),
        "ok",
        0.0,
    )
    promtool(out)
    got = parse(out)
    assert at(got, "exhibit_frames_total") == 2**53 and at(got, "exhibit_fps") == big
    assert ("exhibit_open_fds", ()) not in got  # -1: could not be counted
    assert all(math.isfinite(v) for v in got.values())


# ---------------------------------------------------------------------- exhibit status --prometheus


def run_status(*args) -> int:
    return main(["status", *args])


def test_status_writes_the_metrics_atomically_and_world_readable(tmp_path, capsys):
    health, prom = tmp_path / "health.json", tmp_path / "exhibit.prom"
    write_health(health, sample())
    old = os.umask(0o077)
    try:
        assert run_status("--file", str(health), "--prometheus", str(prom)) == 0
    finally:
        os.umask(old)
    out, err = capsys.readouterr()
    assert out == "" and err == ""  # the file speaks; a timer every 15 s keeps the journal quiet
    assert stat.S_IMODE(prom.stat().st_mode) == 0o644
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exhibit.prom", "health.json"]
    got = parse(prom.read_text())
    assert at(got, "exhibit_up") == 1


@pytest.mark.parametrize("case", ["missing", "broken", "stale", "device lost"])
def test_status_writes_metrics_and_exits_0_whatever_the_health(tmp_path, capsys, case):
    health, prom = tmp_path / "health.json", tmp_path / "exhibit.prom"
    if case == "broken":
        health.write_text("{")
    elif case == "stale":
        write_health(health, sample(time=time.time() - 600))
    elif case == "device lost":
        write_health(health, sample())
    assert run_status("--file", str(health), "--prometheus", str(prom)) == 0
    assert capsys.readouterr().err == ""
    got = parse(prom.read_text())
    assert at(got, "exhibit_up") == int(case == "device lost")
    assert at(got, "exhibit_health", status="ok" if case == "device lost" else case) == 1


def test_status_cannot_write_the_metrics_exits_4_with_one_line(tmp_path, capsys):
    health = tmp_path / "health.json"
    write_health(health, sample())
    prom = tmp_path / "no-such-folder" / "exhibit.prom"
    assert run_status("--file", str(health), "--prometheus", str(prom)) == 4
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write the metrics file" in err
    assert "node_exporter" in err


def test_the_metrics_file_is_not_written_through_a_planted_link(tmp_path, capsys):
    health, prom = tmp_path / "health.json", tmp_path / "exhibit.prom"
    write_health(health, sample())
    victim = tmp_path / "victim"
    victim.write_text("keep")
    (tmp_path / f".exhibit.prom.{os.getpid()}.tmp").symlink_to(victim)
    prom.symlink_to(victim)  # a link at the target itself is replaced, not followed
    assert run_status("--file", str(health), "--prometheus", str(prom)) == 0
    assert victim.read_text() == "keep"
    assert not prom.is_symlink() and "exhibit_up 1" in prom.read_text()


@pytest.mark.parametrize("case", ["300-byte name", "looping link", "loop in the folder"])
def test_status_prometheus_refuses_a_name_the_system_cannot_open(tmp_path, capsys, case):
    """Issue 33: these were internal errors (ENAMETOOLONG, ELOOP) with a traceback's line."""
    health = tmp_path / "health.json"
    write_health(health, sample())
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    prom = {
        "300-byte name": tmp_path / ("a" * 300 + ".prom"),
        "looping link": tmp_path / "loop",
        "loop in the folder": tmp_path / "loop" / "exhibit.prom",
    }[case]
    code = run_status("--file", str(health), "--prometheus", str(prom))
    err = capsys.readouterr().err
    assert err.count("\n") <= 1 and "internal error" not in err
    if case == "looping link":  # the link itself is replaced by the file, never followed
        assert code == 0 and not prom.is_symlink() and "exhibit_up 1" in prom.read_text()
    else:
        assert code == 2 and "--prometheus" in err


def test_status_prometheus_with_json_prints_the_json_too(tmp_path, capsys):
    health, prom = tmp_path / "health.json", tmp_path / "exhibit.prom"
    write_health(health, sample())
    assert run_status("--file", str(health), "--prometheus", str(prom), "--json") == 0
    data = json.loads(capsys.readouterr().out)
    assert [m["device"] for m in data["devices_missing"]] == ["controller", "knobs"]


# ---------------------------------------------------------------------- the systemd units


def unavailable(reason: str):
    """Skip, except under CI=true, where these checks must really run."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: these tests must run)")
    pytest.skip(reason)


@pytest.fixture
def staged(tmp_path):
    """The two units as `exhibit install --prefix /srv/museum/exhibit` would write them, a stub
    for the program they run, and the host's own units, as systemd-analyze needs."""
    from exhibit.commands.install import render

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
    root = tmp_path / "root"
    units = root / "etc/systemd/system"
    units.mkdir(parents=True)
    for name in UNITS:
        (units / name).write_text(render((SYSTEMD / name).read_text(), "/srv/museum/exhibit"))
    exe = root / "srv/museum/exhibit/.venv/bin/exhibit"
    exe.parent.mkdir(parents=True)
    exe.write_text("#!/bin/sh\n")
    exe.chmod(0o755)
    (root / "usr/lib/systemd").mkdir(parents=True)
    (root / "usr/lib/systemd/system").symlink_to(host_units)
    return root


def analyze(root: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        ["systemd-analyze", *args, f"--root={root}"], capture_output=True, text=True, timeout=60
    )


def test_units_pass_systemd_analyze_verify(staged):
    result = analyze(staged, "verify", "--man=no", "--generators=no", *UNITS)
    lines = [line for line in (result.stdout + result.stderr).splitlines() if "exhibit" in line]
    assert result.returncode == 0 and lines == [], result.stdout + result.stderr
    service = (staged / "etc/systemd/system/exhibit-metrics.service").read_text()
    assert (
        "ExecStart=/srv/museum/exhibit/.venv/bin/exhibit status --prometheus "
        "/var/lib/prometheus/node-exporter/exhibit.prom"
    ) in service
    assert "/opt/exhibit" not in service


def test_the_service_scores_at_most_2_5(staged):
    result = analyze(staged, "security", "--offline=yes", "--no-pager", UNITS[0])
    match = re.search(
        r"Overall exposure level for exhibit-metrics.service: (\d+\.\d+)", result.stdout
    )
    assert match, result.stdout[-600:] + result.stderr[-600:]
    assert float(match.group(1)) <= 2.5


def test_the_timer_runs_the_service_every_15_s():
    from tests.deploy.unitfile import units

    timer = units(SYSTEMD / "exhibit-metrics.timer")
    assert timer["Timer"]["OnUnitActiveSec"] == ["15s"] and timer["Timer"]["AccuracySec"] == ["1s"]
    assert timer["Install"]["WantedBy"] == ["timers.target"]
    service = units(SYSTEMD / "exhibit-metrics.service")["Service"]
    assert service["Type"] == ["oneshot"]
    assert service["ReadWritePaths"] == ["/var/lib/prometheus/node-exporter"]
    assert "EXHIBIT_STATE_DIR=/var/lib/exhibit" in service["Environment"][0]


def test_status_runs_under_the_units_system_call_filter(tmp_path):
    """The unit's SystemCallFilter= (with EPERM), RestrictAddressFamilies= and
    MemoryDenyWriteExecute= applied without systemd (tests/deploy/sandbox_exec.py): the command
    the timer runs reads the health file and writes the metrics as it does unconfined."""
    from tests.deploy.unitfile import allowed_syscalls, units, yes

    service = units(SYSTEMD / "exhibit-metrics.service")["Service"]
    try:
        calls = allowed_syscalls(service)
    except FileNotFoundError:
        unavailable("systemd-analyze is not installed (Debian: apt-get install systemd)")
    syscalls = tmp_path / "allowed"
    syscalls.write_text("\n".join(sorted(calls)) + "\n")
    health, prom = tmp_path / "health.json", tmp_path / "exhibit.prom"
    write_health(health, sample())
    options = [
        "--syscalls",
        str(syscalls),
        "--errno",
        service["SystemCallErrorNumber"][-1],
        "--families",
        service["RestrictAddressFamilies"][-1].replace(" ", ","),
    ]
    assert yes(service, "MemoryDenyWriteExecute")
    options.append("--mdwe")
    result = subprocess.run(
        [
            sys.executable,
            str(REPO / "tests/deploy/sandbox_exec.py"),
            *options,
            "--",
            sys.executable,
            "-m",
            "exhibit",
            "status",
            "--file",
            str(health),
            "--prometheus",
            str(prom),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=REPO,
    )
    if result.returncode != 0 and "seccomp" in result.stderr and "libseccomp" in result.stderr:
        unavailable(f"no libseccomp here: {result.stderr.strip()[-200:]}")
    assert result.returncode == 0, result.stderr[-2000:]
    assert at(parse(prom.read_text()), "exhibit_up") == 1
