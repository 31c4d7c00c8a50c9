"""A simulated 6-axis controller that speaks the real protocol over a pseudo-terminal.

A pty is a real serial line to pyserial, so the host side under test is exactly the code that
talks to the board: the same bytes, the same handshake, the same faults. The behaviour follows
the firmware (firmware/PROTOCOL.md): a lone 0x00, HELLO seq 0 and, 160 ms later, CALIBRATION
after every reset; AXES at 100 Hz while active and for 500 ms after; a HEARTBEAT every 250 ms
while idle; HELLO_REQUEST, CALIBRATE and WATCHDOG_TEST from the host, with rx counters.

The pty's name changes with every "plug"; ``link`` is a stable symlink to it, the way
/dev/serial/by-id/... is for the real board, so a host reconnects by name.

Scripts (``exhibit simulate controller --script FILE``, ``sim://controller?script=FILE``) are
plain text, one command a line::

    axes 0.5 0 0 0 0 -1   # six deflections in [-1, 1], held until changed
    axis 3 0.25           # one axis (1-based)
    buttons 1 2           # these buttons pressed (1..5); "buttons" alone releases all
    wait 1.5              # seconds
    garbage 40            # 40 random bytes on the line
    unplug 1.0            # gone for 1 s, then plugged in again (it boots)
    hang 2.0              # silent for 2 s without a reset (a stuck USB bridge)
    watchdog              # hang until the watchdog resets the board, as WATCHDOG_TEST does
    reset                 # the reset button
    repeat                # from the top again

Why one module of this size: the script language and the byte stream it turns into are tested
together, against the real protocol."""

from __future__ import annotations

import fcntl
import os
import random
import select
import struct
import termios
import tempfile
import threading
import time
import tty
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

from pathlib import Path
from typing import Any, Protocol

from exhibit.devices import protocol as p
from exhibit.devices.base import DeviceError
from exhibit.schema.links import replace_link
import contextlib

__all__ = ["SimController", "Step", "parse_script", "ScriptPlayer"]

TICK_S = 0.010
LINGER_S = 0.500
CALIBRATION_DELAY_S = 0.160
WATCHDOG_S = 0.250
REST_C16 = 8176  # mid-scale zero reported in CALIBRATION


@dataclass(frozen=True)
class Step:
    line: int
    command: str
    args: tuple[float, ...]


_ARITY = {
    "axes": (6, 6),
    "axis": (2, 2),
    "buttons": (0, p.N_BUTTONS),
    "wait": (1, 1),
    "garbage": (1, 1),
    "unplug": (1, 1),
    "hang": (1, 1),
    "watchdog": (0, 0),
    "reset": (0, 0),
    "repeat": (0, 0),
}


def script_lines(text: str, source: str) -> Iterator[tuple[int, str, str, list[str], list[str]]]:
    """The commands of a simulator script, one a line, '#' starting a comment: yields (line
    number, where, command in lower case, its words, the words as written) per non-empty line."""
    for n, raw in enumerate(text.splitlines(), 1):
        words = raw.split("#", 1)[0].split()
        if words:
            yield n, f"{source} line {n}", words[0].lower(), words[1:], words


def parse_script(text: str, source: str = "<script>") -> list[Step]:
    """Parses a simulator script; a bad line raises DeviceError naming the file and line."""
    steps = []
    for n, where, cmd, rest, words in script_lines(text, source):
        if cmd not in _ARITY:
            raise DeviceError(
                f"{where}: unknown command {words[0]!r} (one of {', '.join(sorted(_ARITY))})"
            )
        lo, hi = _ARITY[cmd]
        if not lo <= len(rest) <= hi:
            want = f"{lo}" if lo == hi else f"{lo} to {hi}"
            raise DeviceError(f"{where}: {cmd} takes {want} numbers, got {len(rest)}")
        try:
            args = tuple(float(w) for w in rest)
        except ValueError:
            raise DeviceError(f"{where}: {cmd} needs numbers, got {' '.join(rest)!r}") from None
        bad = None
        if cmd in ("axes", "axis") and not all(
            -1 <= a <= 1 for a in args[-6 if cmd == "axes" else -1 :]
        ):
            bad = "deflections must lie in [-1, 1]"
        elif cmd == "axis" and args[0] not in range(1, 7):
            bad = "axis number must be 1..6"
        elif cmd == "buttons" and not all(a in range(1, p.N_BUTTONS + 1) for a in args):
            bad = f"button numbers must be 1..{p.N_BUTTONS}"
        elif cmd in ("wait", "unplug", "hang", "garbage") and not (0 <= args[0] < 1e6):
            bad = f"{cmd} needs a non-negative number"
        if bad:
            raise DeviceError(f"{where}: {bad}")
        steps.append(Step(n, cmd, args))
    if steps and all(s.command == "repeat" for s in steps):
        raise DeviceError(f"{source}: a script of only 'repeat' would never wait")
    return steps


class Board(Protocol):
    """What a script drives: a SimController, or the firmware in simavr (FirmwareController)."""

    rng: random.Random

    def replug(self) -> None: ...
    def set_axes(self, values: Any) -> None: ...
    def set_axis(self, index: int, value: float) -> None: ...
    def set_buttons(self, bits: int) -> None: ...
    def inject(self, data: bytes) -> None: ...
    def unplug(self) -> None: ...
    def hang(self, seconds: float) -> None: ...
    def watchdog_hang(self) -> None: ...
    def reset(self, cause: p.ResetCause) -> None: ...


class ScriptPlayer:
    """Runs script steps as simulated time passes, without a thread of its own: the simulator
    calls ``advance(now)`` every tick."""

    def __init__(self, steps: list[Step]):
        self.steps = steps
        self.index = 0
        self.resume_at = 0.0
        self._replug_at: float | None = None

    @property
    def done(self) -> bool:
        return self.index >= len(self.steps) and self._replug_at is None

    def advance(self, sim: Board, now: float) -> None:
        if self._replug_at is not None:
            if now < self._replug_at:
                return
            self._replug_at = None
            sim.replug()
        budget = 1000  # a 'repeat' of steps that never wait must not spin forever
        while now >= self.resume_at and self.index < len(self.steps) and budget:
            budget -= 1
            step = self.steps[self.index]
            self.index += 1
            a = step.args
            if step.command == "axes":
                sim.set_axes(a)
            elif step.command == "axis":
                sim.set_axis(int(a[0]) - 1, a[1])
            elif step.command == "buttons":
                sim.set_buttons(sum(1 << (int(b) - 1) for b in a))
            elif step.command == "wait":
                self.resume_at = now + a[0]
            elif step.command == "garbage":
                sim.inject(sim.rng.randbytes(int(a[0])))
            elif step.command == "unplug":
                sim.unplug()
                self._replug_at = self.resume_at = now + a[0]
                return
            elif step.command == "hang":
                sim.hang(a[0])
            elif step.command == "watchdog":
                sim.watchdog_hang()
            elif step.command == "reset":
                sim.reset(p.ResetCause.EXTERNAL)
            elif step.command == "repeat":
                self.index = 0


class SimController:
    """The controller's firmware behaviour on the master side of a pty.

    ``start()`` runs it in a daemon thread (``tick`` every 10 ms); tests that want simulated
    time call ``plug()`` and ``tick(now)`` themselves. ``link`` is the stable name to open.
    ``firmware`` and ``n_buttons`` are what its HELLO says: the current firmware by default, an
    older board with ``firmware=(1, 0, 0), n_buttons=4`` (its missing buttons never press).
    """

    def __init__(
        self,
        link: str | os.PathLike | None = None,
        *,
        firmware: tuple[int, int, int] = (1, 1, 0),
        n_buttons: int = p.N_BUTTONS,
        version: int = p.PROTOCOL_VERSION,
        heartbeat_ms: int = 250,
        script: list[Step] | None = None,
        seed: int | None = None,
        clock: Callable[[], float] = time.monotonic,
        sync: bool = False,
    ) -> None:
        self._tmpdir = None
        if link is None:
            self._tmpdir = tempfile.TemporaryDirectory(prefix="exhibit-sim-")
            link = Path(self._tmpdir.name) / "controller"
        self.link = Path(link)
        self.firmware = firmware
        self.n_buttons = n_buttons
        self.version = version
        self.heartbeat_ms = heartbeat_ms
        self.clock = clock
        # The kernel hands pty bytes to the other side in a work queue, a moment after write().
        # With sync (tests on simulated time) every write waits until the bytes are readable,
        # so a test's next step sees them however loaded the machine is.
        self.sync = sync
        self.rng = random.Random(seed)
        self.player = ScriptPlayer(script) if script else None
        self.tty = ""
        self.plugged = False
        self.rx = p.StreamDecoder()
        self.rx_ok = self.rx_rejected = 0
        self.sent_frames = 0
        self.dropped_bytes = 0
        self.bytes_written = 0
        self.resets = 0
        self._lock = threading.RLock()
        self._master = self._slave = -1
        self._axes = [0] * p.N_AXES
        self._buttons = 0
        self._zeros = (REST_C16,) * p.N_AXES
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._wdt_reset_at: float | None = None
        self._boot(self.clock(), p.ResetCause.POWER_ON, send=False)

    # ---- plugging

    def plug(self) -> None:
        """A fresh pty (a new /dev/pts/N, as a replugged USB device gets a new ttyUSBn), the
        stable link pointed at it, and the board boots."""
        with self._lock:
            if self.plugged:
                return
            master, slave = os.openpty()
            tty.setraw(slave)  # no echo or line editing before the host opens it
            os.set_blocking(master, False)
            self._master, self._slave = master, slave
            self.tty = os.ttyname(slave)
            replace_link(self.link, self.tty)
            self.plugged = True
            self.rx.reset()
            self._boot(self.clock(), p.ResetCause.POWER_ON)

    def unplug(self) -> None:
        """The cable pulled: the host's open port reads EIO, the name disappears."""
        with self._lock:
            if not self.plugged:
                return
            self.plugged = False
            for fd in (self._master, self._slave):
                with contextlib.suppress(OSError):
                    os.close(fd)
            self._master = self._slave = -1
            with contextlib.suppress(FileNotFoundError):
                self.link.unlink()

    def replug(self) -> None:
        self.unplug()
        self.plug()

    # ---- what a visitor (or a test) does

    def set_axes(self, values: Iterable[float]) -> None:
        with self._lock:
            self._axes = [_to_raw(v) for v in values]

    def set_axis(self, index: int, value: float) -> None:
        with self._lock:
            self._axes[index] = _to_raw(value)

    def set_buttons(self, bits: int) -> None:
        with self._lock:
            self._buttons = bits & ((1 << self.n_buttons) - 1)

    def inject(self, data: bytes) -> None:
        """Raw bytes on the line (garbage, partial frames)."""
        with self._lock:
            self._write(data)

    def hang(self, seconds: float) -> None:
        with self._lock:
            self._silent_until = self.clock() + seconds

    def watchdog_hang(self) -> None:
        with self._lock:
            self._wdt_reset_at = self.clock() + WATCHDOG_S

    def reset(self, cause: p.ResetCause = p.ResetCause.EXTERNAL) -> None:
        with self._lock:
            self._boot(self.clock(), cause)

    # ---- the firmware's main loop

    def _boot(self, now: float, cause: p.ResetCause, send: bool = True) -> None:
        self._t_reset = now
        self._seq = 0
        self._silent_until = 0.0
        self._wdt_reset_at = None
        self._cal_due: float | None = now + CALIBRATION_DELAY_S
        self._last_active: float | None = None
        self._next_axes = 0.0
        self._last_axes = now
        self._next_heartbeat = now + CALIBRATION_DELAY_S + self.heartbeat_ms / 1000
        if send:
            self.resets += 1
            self._write(p.DELIMITER)
            self._send(self._hello(cause))

    def tick(self, now: float | None = None) -> None:
        with self._lock:
            now = self.clock() if now is None else now
            if self.player is not None:
                self.player.advance(self, now)
            if not self.plugged:
                return
            data = self._read()
            if self._wdt_reset_at is not None:
                if now >= self._wdt_reset_at:
                    self._boot(now, p.ResetCause.WATCHDOG)
                return  # hung: nothing served, host bytes lost
            if now < self._silent_until:
                return
            for item in self.rx.feed(data):
                if isinstance(item, p.Rejected):
                    self.rx_rejected = (self.rx_rejected + 1) & 0xFFFF
                    continue
                self.rx_ok = (self.rx_ok + 1) & 0xFFFF
                self._command(item.message, now)
            if self._cal_due is not None:
                if now < self._cal_due:
                    return
                self._cal_due = None
                self._send(p.Calibration(p.CalibrationReason.POWER_UP, 0, self._zeros))
            if any(self._axes) or self._buttons:
                self._last_active = now
            if self._last_active is not None and now - self._last_active <= LINGER_S:
                if now >= self._next_axes:
                    self._send(p.Axes(self._ms(now) & 0xFFFF, tuple(self._axes), self._buttons))
                    self._next_axes = max(self._next_axes + TICK_S, now - TICK_S)
                    self._last_axes = now
                    self._next_heartbeat = now + self.heartbeat_ms / 1000
            elif now >= self._next_heartbeat:
                self._send(p.Heartbeat(self._ms(now) & 0xFFFFFFFF, self.rx_ok, self.rx_rejected))
                self._next_heartbeat = now + self.heartbeat_ms / 1000

    def _command(self, msg: p.Message, now: float) -> None:
        if isinstance(msg, p.HelloRequest):
            self._send(self._hello(p.ResetCause.POWER_ON))
        elif isinstance(msg, p.Calibrate):
            self._send(p.Calibration(p.CalibrationReason.HOST, 0, self._zeros))
        elif isinstance(msg, p.WatchdogTest) and msg.key == p.WATCHDOG_KEY:
            self._wdt_reset_at = now + WATCHDOG_S

    def _hello(self, cause: p.ResetCause) -> p.Hello:
        return p.Hello(self.firmware, 1, p.N_AXES, self.n_buttons, 100, self.heartbeat_ms, cause)

    def _ms(self, now: float) -> int:
        return int((now - self._t_reset) * 1000)

    def _send(self, msg: p.Message) -> None:
        payload = msg.pack()
        self._write(p.encode_raw(msg.TYPE, self._seq, payload, version=self.version))
        self._seq = (self._seq + 1) & 0xFF
        self.sent_frames += 1

    def _write(self, data: bytes) -> None:
        if not self.plugged:
            return
        before = _inq(self._slave) if self.sync else 0
        try:
            n = os.write(self._master, data)
        except BlockingIOError:
            n = 0  # nobody reads: the bytes are lost, as on a USB-serial bridge
        except OSError:
            return
        self.dropped_bytes += len(data) - n
        self.bytes_written += n
        if self.sync and n:
            _wait(lambda: _inq(self._slave) >= min(before + n, 4000))

    def wait_from_host(self, n: int) -> None:
        """For tests on simulated time: wait until ``n`` bytes the host wrote are readable here."""
        if self.plugged:
            _wait(lambda: _inq(self._master) >= min(n, 4000))

    def _read(self) -> bytes:
        try:
            return os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return b""

    # ---- running in a thread

    def start(self) -> SimController:
        self.plug()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="sim-controller", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        next_tick = self.clock()
        while not self._stop.is_set():
            self.tick()
            next_tick += TICK_S
            delay = next_tick - self.clock()
            if delay < -0.1:  # fell far behind (a loaded machine): do not burst to catch up
                next_tick, delay = self.clock(), 0.0
            master = self._master
            if master >= 0 and delay > 0:
                try:
                    select.select([master], [], [], delay)  # wake early for host commands
                except (OSError, ValueError):
                    time.sleep(delay)
            elif delay > 0:
                time.sleep(delay)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        self.unplug()
        if self._tmpdir is not None:
            self._tmpdir.cleanup()
            self._tmpdir = None

    def __enter__(self) -> SimController:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _inq(fd: int) -> int:
    """Bytes waiting to be read on a tty descriptor."""
    try:
        return struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]
    except OSError:
        return 1 << 30


def _wait(ready, limit: float = 2.0) -> None:
    end = time.monotonic() + limit
    while not ready() and time.monotonic() < end:
        time.sleep(0.0002)


def _to_raw(v: float) -> int:
    v = float(v)
    if not -1.0 <= v <= 1.0:
        raise ValueError(f"deflection {v} outside [-1, 1]")
    return int(round(v * p.AXIS_FULL_SCALE))
