"""What the controller firmware should send for a voltage: the ADC reading and the scaling of
firmware/PROTOCOL.md section 4, written out independently of the C code, for the tests that read
the firmware running in simavr."""

from __future__ import annotations

import binascii
import struct

from exhibit.devices import protocol as p
from exhibit.devices.simavr import VCC_MV

# Controller scaling constants (firmware/controller/config.h, documented in PROTOCOL.md).
DEADZONE_C16, EDGE_C16, C16_MAX = 12 * 16, 16 * 16, 1023 * 16
# One ADC count is about 68 units of the +-32767 scale; allow two for the ADC's rounding.
AXIS_TOL = 2 * 16 * p.AXIS_FULL_SCALE // (C16_MAX // 2)
CALIB_RECORD_SIZE = 17


def c16(mv: int) -> int:
    """What the 10-bit ADC reads for mv millivolts, in the firmware's 1/16-count unit."""
    return mv * 1023 // VCC_MV * 16


def expected_axis(mv: int, zero: int) -> int:
    d = c16(mv) - zero
    span = C16_MAX - zero if d >= 0 else zero
    mag, rng = abs(d) - DEADZONE_C16, span - DEADZONE_C16 - EDGE_C16
    out = 0 if mag <= 0 else min(p.AXIS_FULL_SCALE, round(mag * p.AXIS_FULL_SCALE / rng))
    return out if d >= 0 else -out


def calib_record(zeros) -> bytes:
    """The EEPROM calibration record (PROTOCOL.md section 5): 'Z' '6', layout 1, six zeros,
    CRC-16/CCITT-FALSE of the 15 bytes before it, all little endian."""
    body = b"Z6\x01" + struct.pack("<6H", *zeros)
    return body + struct.pack("<H", binascii.crc_hqx(body, 0xFFFF))


def read_calib_record(image: bytes) -> tuple[int, ...] | None:
    """The zeros stored in an EEPROM image, or None if its record is erased or torn."""
    rec = image[:CALIB_RECORD_SIZE]
    if len(rec) < CALIB_RECORD_SIZE or rec[:3] != b"Z6\x01":
        return None
    if struct.unpack("<H", rec[15:17])[0] != binascii.crc_hqx(rec[:15], 0xFFFF):
        return None
    return struct.unpack("<6H", rec[3:15])
