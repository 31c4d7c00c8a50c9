"""Logging to the journal in its native protocol (exhibit.operations.journal), checked against a
unix datagram socket bound in a temporary folder standing in for journald's; and the kiosk's records
carrying EXHIBIT_MODE and EXHIBIT_SCENE, and its health file carrying the device durations."""

from __future__ import annotations

import array
import io
import json
import logging
import os
import socket
import struct
import time
from types import SimpleNamespace

import pytest

from exhibit.operations import journal
from exhibit.operations.journal import JournalHandler, encode


def decode(data: bytes) -> dict[str, str]:
    """The native protocol read back as journald does (the last value of a repeated key)."""
    fields, i = {}, 0
    while i < len(data):
        end = data.index(b"\n", i)
        line = data[i:end]
        if b"=" in line:
            key, _, value = line.partition(b"=")
            i = end + 1
        else:
            key = line
            (size,) = struct.unpack("<Q", data[end + 1 : end + 9])
            value = data[end + 9 : end + 9 + size]
            assert data[end + 9 + size : end + 10 + size] == b"\n"
            i = end + 10 + size
        fields[key.decode()] = value.decode("utf-8")
    return fields


@pytest.fixture
def journald(tmp_path):
    """A datagram socket in tmp_path where journald's would be; receive() returns the next
    message's fields (reading a passed memfd as journald does)."""
    path = tmp_path / "journal" / "socket"
    path.parent.mkdir()
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind(str(path))
    server.settimeout(5)

    def receive() -> dict[str, str]:
        fds = array.array("i")
        data, ancdata, _, _ = server.recvmsg(1 << 20, socket.CMSG_SPACE(fds.itemsize))
        for level, kind, payload in ancdata:
            if level == socket.SOL_SOCKET and kind == socket.SCM_RIGHTS:
                fds.frombytes(payload[: len(payload) - len(payload) % fds.itemsize])
        if fds:
            assert data == b""
            with os.fdopen(fds[0], "rb") as memfd:
                memfd.seek(0)  # the sender's offset is at the end; journald maps it from 0
                data = memfd.read()
        return decode(data)

    yield SimpleNamespace(path=path, receive=receive, settimeout=server.settimeout)
    server.close()


@pytest.fixture
def logger():
    """A logger of its own, so the test's handlers see only its records."""
    log = logging.getLogger(f"exhibit.test.journal.{time.monotonic_ns()}")
    log.setLevel(logging.DEBUG)
    yield log
    for h in list(log.handlers):
        log.removeHandler(h)
        h.close()


@pytest.fixture(autouse=True)
def clean_context():
    saved = dict(journal.context)
    journal.context.clear()
    yield
    journal.context.clear()
    journal.context.update(saved)


# ---------------------------------------------------------------------- the protocol


def test_encode_plain_and_binary_safe_values():
    data = encode({"MESSAGE": "hello", "TRACE": "line 1\nline 2", "N": 3, "EMPTY": ""})
    assert data == (
        b"MESSAGE=hello\n"
        + b"TRACE\n"
        + struct.pack("<Q", 13)
        + b"line 1\nline 2\n"
        + b"N=3\n"
        + b"EMPTY=\n"
    )
    assert decode(data) == {"MESSAGE": "hello", "TRACE": "line 1\nline 2", "N": "3", "EMPTY": ""}


@pytest.mark.parametrize("name", ["_PID", "lower", "1ST", "A-B", "", "É", "A" * 65])
def test_names_journald_would_refuse_are_left_out(name):
    assert encode({name: "x", "OK": "y"}) == b"OK=y\n"


def test_values_are_utf8_even_with_a_lone_surrogate():
    assert decode(encode({"MESSAGE": "scène \ud800 🌀"})) == {"MESSAGE": "scène ? 🌀"}


@pytest.mark.parametrize(
    "level, priority",
    [
        (logging.CRITICAL, 2),
        (logging.ERROR, 3),
        (logging.WARNING, 4),
        (logging.INFO, 6),
        (logging.DEBUG, 7),
        (5, 7),
    ],
)
def test_levels_become_syslog_priorities(level, priority):
    assert journal.priority(level) == priority


# ---------------------------------------------------------------------- the handler


def test_a_record_arrives_with_its_fields(journald, logger):
    handler = JournalHandler(journald.path, identifier="exhibit")
    handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    logger.addHandler(handler)
    journal.set_context(EXHIBIT_MODE="attract", EXHIBIT_SCENE="hopf")
    logger.warning("scene %s: %d problems", "hopf", 2)
    got = journald.receive()
    assert got["MESSAGE"] == f"{logger.name}: scene hopf: 2 problems"
    assert got["PRIORITY"] == "4" and got["SYSLOG_IDENTIFIER"] == "exhibit"
    assert got["LOGGER"] == logger.name
    assert got["CODE_FUNC"] == "test_a_record_arrives_with_its_fields"
    assert got["CODE_FILE"] == __file__ and int(got["CODE_LINE"]) > 0
    assert got["EXHIBIT_MODE"] == "attract" and got["EXHIBIT_SCENE"] == "hopf"
    assert got["THREAD_NAME"] == "MainThread"


def test_extra_fields_override_the_context_and_none_removes(journald, logger):
    logger.addHandler(JournalHandler(journald.path))
    journal.set_context(EXHIBIT_MODE="attract", EXHIBIT_SCENE="hopf")
    logger.info("x", extra={"EXHIBIT_SCENE": "veronese", "lowercase": "not a field"})
    got = journald.receive()
    assert got["EXHIBIT_SCENE"] == "veronese" and "lowercase" not in got
    journal.set_context(EXHIBIT_SCENE=None)
    logger.info("y")
    assert "EXHIBIT_SCENE" not in journald.receive()
    with pytest.raises(ValueError):
        journal.set_context(_PID="1")


def test_a_traceback_arrives_whole_in_the_binary_safe_form(journald, logger):
    logger.addHandler(JournalHandler(journald.path))
    try:
        raise ZeroDivisionError("a bug\nover two lines")
    except ZeroDivisionError:
        logger.exception("a frame failed")
    got = journald.receive()
    assert got["PRIORITY"] == "3"
    assert got["MESSAGE"].startswith("a frame failed\nTraceback (most recent call last):")
    assert got["MESSAGE"].endswith("ZeroDivisionError: a bug\nover two lines")


def test_a_record_too_large_for_a_datagram_goes_in_a_sealed_memfd(journald, logger):
    logger.addHandler(JournalHandler(journald.path))
    big = "x" * (4 << 20)  # beyond any datagram the socket takes
    logger.info("%s", big)
    assert journald.receive()["MESSAGE"] == big


def test_without_the_journal_records_go_to_the_fallback(tmp_path, logger):
    out = io.StringIO()
    fallback = logging.StreamHandler(out)
    handler = JournalHandler(tmp_path / "no-socket", fallback=fallback)
    handler.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    logger.addHandler(handler)
    logger.error("still seen")
    assert out.getvalue() == "ERROR still seen\n" and handler.failures == 1


def test_a_full_journal_never_blocks_the_caller(journald, logger):
    """Nobody reads the socket: once its queue is full, records go to the fallback at once."""
    out = io.StringIO()
    handler = JournalHandler(journald.path, fallback=logging.StreamHandler(out))
    logger.addHandler(handler)
    start = time.monotonic()
    for i in range(3000):
        logger.info("record %d", i)
    assert time.monotonic() - start < 10
    assert handler.failures > 0 and out.getvalue().count("\n") == handler.failures


# ---------------------------------------------------------------------- install


@pytest.fixture
def stream(tmp_path):
    with open(tmp_path / "stderr", "w") as f:
        yield f


def journal_stream(f) -> dict[str, str]:
    info = os.fstat(f.fileno())
    return {"JOURNAL_STREAM": f"{info.st_dev}:{info.st_ino}"}


def test_install_replaces_the_stderr_handler_when_stderr_is_the_journal(journald, logger, stream):
    old = logging.StreamHandler(stream)
    old.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    old.setLevel(logging.INFO)
    logger.addHandler(old)
    handler = journal.install(journal_stream(stream), stream, journald.path, logger)
    assert isinstance(handler, JournalHandler) and logger.handlers == [handler]
    assert handler.fallback is old and handler.level == logging.INFO
    assert journal.install(journal_stream(stream), stream, journald.path, logger) is handler
    logger.debug("below the level")
    logger.info("hello")
    assert journald.receive()["MESSAGE"] == f"{logger.name}: hello"


@pytest.mark.parametrize("case", ["no variable", "another file", "garbage", "no socket"])
def test_install_leaves_logging_alone_unless_stderr_is_the_journal(
    journald, logger, stream, tmp_path, case
):
    old = logging.StreamHandler(stream)
    logger.addHandler(old)
    env, path = journal_stream(stream), journald.path
    if case == "no variable":
        env = {}
    elif case == "another file":
        with open(tmp_path / "other", "w") as other:
            env = journal_stream(other)
    elif case == "garbage":
        env = {"JOURNAL_STREAM": "x:y"}
    else:
        path = tmp_path / "nothing"
    assert journal.install(env, stream, path, logger) is None
    assert logger.handlers == [old]


# ---------------------------------------------------------------------- the kiosk


@pytest.fixture
def kiosk_journal(journald):
    """The journal handler on the root logger for the kiosk's records, taken off afterwards."""
    handler = JournalHandler(journald.path)
    root = logging.getLogger()
    root.addHandler(handler)
    level = root.level
    root.setLevel(logging.INFO)
    yield journald
    root.removeHandler(handler)
    root.setLevel(level)
    handler.close()


def all_received(journald) -> list[dict]:
    journald.settimeout(0.2)
    out = []
    while True:
        try:
            out.append(journald.receive())
        except TimeoutError:
            return out


def test_kiosk_records_carry_the_mode_and_scene(tmp_path, monkeypatch, kiosk_journal):
    from tests.kiosk.support import kiosk

    k, _ = kiosk(tmp_path, monkeypatch)
    for _ in range(5):
        k.tick(k.clock())
    k.devices.keyboard.key("space", True)  # a visitor takes over
    k.tick(k.clock())
    k.window.fail = 1  # and the next frame raises
    for _ in range(5):
        k.tick(k.clock())
    k.devices.close()
    records = [r for r in all_received(kiosk_journal) if r["LOGGER"] == "exhibit.kiosk"]
    mode = next(r for r in records if r["MESSAGE"].startswith("mode visitor"))
    assert mode["EXHIBIT_MODE"] == "visitor" and mode["EXHIBIT_SCENE"] == k.state.frame.scene
    error = next(r for r in records if r["MESSAGE"].startswith("a frame failed"))
    assert error["PRIORITY"] == "3" and error["EXHIBIT_MODE"] == "visitor"
    assert error["EXHIBIT_SCENE"] == k.state.frame.scene
    assert "ZeroDivisionError" in error["MESSAGE"]


def test_kiosk_with_no_scene_logs_mode_notice(tmp_path, monkeypatch, kiosk_journal):
    from tests.kiosk.support import kiosk

    k, _ = kiosk(tmp_path, monkeypatch, broken=True)
    assert k.state is None and journal.context == {"EXHIBIT_MODE": "notice"}


def test_the_health_file_has_each_devices_state_and_durations(tmp_path, monkeypatch):
    from tests.kiosk.support import kiosk

    k, _ = kiosk(tmp_path, monkeypatch)
    k.run(max_frames=30)
    data = json.loads((tmp_path / "health.json").read_text())
    assert data["devices"], data
    for device in data["devices"]:
        assert set(device) == {"name", "url", "state", "state_s", "missing_s"}
        assert device["state"] == "connected" and device["missing_s"] is None
        assert device["state_s"] > 0
