"""The host side of the 6-axis controller (firmware/PROTOCOL.md) over a serial line.

Life cycle, all driven from the non-blocking ``poll()``:

- open the port (a missing port is not an error: WAITING, or LOST if it was connected before,
  retried every ``retry_s`` by exhibit.devices.reconnect, which HID devices share);
- handshake: send HELLO_REQUEST, wait for HELLO (resent every 0.5 s), CONNECTING meanwhile;
- CONNECTED: AXES become ABS/BUTTON events, stamped on the device's clock; HEARTBEATs only prove
  the line is alive;
- silence for four heartbeat periods, a read error (unplug shows as EIO) or a hung handshake:
  LOST, the port is closed (no descriptor is kept for a device that is gone) and release events
  zero whatever the controller held; the port is reopened every ``retry_s`` by its stable name
  (/dev/serial/by-id/..., or the udev SYMLINK), so a replugged board resumes within about
  ``retry_s`` plus its boot time.

The port is read with timeout 0 and at most ``max_read`` bytes per poll, so a flood at full baud
costs the render loop a bounded amount of work per frame and never blocks it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import serial

from exhibit.devices import protocol as p
from exhibit.devices.base import Capabilities, Event, Kind, State
from exhibit.devices.reconnect import ReconnectingBackend
import contextlib

__all__ = ["SerialController", "DeviceClock"]


class DeviceClock:
    """Maps the controller's 16-bit millisecond clock onto the host's monotonic timeline.

    The offset is the smallest (arrival - device time) seen: the frame that waited least in
    the USB and OS buffers. It follows crystal drift slowly and re-anchors after a jump (a reset,
    a long gap), so a stamp is never later than the frame's arrival.
    """

    FOLLOW = 0.001  # per frame towards a later offset: follows ~100 ppm drift, not jitter
    JUMP_S = 0.25  # later than this: the device clock jumped, start again

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._raw: int | None = None
        self._ms = 0
        self._offset: float | None = None
        self._last_arrival = 0.0
        self._last_stamp = float("-inf")

    def stamp(self, t_ms: int, arrival: float) -> float:
        if self._raw is None or arrival - self._last_arrival > 30.0:  # 65.5 s wrap: ambiguous
            self._ms, self._offset, self._last_stamp = t_ms, None, float("-inf")
        else:
            self._ms += (t_ms - self._raw) & 0xFFFF
        self._raw, self._last_arrival = t_ms, arrival
        device = self._ms / 1000.0
        candidate = arrival - device
        if (
            self._offset is None
            or candidate < self._offset
            or candidate - self._offset > self.JUMP_S
        ):
            self._offset = candidate
        else:
            self._offset += (candidate - self._offset) * self.FOLLOW
        # A later frame may show that earlier ones were stamped late; never step backwards.
        self._last_stamp = min(max(self._last_stamp, device + self._offset), arrival)
        return self._last_stamp


@dataclass
class SerialController(ReconnectingBackend):
    """``serial://PATH?baud=115200``: the controller board (or its simulator on a pty)."""

    path: str = ""
    baud: int = 115200
    hello_retry_s: float = 0.5
    max_read: int = 4096
    #: what the last HELLO said (None before the handshake)
    hello: p.Hello | None = field(default=None, init=False)
    calibration: p.Calibration | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        self.url = self.url or f"serial://{self.path}?baud={self.baud}"
        # Until the HELLO says otherwise (an older board has fewer buttons): the current board.
        self.capabilities = Capabilities(axes=p.N_AXES, buttons=p.N_BUTTONS)
        self.decoder = p.StreamDecoder()
        self.tracker = p.SequenceTracker()
        self.device_clock = DeviceClock()
        self.bytes_in = self.bytes_out = 0
        self._port: serial.Serial | None = None
        self._seq = 0
        self._last_rx = 0.0
        self._next_hello = 0.0
        self._opened_at = 0.0

    # ---- the port (ReconnectingBackend does the retries, the loss and the release)

    def _connected(self) -> bool:
        return self._port is not None

    def _disconnect(self) -> None:
        port, self._port = self._port, None
        if port is not None:
            with contextlib.suppress(OSError, serial.SerialException):
                port.close()

    def _connect(self, now: float) -> str | None:
        try:
            port = serial.Serial(self.path, self.baud, timeout=0, write_timeout=0, exclusive=True)
        except (OSError, serial.SerialException, ValueError) as exc:
            return f"waiting for {self.path}: {_reason(exc)}"
        self._port = port
        self.decoder.reset()  # a partial frame from before the unplug must not glue onto new bytes
        self.tracker.expected = None  # pyserial flushed the boot HELLO: no gap across a reopen
        self.device_clock.reset()
        # RECONNECTING: the port is back after a loss, the handshake is not done yet.
        self.state = State.RECONNECTING if self.ever_connected else State.CONNECTING
        self.detail = f"handshake on {self.path}"
        self._opened_at = self._last_rx = now
        self._next_hello = now
        return None

    # ---- host -> device

    def send(self, message: p.Message) -> bool:
        """Send a host command (HelloRequest, Calibrate, WatchdogTest); False if the port is
        not open or the write failed (the next poll notices the fault)."""
        if self._port is None:
            return False
        try:
            self.bytes_out += self._port.write(p.encode_frame(message, self._seq)) or 0
        except (OSError, serial.SerialException):
            return False
        self._seq = (self._seq + 1) & 0xFF
        return True

    # ---- polling

    def _read(self, now: float) -> None:
        handshaking = self.state in (State.CONNECTING, State.RECONNECTING)
        if handshaking and now >= self._next_hello:
            self._next_hello = now + self.hello_retry_s
            self.send(p.HelloRequest())
        port = self._port
        assert port is not None  # ReconnectingBackend reads only while connected
        try:
            data = port.read(self.max_read)
        except (OSError, serial.SerialException) as exc:
            self._lost(now, f"read failed on {self.path}: {_reason(exc)}")
            return
        if data:
            self.bytes_in += len(data)
            self._feed(data, now)
        silence = now - self._last_rx
        if self.state is State.CONNECTED and silence > self.lost_after:
            self._lost(now, f"silent for {silence:.1f} s (no heartbeat)")
        elif self.state in (State.CONNECTING, State.RECONNECTING) and now - self._opened_at > max(
            2.0, self.lost_after
        ):
            # Open but no HELLO: a hung board (reopening resets a Nano) or another device.
            self._lost(
                now,
                self.detail
                if "version" in self.detail
                else f"no HELLO from {self.path} in {now - self._opened_at:.1f} s",
            )

    @property
    def lost_after(self) -> float:
        """Four heartbeat periods without any frame (PROTOCOL.md section 4)."""
        return 4 * (self.hello.heartbeat_ms if self.hello else 250) / 1000.0

    def _feed(self, data: bytes, now: float) -> None:
        for item in self.decoder.feed(data):
            if isinstance(item, p.Rejected):
                if item.reason is p.Reject.VERSION and item.data:
                    try:
                        version = p.cobs_decode(item.data)[0]
                    except (p.ProtocolError, IndexError):
                        continue
                    self.detail = (
                        f"{self.path} speaks protocol version {version}; this host "
                        f"speaks {p.PROTOCOL_VERSION} (update the firmware or exhibit)"
                    )
                continue
            msg = item.message
            if isinstance(msg, p.Hello):
                self._on_hello(item, now)
            elif self.state is not State.CONNECTED:
                continue  # frames from before the handshake
            self._last_rx = now
            self.tracker.update(item)
            if isinstance(msg, p.Axes):
                self._on_axes(msg, now)
            elif isinstance(msg, p.Calibration):
                self.calibration = msg

    def _on_hello(self, frame: p.Frame, now: float) -> None:
        hello = frame.message
        assert isinstance(hello, p.Hello)  # _feed passes HELLO frames only
        if self.state is State.CONNECTED and frame.seq == 0:
            # The board restarted: whatever it held is gone until its next AXES.
            self._release(now)
            self.device_clock.reset()
        self.hello = hello
        self.capabilities = Capabilities(axes=hello.n_axes, buttons=hello.n_buttons)
        self.state = State.CONNECTED  # sets ever_connected
        fw = ".".join(map(str, hello.firmware))
        self.detail = f"firmware {fw} on {self.path}"

    def _on_axes(self, msg: p.Axes, now: float) -> None:
        t = min(self.device_clock.stamp(msg.t_ms, now), now)
        out = self._pending
        for i, raw in enumerate(msg.axes):
            v = max(-1.0, min(1.0, raw / p.AXIS_FULL_SCALE))
            if self._axes.get(i, 0.0) != v:
                self._axes[i] = v
                out.append(Event(t, self.name, Kind.ABS, i, v))
        # Every bit of the byte, whatever the board's count: an older board (4 buttons in its
        # HELLO) leaves bit 4 at 0, so its button 5 simply never comes.
        for i in range(8):
            v = float((msg.buttons >> i) & 1)
            if self._buttons.get(i, 0.0) != v:
                self._buttons[i] = v
                out.append(Event(t, self.name, Kind.BUTTON, i, v))

    def status(self, now: float | None = None) -> dict:
        d = super().status(now)
        d["link"] = {
            **self.decoder.summary(),
            "lost_frames": self.tracker.lost,
            "reordered": self.tracker.reordered,
            "duplicates": self.tracker.duplicates,
            "restarts": self.tracker.restarts,
            "reconnects": self.reconnects,
        }
        return d


def _reason(exc: BaseException) -> str:
    """The useful part of a pyserial/OS error message, on one line."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0]
