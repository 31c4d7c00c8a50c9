"""The external tools the exhibit runs (espeak-ng for speech, ffmpeg for MP4s): every time limit
on them in one place, and a runner that bounds a tool's time and output and ties its life to
the exhibit's.

How no tool outlives its caller. Each tool starts in a process group of its own (a new
session: the terminal's Ctrl+C and the caller's process group never reach it by accident, and
the whole group, with anything the tool started, can be killed at once). On every way out of
:func:`run` (answer, error, time limit, an exception in the calling thread) the group gets
SIGKILL. That leaves the caller dying while a tool runs: a clean exit, Ctrl+C, SIGTERM, or
SIGKILL, which runs no handler at all. For that the exhibit starts one small **warden**
process, on its first tool: a ``python -I -S`` loop (about 15 ms to start, once) in a session
of its own, reading a pipe whose only write end the exhibit holds (close-on-exec, and closed in
a fork's child). The exhibit writes ``+PGID`` when a tool starts and ``-PGID`` when it is done;
when the pipe reads end-of-file, which the kernel makes happen however the exhibit ended, the
warden sends SIGKILL to every group still listed and exits. An atexit handler also kills them
at once on a normal exit. So that no tool runs before the warden knows it, a tool starts behind
a gate: ``/bin/bash -p`` (Debian's essential shell, with no startup file or imported function;
dash cannot name a descriptor above 9) waits
for a line on a second pipe, written once ``+PGID`` is, and only then becomes the tool
(``exec``); if the exhibit dies first, the gate reads end-of-file and exits.

Why not the alternatives: PR_SET_PDEATHSIG through prctl in a ``preexec_fn`` is unsafe in a
threaded program (the kiosk speaks from worker threads: a fork may copy a held lock), it
fires when the *thread* that started the tool ends rather than the process, and it reaches
only the tool, not what the tool started; ``setpriv --pdeathsig`` as a wrapper has the same
thread and group limits and needs util-linux; signal handlers (SIGTERM, SIGINT) would take
signals over from the kiosk and the commands, and still miss SIGKILL. The warden needs none of
that, and costs a bash exec (a few milliseconds) a tool.

A tool's output is read as bytes (decoded, where shown, with :func:`text`: anything that is not
UTF-8 is replaced), from both pipes at once, so a tool that fills one cannot block on it.
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import logging
import os
import selectors
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

log = logging.getLogger(__name__)

# ------------------------------------------------------------------------------------ limits
#: One call of espeak-ng: it speaks the longest text the exhibit allows (2000 characters) in
#: 0.15 s and a shipped segment in 20 ms, so 20 s leaves room for a machine whose cores are
#: busy drawing the kiosk's frames; an engine silent that long has hung (a broken voice or
#: audio setting), and waiting longer would only keep a visitor or an installer waiting.
ESPEAK_CALL_S = 20.0
#: All the speech one command makes (check-config, prepare, render --narration), summed over
#: its segments: about 100 times the 1.3 s the shipped 60 segments take, and well inside the
#: 300 s that `exhibit update` gives check-config (exhibit/commands/_releases.py). A slow
#: engine, not hung but over this, leaves the remaining segments unspoken, named.
SPEECH_TOTAL_S = 120.0
#: ffmpeg silent this long has hung: while it encodes it reports its progress twice a second
#: (-progress), and no single frame, even 8192 x 8192, takes it a minute.
FFMPEG_STALL_S = 60.0
#: The most one MP4 may take in all, however it progresses: 10 minutes, plus 1 s a million
#: pixels of frames (libx264 encodes about 30 million a second on one core: 30 times slower
#: still finishes; the largest job render allows, 2**34 pixels, gets about 5 hours).
FFMPEG_BASE_S = 600.0
FFMPEG_S_PER_MPIX = 1.0
# -------------------------------------------------------------------------------------------

#: The warden (module docstring): kill every listed group once stdin reads end-of-file.
_WARDEN = r"""
import os, signal
signal.signal(signal.SIGINT, signal.SIG_IGN)
groups, rest = set(), b""
while True:
    try:
        chunk = os.read(0, 4096)
    except InterruptedError:
        continue
    except OSError:
        break
    if not chunk:
        break
    *lines, rest = (rest + chunk).split(b"\n")
    for line in lines:
        if line[:1] in (b"+", b"-") and line[1:].isdigit():
            (groups.add if line[:1] == b"+" else groups.discard)(int(line[1:]))
for pgid in groups:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except OSError:
        pass
"""


class ToolHung(Exception):
    """The tool gave no answer in time. ``seconds``: the limit it ran past; ``stalled``: it
    went silent (the stall limit) rather than ran out of its whole time; ``out``/``err``: what
    it had written."""

    def __init__(self, tool: str, seconds: float, stalled: bool, out: bytes, err: bytes):
        super().__init__(f"{tool} did not answer within {seconds:g} s")
        self.tool, self.seconds, self.stalled, self.out, self.err = tool, seconds, stalled, out, err


class ToolOutputTooLarge(Exception):
    """The tool wrote more than it may (``stream``: "stdout" or "stderr", ``limit`` bytes)."""

    def __init__(self, tool: str, stream: str, limit: int):
        super().__init__(f"{tool} wrote over {limit} bytes on {stream}")
        self.tool, self.stream, self.limit = tool, stream, limit


@dataclass(frozen=True)
class Finished:
    """A tool that ended by itself: its exit status and what it wrote."""

    code: int
    out: bytes
    err: bytes


class _Warden:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._fd: int | None = None
        self._process: subprocess.Popen | None = None
        self._groups: set[int] = set()

    def _start(self) -> None:
        if self._fd is not None:
            return
        read, write = os.pipe()  # both close-on-exec: no tool inherits the write end
        try:
            self._process = subprocess.Popen(
                [sys.executable, "-I", "-S", "-c", _WARDEN],
                stdin=read,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        except OSError as exc:
            os.close(write)
            log.warning("no warden for external tools (%s): one may outlive a crash", exc)
            return
        finally:
            os.close(read)
        self._fd = write

    def _tell(self, message: bytes) -> None:
        if self._fd is None:
            return
        try:
            os.write(self._fd, message)
        except OSError:  # the warden was killed: tools are still killed by run() and atexit
            os.close(self._fd)
            self._fd = None

    def ready(self) -> None:
        with self._lock:
            self._start()

    def watch(self, pgid: int) -> None:
        with self._lock:
            self._start()
            self._groups.add(pgid)
            self._tell(b"+%d\n" % pgid)

    def release(self, pgid: int) -> None:
        with self._lock:
            self._groups.discard(pgid)
            self._tell(b"-%d\n" % pgid)

    def kill_all(self) -> None:
        with self._lock:
            groups = list(self._groups)
        for pgid in groups:
            with contextlib.suppress(OSError):
                os.killpg(pgid, signal.SIGKILL)

    def forget(self) -> None:
        """In a fork's child: the parent's tools and warden are the parent's."""
        self._lock = threading.Lock()
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
        self._fd, self._process, self._groups = None, None, set()


_warden = _Warden()
atexit.register(_warden.kill_all)
os.register_at_fork(after_in_child=_warden.forget)


#: The gate a tool starts behind (module docstring): a line on fd {fd}, then the tool itself.
_GATE = 'read -r go <&{fd} || exit 125; exec {fd}<&-; exec "$@"'
_SHELL = "/bin/bash"


def start(command: Sequence[str], *, stdin: bool = False, env: dict | None = None):
    """``command`` started in a new session, its pipes open (stdin only if ``stdin``), watched
    by the warden before it runs: stop it with :func:`stop`. OSError when it cannot be
    started (FileNotFoundError when it is not there)."""
    name, path = command[0], (env if env is not None else os.environ).get("PATH")
    if not (os.access(name, os.X_OK) if "/" in name else shutil.which(name, path=path)):
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), command[0])
    _warden.ready()
    gate, opener = os.pipe()
    # without bash (not Debian) the tool runs ungated: a kill in the moment before it is
    # watched may leave it running
    gated = (
        [_SHELL, "-p", "-c", _GATE.format(fd=gate), "gate"] if os.access(_SHELL, os.X_OK) else []
    )
    try:
        process = subprocess.Popen(
            [*gated, *command],
            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=env,
            start_new_session=True,
            pass_fds=(gate,) if gated else (),
        )
    except BaseException:
        os.close(opener)
        raise
    finally:
        os.close(gate)
    try:
        _warden.watch(process.pid)
        if gated:
            os.write(opener, b"go\n")
    except BaseException:
        stop(process)
        raise
    finally:
        os.close(opener)
    return process


def stop(process: subprocess.Popen) -> None:
    """SIGKILL to ``process``'s whole group (sent while its leader is unreaped, so the group's
    number cannot have been reused), then reap it and close its pipes."""
    with contextlib.suppress(OSError):
        os.killpg(process.pid, signal.SIGKILL)
    _warden.release(process.pid)
    with contextlib.suppress(subprocess.TimeoutExpired):
        process.wait(timeout=10)  # SIGKILL cannot be refused; only a stuck disk delays it
    for stream in (process.stdin, process.stdout, process.stderr):
        if stream is not None:
            with contextlib.suppress(OSError):
                stream.close()


def _exited(pid: int) -> bool:
    """Whether ``pid`` has exited, without reaping it (its group number stays reserved)."""
    try:
        return os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
    except ChildProcessError:
        return True


def run(
    command: Sequence[str],
    stdin: bytes = b"",
    *,
    limit_s: float,
    stall_s: float | None = None,
    max_out: int = 1 << 26,
    max_err: int = 1 << 16,
    tail: bool = False,
    env: dict | None = None,
) -> Finished:
    """Run ``command`` (started as :func:`start` does) with ``stdin`` as its input, until it
    exits. ToolHung after ``limit_s`` seconds in all, or ``stall_s`` seconds without a byte
    written; ToolOutputTooLarge past ``max_out`` bytes of stdout or ``max_err`` of stderr
    (with ``tail``, only their last so many bytes are kept instead). However it ends, the
    tool's whole group is killed before this returns."""
    tool = os.path.basename(command[0])
    process = start(command, stdin=bool(stdin), env=env)
    out, err = bytearray(), bytearray()
    streams = {"stdout": (out, max_out), "stderr": (err, max_err)}
    begun = last = time.monotonic()
    deadline = begun + limit_s

    def hung(stalled: bool) -> ToolHung:
        seconds = stall_s if stalled and stall_s is not None else limit_s
        return ToolHung(tool, seconds, stalled, bytes(out), bytes(err))

    try:
        with selectors.DefaultSelector() as selector:
            assert process.stdout is not None and process.stderr is not None
            selector.register(process.stdout, selectors.EVENT_READ, "stdout")
            selector.register(process.stderr, selectors.EVENT_READ, "stderr")
            pending = memoryview(stdin)
            if process.stdin is not None:
                os.set_blocking(process.stdin.fileno(), False)
                selector.register(process.stdin, selectors.EVENT_WRITE, "stdin")
            while selector.get_map():
                now = time.monotonic()
                until = deadline if stall_s is None else min(deadline, last + stall_s)
                if now >= until:
                    raise hung(stalled=until < deadline)
                for key, _ in selector.select(until - now):
                    if key.data == "stdin":
                        try:
                            pending = pending[os.write(key.fd, pending) :]
                        except BrokenPipeError:  # the tool stopped reading: its answer says why
                            pending = pending[:0]
                        if not pending:
                            selector.unregister(key.fileobj)
                            key.fileobj.close()  # type: ignore[union-attr]
                        continue
                    chunk = os.read(key.fd, 1 << 16)
                    if not chunk:
                        selector.unregister(key.fileobj)
                        continue
                    last = time.monotonic()
                    buffer, most = streams[key.data]
                    buffer.extend(chunk)
                    if len(buffer) > most:
                        if not tail:
                            raise ToolOutputTooLarge(tool, key.data, most)
                        del buffer[:-most]
        pause = 0.001
        while not _exited(process.pid):  # both pipes closed: it ends now, or it has hung
            now = time.monotonic()
            if now >= deadline:
                raise hung(stalled=False)
            time.sleep(min(pause, deadline - now))
            pause = min(pause * 2, 0.05)
    finally:
        stop(process)
    return Finished(process.returncode, bytes(out), bytes(err))


def text(data: bytes | str | None) -> str:
    """A tool's output as text: UTF-8, anything else replaced (a tool may print any bytes)."""
    if isinstance(data, bytes):
        return data.decode("utf-8", errors="replace")
    return data or ""


def last_line(data: bytes, width: int = 200) -> str:
    """The last line a tool wrote that says something, on one line and at most ``width``
    characters, control characters and undecodable bytes replaced."""
    for line in reversed(text(data).splitlines()):
        shown = "".join(c if c.isprintable() else "\ufffd" for c in " ".join(line.split()))
        if shown:
            return shown if len(shown) <= width else shown[: width - 1] + "…"
    return ""
