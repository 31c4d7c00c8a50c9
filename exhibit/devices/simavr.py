"""The real controller firmware as the simulator: the built .elf runs in simavr
(firmware/sim/harness.c), whose UART is a pseudo-terminal that the exhibit opens as it opens the
board's serial port.

The protocol-level simulator (:mod:`exhibit.devices.sim`) is faster and starts instantly; this
one runs the very bytes that are flashed, so what it shows is what the board does: its ADC
scaling, filters, dead zone, timing, EEPROM and watchdog. ``exhibit simulate controller
--firmware ...`` and the end-to-end tests (tests/firmware/test_end_to_end.py) use it.

:class:`Harness` is one harness process: commands on its stdin (``adc``, ``pin``, ``run``, ...),
replies and reset notices on its stdout. :class:`FirmwareController` is a plugged-in board: a
harness behind a stable symlink (like /dev/serial/by-id/...), an EEPROM image kept in a file
across "power cycles", and the simulator's script language (:mod:`exhibit.devices.sim`), where
a deflection in [-1, 1] is a voltage on the pot's wiper (0 V .. Vcc, rest at Vcc/2).

Why one module of this size: the emulator's C bindings and the board's pins and timing belong
together."""

from __future__ import annotations

import os
import queue
import random
import subprocess
import tempfile
import threading
import time
from collections.abc import Iterable
from pathlib import Path


from exhibit.devices import protocol as p
from exhibit.devices.base import DeviceError
from exhibit.devices.sim import ScriptPlayer, Step
from exhibit.schema.links import replace_link
import contextlib

__all__ = [
    "Harness",
    "FirmwareController",
    "find_harness",
    "check_elf",
    "deflection_mv",
    "VCC_MV",
    "REST_MV",
    "BUTTON_PINS",
    "EEPROM_SIZE",
    "HARNESS_PACKAGES",
]

VCC_MV = 5000
REST_MV = VCC_MV // 2
BUTTON_PINS = {1: 2, 2: 3, 3: 4, 4: 5, 5: 6}  # button -> PDn (firmware/controller/config.h)
EEPROM_SIZE = 1024  # ATmega328P
HARNESS_PACKAGES = "gcc make pkg-config libsimavr-dev libelf-dev"
ROOT = Path(__file__).resolve().parents[2]
_EM_AVR = 83  # ELF e_machine of Atmel AVR


def deflection_mv(v: float) -> int:
    """The wiper voltage of a pot deflected by v in [-1, 1] (rest at mid-scale)."""
    if not -1.0 <= v <= 1.0:
        raise ValueError(f"deflection {v} outside [-1, 1]")
    return round(REST_MV + v * REST_MV)


def check_elf(path: Path) -> Path:
    """``path`` if it is an AVR ELF file; DeviceError saying what it is otherwise."""
    path = Path(path)
    try:
        head = path.read_bytes()[:20]
    except OSError as exc:
        hint = (
            " (build it: make -C firmware controller)" if isinstance(exc, FileNotFoundError) else ""
        )
        raise DeviceError(
            f"{path}: cannot read the firmware: {exc.strerror or exc}{hint}"
        ) from None
    if head[:4] != b"\x7fELF" or len(head) < 20:
        raise DeviceError(f"{path}: not an ELF file (give the .elf, not the .hex)")
    machine = int.from_bytes(head[18:20], "little")
    if machine != _EM_AVR:
        raise DeviceError(f"{path}: an ELF file for machine {machine}, not for the AVR")
    return path


def find_harness(elf: Path | None = None, harness: Path | None = None) -> Path:
    """The harness binary: ``harness`` if given, else $EXHIBIT_SIM_HARNESS, else
    sim/harness beside the firmware's build directory, else firmware/build/sim/harness."""
    if harness is None and os.environ.get("EXHIBIT_SIM_HARNESS"):
        harness = Path(os.environ["EXHIBIT_SIM_HARNESS"])
    if harness is not None:
        candidates = [Path(harness)]
    else:
        candidates = []
        if elf is not None:
            elf = Path(elf).resolve()
            candidates += [elf.parent.parent / "sim" / "harness", elf.parent / "sim" / "harness"]
        candidates.append(ROOT / "firmware" / "build" / "sim" / "harness")
    for c in candidates:
        if c.is_file() and os.access(c, os.X_OK):
            return c
    raise DeviceError(
        f"{candidates[0]}: the simavr harness is not built: make -C firmware sim "
        f"(Debian: apt-get install {HARNESS_PACKAGES})"
    )


class Harness:
    """One harness process running ``elf``; ``pty`` is the serial port to open.

    The CPU waits for :meth:`run`, so a host can open the pty first and see the boot frames.
    ``resets`` collects the simulated times (s) of CPU resets (the watchdog, ...)."""

    def __init__(
        self,
        elf: Path,
        *,
        harness: Path | None = None,
        speed: float = 1.0,
        eeprom: Path | None = None,
        log: Path | None = None,
        timeout: float = 10.0,
    ):
        elf = check_elf(elf)
        exe = find_harness(elf, harness)
        self.timeout = timeout
        self._tmp = None
        if log is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="exhibit-harness-")
            log = Path(self._tmp.name) / "harness.log"
        self.log_path = Path(log)
        self._log = open(self.log_path, "w")  # noqa: SIM115 - the harness's log while it runs
        cmd = [str(exe), "--speed", f"{speed:g}"]
        if eeprom is not None:
            cmd += ["--eeprom", str(eeprom)]
        self.proc = subprocess.Popen(
            cmd + [str(elf)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._log,
            text=True,
            bufsize=1,
        )
        self.replies: queue.Queue[str | None] = queue.Queue()
        self.resets: list[float] = []
        self._lock = threading.Lock()
        self._reader = threading.Thread(target=self._read, name="harness-reader", daemon=True)
        self._reader.start()
        try:
            line = self._reply("start")
        except DeviceError:
            self.close()
            raise
        if not line.startswith("pty "):
            self.close()
            raise DeviceError(f"{exe}: unexpected first line {line!r}")
        self.pty = line.split(" ", 1)[1]

    def _read(self) -> None:
        assert self.proc.stdout is not None  # Popen(stdout=PIPE)
        for line in self.proc.stdout:
            line = line.strip()
            if line.startswith("reset at "):
                self.resets.append(int(line.split()[-1]) / 1e6)
            else:
                self.replies.put(line)
        self.replies.put(None)  # the process ended

    def _reply(self, what: str) -> str:
        try:
            line = self.replies.get(timeout=self.timeout)
        except queue.Empty:
            raise DeviceError(
                f"simavr harness: no answer to {what!r} in {self.timeout:g} s"
            ) from None
        if line is None:
            self.replies.put(None)
            raise DeviceError(f"simavr harness stopped ({what!r}): {self.log_tail()}")
        return line

    def log_tail(self, n: int = 5) -> str:
        try:
            lines = self.log_path.read_text(errors="replace").splitlines()
        except OSError:
            return "no log"
        lines = [line for line in lines if not line.startswith("Loaded ")]
        return " | ".join(lines[-n:]) or f"exit status {self.proc.poll()}"

    def cmd(self, text: str) -> str:
        """Sends one command and returns its "ok ..." reply; DeviceError otherwise."""
        with self._lock:
            assert self.proc.stdin is not None  # Popen(stdin=PIPE)
            try:
                self.proc.stdin.write(text + "\n")
                self.proc.stdin.flush()
            except (BrokenPipeError, ValueError, OSError):
                raise DeviceError(f"simavr harness stopped: {self.log_tail()}") from None
            reply = self._reply(text)
        if not reply.startswith("ok"):
            raise DeviceError(f"simavr harness: {text!r}: {reply}")
        return reply

    # ---- the board's inputs and the CPU

    def adc(self, ch: int, mv: int) -> None:
        self.cmd(f"adc {ch} {mv}")

    def pin(self, port: str, bit: int, level: int) -> None:
        self.cmd(f"pin {port} {bit} {level}")

    def button(self, n: int, pressed: bool) -> None:
        self.pin("D", BUTTON_PINS[n], 0 if pressed else 1)  # to GND, pull-up

    def run(self) -> None:
        self.cmd("run")

    def pause(self) -> None:
        self.cmd("pause")

    def reset(self) -> None:
        self.cmd("reset")

    def uart(self, data: bytes) -> None:
        """Bytes into the firmware's UART, as if the host had sent them."""
        if data:
            self.cmd(f"uart {data.hex()}")

    def tx(self, data: bytes) -> None:
        """Bytes on the line towards the host, beside the firmware's (noise)."""
        if data:
            self.cmd(f"tx {data.hex()}")

    def sim_time(self) -> float:
        """Simulated seconds since the harness started."""
        return int(self.cmd("time").split()[-1]) / 1e6

    def line_bytes(self) -> tuple[int, int]:
        """Bytes on the line so far: (sent towards the host, received from the host).

        With the CPU paused, the first is where the host's stream stands at this simulated
        instant; the second grows once the harness has taken what the host wrote, so a test
        can tie either to simulated time however late the machine runs it."""
        words = self.cmd("bytes").split()
        return int(words[3]), int(words[5])

    def stats(self) -> dict[str, int]:
        """CPU load since the last call: bursts, max_burst, max_window, window (cycles)."""
        words = self.cmd("stats").split()[2:]
        return {k: int(v) for k, v in zip(words[::2], words[1::2])}

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def kill(self) -> None:
        """Gone at once, as a pulled cable (the EEPROM image keeps its last write)."""
        if self.alive:
            self.proc.kill()
        self.close()

    def close(self) -> None:
        if self.alive:
            with contextlib.suppress(DeviceError):
                self.cmd("quit")
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for f in (self.proc.stdin, self.proc.stdout):
            assert f is not None  # Popen(stdin=PIPE, stdout=PIPE)
            with contextlib.suppress(OSError):
                f.close()
        self._log.close()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None


class FirmwareController:
    """The controller firmware in simavr as a plugged-in board, behind a stable ``link``.

    Unplugging stops the harness (its pty disappears: the host's read fails, as with a pulled
    USB cable); plugging starts a new one (a new /dev/pts/N, the link moved to it) with the same
    EEPROM image, so a stored calibration survives, as on the chip. ``eeprom`` names that image
    (default: a temporary file, erased at the first start).
    """

    def __init__(
        self,
        elf: Path,
        link: str | os.PathLike | None = None,
        *,
        harness: Path | None = None,
        eeprom: Path | None = None,
        speed: float = 1.0,
        script: list[Step] | None = None,
        seed: int | None = None,
        log_dir: Path | None = None,
    ):
        self.elf = check_elf(elf)
        self.harness_exe = find_harness(self.elf, harness)
        self._tmpdir = tempfile.TemporaryDirectory(prefix="exhibit-fwsim-")
        tmp = Path(self._tmpdir.name)
        self.link = Path(link) if link is not None else tmp / "controller"
        self.eeprom = Path(eeprom) if eeprom is not None else tmp / "eeprom.bin"
        self.log_dir = Path(log_dir) if log_dir is not None else tmp
        self.speed = speed
        self.rng = random.Random(seed)
        self.player = ScriptPlayer(script) if script else None
        self.harness: Harness | None = None
        self.plugs = 0
        self.tty = ""
        self._mv = [REST_MV] * p.N_AXES
        self._buttons = 0
        self._paused_until: float | None = None
        self._seq = 0
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        #: why the running thread stopped (the harness died): the command reports it
        self.error: DeviceError | None = None

    @property
    def plugged(self) -> bool:
        return self.harness is not None

    # ---- plugging

    def plug(self, run: bool = True) -> None:
        """Power on: a new harness, the inputs as they are now, the link pointed at its pty.
        ``run=False`` holds the CPU until :meth:`run`, so a host can open the port first and see
        the boot frames (as a Nano's reset on opening the port shows them)."""
        with self._lock:
            if self.harness is not None:
                return
            self.plugs += 1
            h = Harness(
                self.elf,
                harness=self.harness_exe,
                speed=self.speed,
                eeprom=self.eeprom,
                log=self.log_dir / f"harness-{self.plugs}.log",
            )
            try:
                for ch, mv in enumerate(self._mv):
                    h.adc(ch, mv)
                for n in BUTTON_PINS:
                    h.button(n, bool(self._buttons >> (n - 1) & 1))
                replace_link(self.link, h.pty)
                if run:
                    h.run()
            except BaseException:
                h.close()
                raise
            self.harness, self.tty = h, h.pty
            self._paused_until = None

    def run(self) -> None:
        """Starts the CPU of a board plugged with ``run=False``."""
        with self._lock:
            if self.harness is not None:
                self.harness.run()

    def unplug(self, hard: bool = False) -> None:
        """Power off: the link removed, the harness stopped (``hard``: killed, no goodbye)."""
        with self._lock:
            h, self.harness = self.harness, None
            if h is None:
                return
            self.link.unlink(missing_ok=True)
            if hard:
                h.kill()
            else:
                h.close()

    def replug(self) -> None:
        self.unplug()
        self.plug()

    # ---- inputs (the script language of exhibit.devices.sim)

    def set_volts(self, ch: int, mv: int) -> None:
        with self._lock:
            self._mv[ch] = mv
            if self.harness is not None:
                self.harness.adc(ch, mv)

    def set_axes(self, values: Iterable[float]) -> None:
        for ch, v in enumerate(values):
            self.set_volts(ch, deflection_mv(v))

    def set_axis(self, index: int, value: float) -> None:
        self.set_volts(index, deflection_mv(value))

    def set_buttons(self, bits: int) -> None:
        with self._lock:
            self._buttons = bits & ((1 << len(BUTTON_PINS)) - 1)
            if self.harness is not None:
                for n in BUTTON_PINS:
                    self.harness.button(n, bool(self._buttons >> (n - 1) & 1))

    def inject(self, data: bytes) -> None:
        with self._lock:
            if self.harness is not None:
                self.harness.tx(data)

    def send_to_firmware(self, message: p.Message) -> None:
        """A host command straight into the UART (the script's ``watchdog``)."""
        with self._lock:
            if self.harness is not None:
                self.harness.uart(p.encode_frame(message, self._seq))
                self._seq = (self._seq + 1) & 0xFF

    def hang(self, seconds: float) -> None:
        """The CPU stopped for ``seconds`` (no reset): a hung line as the host sees it."""
        with self._lock:
            if self.harness is not None:
                self.harness.pause()
                self._paused_until = time.monotonic() + seconds

    def watchdog_hang(self) -> None:
        self.send_to_firmware(p.WatchdogTest())

    def reset(self, cause: p.ResetCause | None = None) -> None:
        with self._lock:
            if self.harness is not None:
                self.harness.reset()

    # ---- running in a thread

    def tick(self, now: float | None = None) -> None:
        with self._lock:
            now = time.monotonic() if now is None else now
            if self._paused_until is not None and now >= self._paused_until:
                self._paused_until = None
                if self.harness is not None:
                    self.harness.run()
            if self.harness is not None and not self.harness.alive:
                raise DeviceError(f"the simavr harness stopped: {self.harness.log_tail()}")
            if self.player is not None:
                self.player.advance(self, now)

    def start(self) -> FirmwareController:
        self.plug()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="fw-controller", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.wait(0.01):
            try:
                self.tick()
            except DeviceError as exc:
                self.error = exc
                return

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        self.unplug()
        self._tmpdir.cleanup()

    def __enter__(self) -> FirmwareController:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
