"""External tools run bounded (exhibit.tools): output read as bytes, a hung tool stopped at its
limit (in all, or when silent), and no tool or anything it started outliving its run or the
process that started it, however that process ends (a clean exit, SIGTERM, SIGINT, SIGKILL).

Every fake tool writes its pid to a file; "gone" is checked in /proc (a zombie waiting for a
reaper counts as gone). Time bounds are generous (10 times the limit): they prove "did not wait
for ever", not speed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from exhibit import tools
from tests.processes import alive, gone, outlived, pids


@pytest.fixture
def fake(tmp_path):
    """fake(body) -> a shell script that writes its pid to ``tmp_path/pids`` then runs body;
    whatever is left of them is killed at the end (a failing test leaves no process)."""
    record = tmp_path / "pids"

    def make(body: str, name: str = "tool") -> Path:
        script = tmp_path / name
        script.write_text(f'#!/bin/sh\necho $$ >> "{record}"\n{body}\n')
        script.chmod(0o755)
        return script

    make.pids = record  # type: ignore[attr-defined]
    yield make
    if record.exists():
        for pid in map(int, record.read_text().split()):
            if alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_output_is_bytes_and_the_status_is_kept(fake):
    tool = fake(r"printf 'out\377'; printf '\377\376 no UTF-8 \033[0m\n' >&2; exit 3")
    done = tools.run([str(tool)], limit_s=10)
    assert (done.code, done.out, done.err) == (3, b"out\xff", b"\xff\xfe no UTF-8 \x1b[0m\n")
    assert tools.last_line(done.err) == "\ufffd\ufffd no UTF-8 \ufffd[0m"


def test_input_larger_than_a_pipe_goes_in_without_a_deadlock():
    data = os.urandom(1 << 20)
    assert tools.run(["cat"], data, limit_s=20).out == data


@pytest.mark.parametrize("stall", [None, 0.3])
def test_a_hung_tool_is_stopped_at_its_limit_and_killed(fake, stall):
    tool = fake("printf started; exec sleep 1000")
    begun = time.monotonic()
    with pytest.raises(tools.ToolHung) as info:
        tools.run([str(tool)], limit_s=30 if stall else 0.3, stall_s=stall)
    assert time.monotonic() - begun < 3.0  # 10 x the limit: it did not wait for ever
    assert info.value.stalled is bool(stall) and info.value.seconds == 0.3
    assert info.value.out == b"started"
    assert str(info.value) == "tool did not answer within 0.3 s"
    assert gone(pids(fake.pids)[0])


def test_a_tool_that_keeps_talking_is_not_stalled(fake):
    tool = fake("for i in 1 2 3 4 5 6; do echo $i; sleep 0.1; done")
    assert tools.run([str(tool)], limit_s=30, stall_s=0.4).out.split() == [
        b"1",
        b"2",
        b"3",
        b"4",
        b"5",
        b"6",
    ]


def test_tail_keeps_the_last_bytes_instead_of_failing(fake):
    tool = fake("seq 1 100000")
    with pytest.raises(tools.ToolOutputTooLarge, match="over 1000 bytes on stdout"):
        tools.run([str(tool)], limit_s=20, max_out=1000)
    assert tools.run([str(tool)], limit_s=20, max_out=1000, tail=True).out.endswith(
        b"99999\n100000\n"
    )


def test_what_a_tool_started_in_the_background_dies_with_it(fake, tmp_path):
    """The tool exits at once, leaving a child of its own behind (holding no pipe)."""
    tool = fake(f'sleep 1000 </dev/null >/dev/null 2>&1 & echo $! >> "{fake.pids}"')
    assert tools.run([str(tool)], limit_s=10).code == 0
    leader, child = pids(fake.pids, want=2)
    assert gone(child)


CALLER = """
import sys
from exhibit import tools
tools.run([sys.argv[1]], limit_s=1000)
"""


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_no_tool_outlives_the_process_that_started_it(fake, sig):
    """The caller killed while its tool hangs (SIGKILL runs no handler): the tool goes too."""
    tool = fake("exec sleep 1000")
    caller = subprocess.Popen([sys.executable, "-c", CALLER, str(tool)], stderr=subprocess.DEVNULL)
    left = outlived(caller, fake.pids, sig, within=20)
    assert left is None, f"the tool outlived its caller ({sig.name})"


def test_a_clean_exit_with_a_tool_on_a_daemon_thread_kills_it(fake):
    tool = fake("exec sleep 1000")
    code = textwrap.dedent(
        """
        import os, sys, threading, time
        from exhibit import tools
        threading.Thread(target=tools.run, args=([sys.argv[1]],), kwargs={"limit_s": 1000},
                         daemon=True).start()
        while not os.path.exists(sys.argv[2]):  # the tool has started
            time.sleep(0.01)
        """
    )
    caller = subprocess.run([sys.executable, "-c", code, str(tool), str(fake.pids)], timeout=60)
    assert caller.returncode == 0
    assert gone(pids(fake.pids)[0])


def test_a_tool_that_is_not_there_is_an_oserror(tmp_path):
    with pytest.raises(FileNotFoundError):
        tools.run([str(tmp_path / "no-such-tool")], limit_s=10)
    with pytest.raises(FileNotFoundError):
        tools.run(["no-such-tool-anywhere"], limit_s=10, env={"PATH": str(tmp_path)})
