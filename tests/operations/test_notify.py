"""The sd_notify client against a real AF_UNIX datagram socket standing in for systemd's, with the
kernel's sender credentials checked as NotifyAccess=main does; watchdog pacing on a fake clock."""

from __future__ import annotations

import logging
import os
import socket
import struct
import tempfile
import uuid
from pathlib import Path

import pytest

from exhibit.operations.notify import Notifier


class FakeSystemd:
    """A bound SOCK_DGRAM socket with SO_PASSCRED, as PID 1's notify socket is."""

    def __init__(self, abstract: bool = False):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_PASSCRED, 1)
        if abstract:
            name = f"exhibit-test-{uuid.uuid4().hex}"
            self.sock.bind("\0" + name)
            self.address = "@" + name
            self._dir = None
        else:
            # sun_path holds 108 bytes: pytest's tmp_path can be longer than that.
            self._dir = tempfile.TemporaryDirectory(prefix="exn-", dir="/tmp")
            self.address = os.path.join(self._dir.name, "notify")
            self.sock.bind(self.address)
        self.sock.settimeout(2)

    def receive(self) -> tuple[list[str], int]:
        """One datagram: its KEY=VALUE lines and the sender's PID from SCM_CREDENTIALS."""
        data, ancillary, _flags, _addr = self.sock.recvmsg(4096, socket.CMSG_SPACE(12))
        pid = None
        for level, kind, payload in ancillary:
            if level == socket.SOL_SOCKET and kind == socket.SCM_CREDENTIALS:
                pid, _uid, _gid = struct.unpack("iII", payload[:12])
        return data.decode().split("\n"), pid

    def pending(self) -> list[list[str]]:
        """Every datagram already queued, without waiting."""
        out = []
        self.sock.setblocking(False)
        try:
            while True:
                try:
                    data = self.sock.recv(4096)
                except BlockingIOError:
                    return out
                out.append(data.decode().split("\n"))
        finally:
            self.sock.settimeout(2)

    def close(self):
        self.sock.close()
        if self._dir is not None:
            self._dir.cleanup()


@pytest.fixture(params=[False, True], ids=["path", "abstract"])
def systemd(request):
    server = FakeSystemd(abstract=request.param)
    yield server
    server.close()


@pytest.fixture(autouse=True)
def _close_notifiers(monkeypatch):
    """Every Notifier a test makes is closed afterwards (ResourceWarning is an error here)."""
    made = []
    original = Notifier.__init__

    def init(self, *args, **kwargs):
        original(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(Notifier, "__init__", init)
    yield
    for notifier in made:
        notifier.close()


class Clock:
    def __init__(self):
        self.t = 1000.0

    def __call__(self):
        return self.t


def test_ready_status_watchdog_stopping_reach_the_socket_from_this_pid(systemd):
    env = {
        "NOTIFY_SOCKET": systemd.address,
        "WATCHDOG_USEC": "10000000",
        "WATCHDOG_PID": str(os.getpid()),
    }
    with Notifier.from_env(env) as notifier:
        assert notifier.enabled and notifier.watchdog_interval == 10.0
        assert notifier.ping_period == 5.0
        assert notifier.ready(status="first frame")
        assert systemd.receive() == (["READY=1", "STATUS=first frame"], os.getpid())
        assert notifier.status("60 fps, attract, hopf;\nserial:///dev/exhibit-controller connected")
        assert systemd.receive()[0] == [
            "STATUS=60 fps, attract, hopf; serial:///dev/exhibit-controller connected"
        ]
        assert notifier.watchdog()
        assert systemd.receive() == (["WATCHDOG=1"], os.getpid())
        assert notifier.extend_timeout(30)
        assert systemd.receive()[0] == ["EXTEND_TIMEOUT_USEC=30000000"]
        assert notifier.stopping()
        assert systemd.receive()[0] == ["STOPPING=1"]
        assert notifier.sent == 5 and notifier.send_errors == 0


def test_repeated_status_is_not_resent(systemd):
    notifier = Notifier(systemd.address)
    assert notifier.status("60 fps") and not notifier.status("60 fps")
    assert notifier.status("59 fps")
    assert systemd.pending() == [["STATUS=60 fps"], ["STATUS=59 fps"]]


def test_watchdog_pings_at_half_the_timeout_and_not_in_between(systemd):
    clock = Clock()
    notifier = Notifier(systemd.address, watchdog_usec=4_000_000, clock=clock)
    sent_at = []
    for _ in range(641):  # 10 s of frames at 64 fps (exact in binary, so no drift)
        if notifier.watchdog():
            sent_at.append(clock.t)
        clock.t += 1 / 64
    assert sent_at == [1000.0, 1002.0, 1004.0, 1006.0, 1008.0, 1010.0]
    assert len(systemd.pending()) == 6


def test_watchdog_not_due_makes_no_system_call(systemd, monkeypatch):
    clock = Clock()
    notifier = Notifier(systemd.address, watchdog_usec=2_000_000, clock=clock)
    assert notifier.watchdog()

    def refuse(*_args, **_kwargs):
        raise AssertionError("no socket work expected when no ping is due")

    monkeypatch.setattr(socket.socket, "sendto", refuse)
    monkeypatch.setattr(socket, "socket", refuse)
    clock.t += 0.999
    assert not any(notifier.watchdog() for _ in range(1000))


def test_a_stalled_loop_stops_the_pings(systemd):
    clock = Clock()
    notifier = Notifier(systemd.address, watchdog_usec=1_000_000, clock=clock)
    notifier.watchdog()
    clock.t += 30.0  # the loop hung for 30 s: nothing is sent without a call from the loop
    assert systemd.pending() == [["WATCHDOG=1"]]
    assert notifier.watchdog()  # the loop resumes: ping again at once


def test_failed_ping_is_retried_after_a_tenth_of_the_period(caplog):
    clock = Clock()
    missing = f"/tmp/exhibit-no-such-socket-{uuid.uuid4().hex}"
    notifier = Notifier(missing, watchdog_usec=10_000_000, clock=clock)
    with caplog.at_level(logging.WARNING, logger="exhibit.operations.notify"):
        assert not notifier.watchdog()
        clock.t += 0.4
        assert not notifier.watchdog()  # not retried before 0.5 s ...
        assert notifier.send_errors == 1
        clock.t += 0.1
        assert not notifier.watchdog()  # ... but at 0.5 s, not 5 s
        assert notifier.send_errors == 2
        notifier.ready()
        notifier.stopping()
    assert notifier.send_errors == 4
    warnings = [r for r in caplog.records if "cannot notify systemd" in r.getMessage()]
    assert len(warnings) == 1 and missing in warnings[0].getMessage()


def test_send_error_never_raises_when_the_queue_is_full(systemd):
    """systemd busy: the receive queue fills, sends fail with EAGAIN instead of blocking a frame."""
    notifier = Notifier(systemd.address)
    for _ in range(100_000):
        if not notifier.send("STATUS=" + "x" * 1000):
            break
    else:
        pytest.fail("the receive queue never filled")
    assert notifier.send_errors == 1
    systemd.pending()
    assert notifier.send("STATUS=drained")


def test_without_notify_socket_everything_is_a_cheap_no_op(monkeypatch):
    monkeypatch.setattr(socket, "socket", lambda *a, **k: pytest.fail("no socket expected"))
    notifier = Notifier.from_env({})
    assert not notifier.enabled and notifier.watchdog_interval is None
    assert not notifier.ready() and not notifier.status("x") and not notifier.watchdog()
    assert not notifier.stopping() and notifier.sent == 0 and notifier.send_errors == 0


@pytest.mark.parametrize(
    "env, enabled, interval",
    [
        ({"NOTIFY_SOCKET": "@sock", "WATCHDOG_USEC": "3000000"}, True, 3.0),
        ({"NOTIFY_SOCKET": "@sock", "WATCHDOG_USEC": "3000000", "WATCHDOG_PID": "1"}, True, None),
        ({"NOTIFY_SOCKET": "@sock", "WATCHDOG_USEC": "3000000", "WATCHDOG_PID": "x"}, True, None),
        ({"NOTIFY_SOCKET": "@sock", "WATCHDOG_USEC": "0"}, True, None),
        ({"NOTIFY_SOCKET": "@sock", "WATCHDOG_USEC": "soon"}, True, None),
        ({"NOTIFY_SOCKET": "relative/sock", "WATCHDOG_USEC": "3000000"}, False, None),
        ({"NOTIFY_SOCKET": "/" + "x" * 200}, False, None),
        ({"WATCHDOG_USEC": "3000000"}, False, None),  # a watchdog needs somewhere to ping
    ],
)
def test_from_env_accepts_only_what_systemd_would_send(env, enabled, interval, caplog):
    notifier = Notifier.from_env(env)
    assert notifier.enabled is enabled
    assert notifier.watchdog_interval == interval


def test_watchdog_pid_of_this_process_enables_the_watchdog():
    env = {"NOTIFY_SOCKET": "@sock", "WATCHDOG_USEC": "3000000", "WATCHDOG_PID": str(os.getpid())}
    assert Notifier.from_env(env).watchdog_interval == 3.0


def test_a_field_that_would_break_the_protocol_is_refused(systemd):
    notifier = Notifier(systemd.address)
    with pytest.raises(ValueError):
        notifier.send("READY=1\nWATCHDOG=1")
    with pytest.raises(ValueError):
        notifier.send("READY")
    with pytest.raises(ValueError):
        notifier.extend_timeout(float("nan"))
    assert systemd.pending() == []


def test_abstract_address_is_the_nul_prefixed_name():
    server = FakeSystemd(abstract=True)
    try:
        Notifier(server.address).ready()
        assert server.receive()[0] == ["READY=1"]
        assert Path(server.address[1:]).exists() is False
    finally:
        server.close()
