"""Host side of the 6-axis controller's serial protocol, version 1: a pure codec, no I/O.

``firmware/PROTOCOL.md`` is the specification; ``firmware/vectors/protocol.json`` holds the test
vectors that this module and the firmware's C code are both checked against, byte for byte.

On the wire every frame is::

    COBS( version | type | seq | payload ... | crc16_lo | crc16_hi )  0x00

with the CRC-16/CCITT-FALSE of ``version .. payload``. A receiver resynchronises at every 0x00.

Typical use by a serial backend (which owns the port; this module never touches one)::

    decoder = StreamDecoder()
    for item in decoder.feed(port.read(port.in_waiting or 1)):
        if isinstance(item, Frame):
            handle(item.message)           # Hello, Heartbeat, Axes, Calibration, ...
        else:
            log(item.reason)               # a Rejected chunk
    port.write(encode_frame(HelloRequest(), seq=host_seq))

``decoder.summary()`` gives ``{"frames_ok": N, "rejected": N, "bytes_skipped": N}``.

Why one module of this size: the wire format (framing, CRC, every message and its codec) is kept
whole beside its C mirror in firmware/, so the two are read side by side."""

from __future__ import annotations

import binascii
import enum
import struct
from dataclasses import dataclass, field
from typing import ClassVar

__all__ = [
    "PROTOCOL_VERSION",
    "DELIMITER",
    "MAX_PAYLOAD",
    "MAX_ENCODED",
    "AXIS_FULL_SCALE",
    "N_AXES",
    "N_BUTTONS",
    "WATCHDOG_KEY",
    "MsgType",
    "ResetCause",
    "CalibrationReason",
    "Reject",
    "ProtocolError",
    "Message",
    "Hello",
    "Heartbeat",
    "Axes",
    "Calibration",
    "HelloRequest",
    "Calibrate",
    "WatchdogTest",
    "Frame",
    "Rejected",
    "crc16",
    "cobs_encode",
    "cobs_decode",
    "encode_raw",
    "encode_frame",
    "decode_frame",
    "StreamDecoder",
    "SequenceTracker",
]

PROTOCOL_VERSION = 1
DELIMITER = b"\x00"
HEADER_SIZE = 3  # version, type, seq
CRC_SIZE = 2
MAX_PAYLOAD = 32
MAX_RAW = HEADER_SIZE + MAX_PAYLOAD + CRC_SIZE
MAX_ENCODED = MAX_RAW + 1  # COBS adds one byte per 254; frames are shorter than that
AXIS_FULL_SCALE = 32767
N_AXES = 6
#: buttons of the current firmware (1.1.0); the HELLO says how many a board has: 1.0.0 had 4
N_BUTTONS = 5
WATCHDOG_KEY = b"WDT!"


class MsgType(enum.IntEnum):
    """Message types. 0x01-0x0F go device -> host, 0x10-0x1F host -> device."""

    HELLO = 0x01
    HEARTBEAT = 0x02
    AXES = 0x03
    CALIBRATION = 0x04
    HELLO_REQUEST = 0x10
    CALIBRATE = 0x11
    WATCHDOG_TEST = 0x12


class ResetCause(enum.IntFlag):
    """Why the controller last reset (the AVR's MCUSR bits); 0 when unknown."""

    POWER_ON = 0x01
    EXTERNAL = 0x02
    BROWN_OUT = 0x04
    WATCHDOG = 0x08


class CalibrationReason(enum.IntEnum):
    POWER_UP = 0
    BUTTONS = 1
    HOST = 2


class Reject(str, enum.Enum):
    """Why a chunk between two delimiters was not accepted as a frame (checked in this order)."""

    TOO_LONG = "too_long"  # longer than MAX_ENCODED: a flood or a lost delimiter
    COBS = "cobs"  # not valid COBS
    SHORT = "short"  # fewer bytes than header and CRC
    CRC = "crc"
    VERSION = "version"  # intact, but another protocol version
    TYPE = "type"  # intact, but a type this version does not define
    LENGTH = "length"  # intact, but the payload length does not match the type


class ProtocolError(ValueError):
    """A chunk that is not a valid frame; ``reason`` says why."""

    def __init__(self, reason: Reject, detail: str = ""):
        super().__init__(f"{reason.value}: {detail}" if detail else reason.value)
        self.reason = reason


# ---- checksum and stuffing -----------------------------------------------------------------


def crc16(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final xor), which is the
    standard library's ``binascii.crc_hqx`` started at 0xFFFF. ``crc16(b"123456789") == 0x29B1``.
    The firmware's C implementation is checked against the same vectors."""
    return binascii.crc_hqx(data, crc)


def cobs_encode(data: bytes) -> bytes:
    """Canonical COBS encoding (no delimiter appended)."""
    out = bytearray()
    block = bytearray()
    for i, b in enumerate(data):
        if b == 0:
            out.append(len(block) + 1)
            out += block
            block.clear()
        else:
            block.append(b)
            if len(block) == 254 and i + 1 < len(data):
                out.append(0xFF)
                out += block
                block.clear()
    out.append(len(block) + 1)
    out += block
    return bytes(out)


def cobs_decode(data: bytes) -> bytes:
    """Inverse of :func:`cobs_encode`; raises :class:`ProtocolError` (reason COBS)."""
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        code = data[i]
        if code == 0:
            raise ProtocolError(Reject.COBS, "zero byte inside a frame")
        end = i + code
        if end > n:
            raise ProtocolError(Reject.COBS, "block runs past the end")
        block = data[i + 1 : end]
        if 0 in block:
            raise ProtocolError(Reject.COBS, "zero byte inside a frame")
        out += block
        i = end
        if code != 0xFF and i < n:
            out.append(0)
    return bytes(out)


# ---- messages ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Message:
    """Base of all messages: ``pack()`` gives the payload, ``unpack(payload)`` parses it."""

    TYPE: ClassVar[MsgType]
    SIZE: ClassVar[int]

    def pack(self) -> bytes:  # pragma: no cover - every subclass overrides
        raise NotImplementedError

    @classmethod
    def unpack(cls, payload: bytes) -> Message:  # pragma: no cover
        raise NotImplementedError

    def to_dict(self) -> dict:
        """JSON-friendly fields (enums as names)."""
        d = {}
        for k, v in self.__dict__.items():
            if isinstance(v, enum.Flag):
                v = [m.name for m in type(v) if m in v]
            elif isinstance(v, enum.Enum):
                v = v.name
            elif isinstance(v, bytes):
                v = v.hex()
            elif isinstance(v, tuple):
                v = list(v)
            d[k] = v
        return d


@dataclass(frozen=True)
class Hello(Message):
    """Sent at boot and on :class:`HelloRequest`. ``firmware`` is (major, minor, patch);
    ``n_buttons`` how many buttons the board has (5 since firmware 1.1.0, 4 before);
    ``heartbeat_ms`` is the idle heartbeat period, ``frame_hz`` the axes rate while active."""

    firmware: tuple[int, int, int] = (0, 0, 0)
    board: int = 1
    n_axes: int = N_AXES
    n_buttons: int = N_BUTTONS
    frame_hz: int = 100
    heartbeat_ms: int = 250
    reset_cause: ResetCause = ResetCause(0)

    TYPE = MsgType.HELLO
    SIZE = 10
    _FMT: ClassVar[str] = "<7BHB"

    def pack(self) -> bytes:
        return struct.pack(
            self._FMT,
            *self.firmware,
            self.board,
            self.n_axes,
            self.n_buttons,
            self.frame_hz,
            self.heartbeat_ms,
            int(self.reset_cause),
        )

    @classmethod
    def unpack(cls, payload: bytes) -> Hello:
        ma, mi, pa, board, na, nb, hz, hb, rc = struct.unpack(cls._FMT, payload)
        return cls((ma, mi, pa), board, na, nb, hz, hb, ResetCause(rc))


@dataclass(frozen=True)
class Heartbeat(Message):
    """Sent every ``heartbeat_ms`` while nobody touches the controller. ``rx_ok`` and
    ``rx_rejected`` count the frames the device received from the host (mod 2**16)."""

    uptime_ms: int = 0
    rx_ok: int = 0
    rx_rejected: int = 0

    TYPE = MsgType.HEARTBEAT
    SIZE = 8
    _FMT: ClassVar[str] = "<IHH"

    def pack(self) -> bytes:
        return struct.pack(self._FMT, self.uptime_ms, self.rx_ok, self.rx_rejected)

    @classmethod
    def unpack(cls, payload: bytes) -> Heartbeat:
        return cls(*struct.unpack(cls._FMT, payload))


@dataclass(frozen=True)
class Axes(Message):
    """Sent at ``frame_hz`` while active. ``axes`` are six deflections, +-32767 at full scale,
    0 inside the dead zone; ``buttons`` bit i is button i+1 (bit ``n_buttons`` of the HELLO and
    above are 0); ``t_ms`` is the device clock (ms, mod 2**16) when the axes were sampled, for
    jitter-free rate integration."""

    t_ms: int = 0
    axes: tuple[int, ...] = (0,) * N_AXES
    buttons: int = 0

    TYPE = MsgType.AXES
    SIZE = 15
    _FMT: ClassVar[str] = "<H6hB"

    def pack(self) -> bytes:
        return struct.pack(self._FMT, self.t_ms, *self.axes, self.buttons)

    @classmethod
    def unpack(cls, payload: bytes) -> Axes:
        t, *axes, buttons = struct.unpack(cls._FMT, payload)
        return cls(t, tuple(axes), buttons)

    @property
    def normalized(self) -> tuple[float, ...]:
        """Deflections in [-1, 1]."""
        return tuple(a / AXIS_FULL_SCALE for a in self.axes)


@dataclass(frozen=True)
class Calibration(Message):
    """The zero points in use, sent after boot and after each calibration. ``zeros`` are in
    1/16 ADC counts (0..16368); ``eeprom_mask`` bit i: axis i kept its stored zero because the
    power-up reading was off (someone held the stick while the exhibit booted)."""

    reason: CalibrationReason = CalibrationReason.POWER_UP
    eeprom_mask: int = 0
    zeros: tuple[int, ...] = (8184,) * N_AXES

    TYPE = MsgType.CALIBRATION
    SIZE = 14
    _FMT: ClassVar[str] = "<BB6H"

    def pack(self) -> bytes:
        return struct.pack(self._FMT, int(self.reason), self.eeprom_mask, *self.zeros)

    @classmethod
    def unpack(cls, payload: bytes) -> Calibration:
        reason, mask, *zeros = struct.unpack(cls._FMT, payload)
        try:  # noqa: SIM105 - the codec imports no more than it needs (test_codec_module_does_no_io)
            reason = CalibrationReason(reason)
        except ValueError:
            pass  # a reason added later: keep the number
        return cls(reason, mask, tuple(zeros))


@dataclass(frozen=True)
class HelloRequest(Message):
    """Host -> device: answer with a :class:`Hello` (the handshake after opening the port)."""

    TYPE = MsgType.HELLO_REQUEST
    SIZE = 0

    def pack(self) -> bytes:
        return b""

    @classmethod
    def unpack(cls, payload: bytes) -> HelloRequest:
        return cls()


@dataclass(frozen=True)
class Calibrate(Message):
    """Host -> device: take the current position as zero and store it in EEPROM."""

    TYPE = MsgType.CALIBRATE
    SIZE = 0

    def pack(self) -> bytes:
        return b""

    @classmethod
    def unpack(cls, payload: bytes) -> Calibrate:
        return cls()


@dataclass(frozen=True)
class WatchdogTest(Message):
    """Host -> device: hang the main loop so the hardware watchdog resets the board (it comes
    back with a :class:`Hello` whose ``reset_cause`` has WATCHDOG). Ignored unless ``key`` is
    ``b"WDT!"``."""

    key: bytes = WATCHDOG_KEY

    TYPE = MsgType.WATCHDOG_TEST
    SIZE = 4

    def pack(self) -> bytes:
        return bytes(self.key)

    @classmethod
    def unpack(cls, payload: bytes) -> WatchdogTest:
        return cls(bytes(payload))


_MESSAGES: dict[int, type[Message]] = {
    cls.TYPE: cls
    for cls in (Hello, Heartbeat, Axes, Calibration, HelloRequest, Calibrate, WatchdogTest)
}


# ---- frames --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Frame:
    """One accepted frame."""

    type: MsgType
    seq: int
    message: Message
    version: int = PROTOCOL_VERSION

    def to_dict(self) -> dict:
        return {"type": self.type.name, "seq": self.seq, **self.message.to_dict()}


@dataclass(frozen=True)
class Rejected:
    """One rejected chunk (the bytes between two delimiters, or their count if too long)."""

    reason: Reject
    size: int
    data: bytes = field(default=b"", repr=False)

    def to_dict(self) -> dict:
        return {"rejected": self.reason.value, "size": self.size, "data": self.data.hex()}


def encode_raw(msg_type: int, seq: int, payload: bytes, version: int = PROTOCOL_VERSION) -> bytes:
    """A wire frame from its parts, without checking them: for simulators and fuzzing."""
    raw = bytes((version & 0xFF, msg_type & 0xFF, seq & 0xFF)) + bytes(payload)
    raw += crc16(raw).to_bytes(2, "little")
    return cobs_encode(raw) + DELIMITER


def encode_frame(message: Message, seq: int) -> bytes:
    """The wire bytes of ``message`` with sequence number ``seq`` (mod 256), delimiter included."""
    payload = message.pack()
    if len(payload) != message.SIZE:
        raise ValueError(
            f"{type(message).__name__} packs to {len(payload)} bytes, not {message.SIZE}"
        )
    return encode_raw(message.TYPE, seq, payload)


def decode_frame(chunk: bytes) -> Frame:
    """Parses the bytes between two delimiters; raises :class:`ProtocolError` with the reason."""
    if len(chunk) > MAX_ENCODED:
        raise ProtocolError(Reject.TOO_LONG, f"{len(chunk)} bytes")
    raw = cobs_decode(chunk)
    if len(raw) < HEADER_SIZE + CRC_SIZE:
        raise ProtocolError(Reject.SHORT, f"{len(raw)} bytes")
    # CRC before anything else: a corrupt frame is not a version or type problem.
    if crc16(raw[:-2]) != int.from_bytes(raw[-2:], "little"):
        raise ProtocolError(Reject.CRC)
    version, msg_type, seq = raw[0], raw[1], raw[2]
    if version != PROTOCOL_VERSION:
        raise ProtocolError(
            Reject.VERSION, f"version {version}, this host speaks {PROTOCOL_VERSION}"
        )
    cls = _MESSAGES.get(msg_type)
    if cls is None:
        raise ProtocolError(Reject.TYPE, f"type 0x{msg_type:02x}")
    payload = raw[HEADER_SIZE:-CRC_SIZE]
    if len(payload) != cls.SIZE:
        raise ProtocolError(Reject.LENGTH, f"{cls.TYPE.name} with {len(payload)} bytes")
    return Frame(cls.TYPE, seq, cls.unpack(payload), version)


Item = Frame | Rejected


class StreamDecoder:
    """Incremental decoder for a byte stream: feed it whatever the port delivered, get back
    the frames (and rejected chunks) completed by those bytes, in order.

    Counters, identical to the firmware's receiver (``proto_rx`` in firmware/common/proto.c):

    - ``frames_ok``: valid frames;
    - ``rejected``: non-empty chunks between delimiters that are not valid frames;
    - ``bytes_skipped``: the bytes of those chunks (delimiters and empty chunks not counted).

    Memory is bounded: a chunk longer than MAX_ENCODED is dropped as it arrives.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self._discarding = 0  # bytes dropped of an overlong chunk, 0 when not in that state
        self.frames_ok = 0
        self.rejected = 0
        self.bytes_skipped = 0

    def feed(self, data: bytes) -> list[Item]:
        out: list[Item] = []
        buf = self._buf
        buf += data
        start = 0
        while True:
            end = buf.find(0, start)
            if end < 0:
                break
            chunk = bytes(buf[start:end])
            start = end + 1
            if self._discarding:
                n = self._discarding + len(chunk)
                self._discarding = 0
                self._reject(out, Rejected(Reject.TOO_LONG, n))
                continue
            if not chunk:
                continue  # idle fill between frames, and the firmware's boot delimiter
            try:
                frame = decode_frame(chunk)
            except ProtocolError as e:
                self._reject(out, Rejected(e.reason, len(chunk), chunk))
            else:
                self.frames_ok += 1
                out.append(frame)
        del buf[:start]
        if len(buf) > MAX_ENCODED:
            self._discarding += len(buf)
            buf.clear()
        return out

    def _reject(self, out: list[Item], item: Rejected) -> None:
        self.rejected += 1
        self.bytes_skipped += item.size
        out.append(item)

    @property
    def pending(self) -> int:
        """Bytes received after the last delimiter (part of a frame still arriving)."""
        return len(self._buf) + self._discarding

    def reset(self) -> None:
        """Forget a partial frame (e.g. after reopening the port); counters are kept."""
        self._buf.clear()
        self._discarding = 0

    def summary(self) -> dict[str, int]:
        return {
            "frames_ok": self.frames_ok,
            "rejected": self.rejected,
            "bytes_skipped": self.bytes_skipped,
        }


class SequenceTracker:
    """Counts frames lost, reordered and duplicated, from their 8-bit sequence numbers.

    ``update(frame)`` returns how many frames were missed just before it. Numbers wrap at 256,
    so a step back is ambiguous: a frame at most WINDOW behind the newest is taken for a late or
    repeated one, not for a gap of 200-odd frames that wrapped around. A frame that arrives late
    was counted lost when the frames after it came, so it is taken back off ``lost`` and counted
    ``reordered``; a repeat is counted in ``duplicates`` (a swapped pair 5, 7, 6, 8 is 0 lost and
    1 reordered; 5, 5 is 1 duplicate). The price: a real gap of 255 - WINDOW to 255 frames reads
    as a step back and is undercounted; the controller resyncs (``expected = None``) whenever
    it reopens the port, which it does after a second of silence.

    A :class:`Hello` with seq 0 means the device restarted (its counter starts at 0), which is
    not a loss.
    """

    WINDOW = 64

    def __init__(self) -> None:
        self.expected: int | None = None
        self.lost = self.restarts = self.reordered = self.duplicates = 0
        self._missing: set[int] = set()  # skipped numbers at most WINDOW back: may arrive late
        self._span = 0  # how far behind the newest frame anything is known since the resync

    def update(self, frame: Frame) -> int:
        seq = frame.seq & 0xFF
        if isinstance(frame.message, Hello) and seq == 0:
            if self.expected is not None and self.expected != 0:
                self.restarts += 1
            self.expected = None
        gap = 0
        if self.expected is None:  # first frame, restart, or the controller reopened the port
            self._missing.clear()
            self._span = 0
        else:
            gap = (seq - self.expected) & 0xFF
            if gap >= 255 - self.WINDOW:  # behind the newest frame (by 255 - gap)
                if seq in self._missing:
                    self._missing.discard(seq)
                    self.lost -= 1
                    self.reordered += 1
                elif 255 - gap <= self._span:
                    self.duplicates += 1
                else:
                    self.reordered += 1  # from before the resync: nothing to take back
                return 0
            self.lost += gap
            self._missing.update(
                (self.expected + k) & 0xFF for k in range(max(0, gap - self.WINDOW), gap)
            )
            self._span = min(self.WINDOW, self._span + gap + 1)
            if self._missing:
                self._missing = {m for m in self._missing if (seq - m) & 0xFF <= self.WINDOW}
        self.expected = (seq + 1) & 0xFF
        return gap
