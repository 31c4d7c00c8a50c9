"""The firmware's filtering, calibration, debouncing, scheduling, quadrature decoding and HID
report code (firmware/common), compiled for the host and driven through ctypes."""

import binascii
import ctypes
import random

import pytest

from .conftest import u8, u16

C16_MAX = 1023 * 16
FULL = 32767


# ---- low-pass filter -----------------------------------------------------------------------

def run_filter(fw, shift, xs):
    y = (ctypes.c_uint16 * len(xs))()
    fw.shim_filter_run(shift, u16(xs), len(xs), y)
    return list(y)


def test_filter_primes_on_first_sample_and_holds_a_constant(fw):
    assert run_filter(fw, 2, [5000] * 10) == [5000] * 10


def test_filter_step_response_is_first_order(fw):
    ys = run_filter(fw, 2, [1000] + [9000] * 40)
    for k, y in enumerate(ys[1:], start=1):
        ideal = 9000 - 8000 * 0.75**k
        assert abs(y - ideal) <= 2, (k, y, ideal)  # fixed point: within 2/16 count
    assert ys[-1] == 9000
    assert all(a <= b for a, b in zip(ys, ys[1:]))  # no overshoot, no ringing


def test_filter_settles_exactly_downwards_too(fw):
    ys = run_filter(fw, 2, [16368] + [0] * 60)
    assert ys[-1] == 0 and all(a >= b for a, b in zip(ys, ys[1:]))


def test_filter_attenuates_alternating_noise(fw):
    ys = run_filter(fw, 2, [8000] + [8000 + (160 if i % 2 else -160) for i in range(100)])
    assert max(abs(y - 8000) for y in ys[50:]) < 160 / 2


# ---- scaling and dead zone -----------------------------------------------------------------

def scale(fw, value, zero, dz=192, edge=256):
    return fw.shim_axis_scale(value, zero, dz, edge)


def test_scale_hand_computed_points(fw):
    # zero 8000, no dead zone or edge: positive span 8368 counts16, negative span 8000
    assert scale(fw, 8000 + 4184, 8000, 0, 0) == 16384
    assert scale(fw, 4000, 8000, 0, 0) == -16384  # (4000 * 32767 + 4000) / 8000 rounded
    assert scale(fw, C16_MAX, 8000, 0, 0) == FULL
    assert scale(fw, 0, 8000, 0, 0) == -FULL


@pytest.mark.parametrize("zero", [8176, 6000, 11000])
def test_scale_dead_zone_monotonic_and_saturating(fw, zero):
    dz, edge = 192, 256
    out = [scale(fw, v, zero, dz, edge) for v in range(C16_MAX + 1)]
    assert all(out[v] == 0 for v in range(zero - dz, zero + dz + 1))
    assert out[zero + dz + 1] > 0 and out[zero - dz - 1] < 0
    # continuous at the dead-zone edge: one c16 step is one step of the scale
    assert out[zero + dz + 1] <= FULL // (C16_MAX - zero - dz - edge) + 1
    assert all(a <= b for a, b in zip(out, out[1:]))
    assert out[C16_MAX - edge] == FULL and out[C16_MAX] == FULL
    assert out[edge] == -FULL and out[0] == -FULL
    assert max(out) == FULL and min(out) == -FULL


def test_scale_zero_at_a_rail_is_not_a_division_by_zero(fw):
    assert scale(fw, 0, 0) == 0 and scale(fw, C16_MAX, 0) == FULL
    assert scale(fw, C16_MAX, C16_MAX) == 0 and scale(fw, 0, C16_MAX) == -FULL


# ---- calibration record, power-up choice, gesture ------------------------------------------

def pack(fw, zeros):
    rec = (ctypes.c_uint8 * 17)()
    fw.calib_pack(u16(zeros), rec)
    return bytes(rec)


def unpack(fw, rec):
    out = (ctypes.c_uint16 * 6)()
    ok = fw.calib_unpack(u8(rec), out)
    return ok, list(out)


def test_calibration_record_round_trip_and_layout(fw):
    zeros = [8176, 0, 16368, 1, 9000, 7000]
    rec = pack(fw, zeros)
    assert rec[:3] == b"Z6\x01" and len(rec) == fw.shim_const(b"CALIB_RECORD_SIZE")
    assert int.from_bytes(rec[-2:], "little") == binascii.crc_hqx(rec[:-2], 0xFFFF)
    assert unpack(fw, rec) == (1, zeros)


def test_calibration_record_rejects_erased_torn_and_out_of_range(fw):
    assert unpack(fw, b"\xff" * 17)[0] == 0  # a new chip's EEPROM
    assert unpack(fw, b"\x00" * 17)[0] == 0
    rec = pack(fw, [8176] * 6)
    for i in range(17):  # any corrupted byte
        bad = bytearray(rec)
        bad[i] ^= 0x40
        assert unpack(fw, bad)[0] == 0, i
    body = bytearray(rec[:-2])
    body[3:5] = (C16_MAX + 1).to_bytes(2, "little")  # intact CRC, impossible value
    assert unpack(fw, bytes(body) + binascii.crc_hqx(bytes(body), 0xFFFF).to_bytes(2, "little"))[0] == 0


def choose(fw, measured, stored, tol):
    out = (ctypes.c_uint16 * 6)()
    mask = fw.calib_choose(u16(measured), u16(stored) if stored else None, tol, out)
    return mask, list(out)


def test_power_up_zero_prefers_measurement_unless_the_stick_is_held(fw):
    stored = [8000] * 6
    measured = [8000, 8768, 7232, 8769, 7231, 12000]  # tolerance 768: the last three are "held"
    assert choose(fw, measured, None, 768) == (0, measured)
    assert choose(fw, measured, stored, 768) == (0b111000, measured[:3] + [8000] * 3)


def run_gesture(fw, buttons, mask=0b11, hold=5):
    fired = (ctypes.c_uint8 * len(buttons))()
    fw.shim_gesture_run(u8(buttons), len(buttons), mask, hold, fired)
    return [i for i, f in enumerate(fired) if f]


def test_gesture_fires_once_after_the_hold_and_rearms_on_release(fw):
    assert run_gesture(fw, [3] * 12) == [4]  # once, on the 5th tick, however long the hold
    assert run_gesture(fw, [1] * 12 + [2] * 12) == []  # one button at a time is not the gesture
    assert run_gesture(fw, [3, 3, 3, 3, 1, 3, 3, 3, 3, 3]) == [9]  # a slip restarts the count
    assert run_gesture(fw, [3] * 6 + [0] + [7] * 6) == [4, 11]  # extra buttons do not matter


# ---- button debouncing ---------------------------------------------------------------------

def run_debounce(fw, raw, n=5, initial=0):
    out = (ctypes.c_uint8 * len(raw))()
    fw.shim_debounce_run(n, initial, u8(raw), len(raw), out)
    return list(out)


def test_debounce_ignores_bounce_shorter_than_n_samples(fw):
    bouncy_press = [1, 0, 1, 0, 0, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1]
    out = run_debounce(fw, bouncy_press)
    assert out[:12] == [0] * 12 and out[12:] == [1] * 4  # pressed after 5 stable samples
    bouncy_release = [0, 1, 0, 1, 1, 0, 0, 0, 0, 0, 0]
    assert run_debounce(fw, bouncy_release, initial=1) == [1] * 9 + [0] * 2


def test_debounce_bits_are_independent(fw):
    raw = [0b01] * 5 + [0b11] * 5 + [0b10] * 6
    out = run_debounce(fw, raw)
    assert out[4] == 0b01 and out[9] == 0b11 and out[14] == 0b10


# ---- what to send on each tick -------------------------------------------------------------

def run_sched(fw, active, linger=3, hb=4):
    out = (ctypes.c_uint8 * len(active))()
    fw.shim_sched_run(linger, hb, u8(active), len(active), out)
    return "".join(".AH"[a] for a in out)


def test_heartbeat_while_idle_axes_while_active_then_linger(fw):
    assert run_sched(fw, [0] * 12) == "...H...H...H"
    assert run_sched(fw, [0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0]) == "..AAAAA...H.."
    assert run_sched(fw, [1, 0, 1, 0, 0, 0, 0] + [0] * 6) == "AAAAAA...H..."


# ---- quadrature decoding -------------------------------------------------------------------

CW = [0b01, 0b11, 0b10, 0b00]  # from rest at 00, clockwise


def run_quad(fw, samples, ab0=0, steps=4, start=0):
    det = (ctypes.c_int8 * max(len(samples), 1))()
    count, errors = ctypes.c_uint8(), ctypes.c_uint16()
    fw.shim_quad_run(ab0, steps, start, u8(samples), len(samples), det, ctypes.byref(count),
                     ctypes.byref(errors))
    return list(det[: len(samples)]), count.value, errors.value


def test_one_detent_each_way(fw):
    assert run_quad(fw, CW) == ([0, 0, 0, 1], 1, 0)
    assert run_quad(fw, CW[::-1][1:] + [0b00]) == ([0, 0, 0, -1], 255, 0)


def test_bounce_on_every_edge_cancels(fw):
    """Each new state chatters back to the previous one twice before it settles."""
    seq, prev = [], 0b00
    for _ in range(10):  # ten detents clockwise
        for s in CW:
            seq += [s, prev, s, prev, s]
            prev = s
    det, count, errors = run_quad(fw, seq)
    assert count == 10 and sum(det) == 10 and errors == 0


def test_bounce_at_the_detent_does_not_double_count(fw):
    det, count, _ = run_quad(fw, CW + [0b10, 0b00, 0b10, 0b00, 0b01, 0b00])
    assert count == 1 and det.count(1) == 1 and -1 not in det


def test_invalid_jumps_count_zero_and_are_reported(fw):
    det, count, errors = run_quad(fw, [0b11, 0b00, 0b11, 0b00])
    assert (det, count, errors) == ([0, 0, 0, 0], 0, 4)


def test_half_cycle_encoders(fw):
    det, count, _ = run_quad(fw, CW, steps=2)
    assert det == [0, 1, 0, 1] and count == 2


def test_counter_wraps_both_ways(fw):
    assert run_quad(fw, CW * 3, start=254)[1] == 1  # 254 + 3 = 257 = 1 (mod 256)
    assert run_quad(fw, (CW[::-1][1:] + [0]) * 2, start=1)[1] == 255


def test_random_rotation_with_random_bounce(fw):
    rng = random.Random(7)
    for _ in range(50):
        seq, state, net = [], 0, 0
        for _ in range(rng.randrange(1, 40)):
            direction = rng.choice((1, -1))
            for _ in range(4):
                i = CW.index(state) if state else 3
                nxt = CW[(i + direction) % 4] if direction > 0 else CW[(i - 1) % 4]
                for _ in range(rng.randrange(0, 3)):
                    seq += [nxt, state]  # chatter
                seq.append(nxt)
                state = nxt
            net += direction
        det, count, errors = run_quad(fw, seq)
        assert sum(det) == net and count == net % 256 and errors == 0


# ---- knob box HID report -------------------------------------------------------------------

class Reporter:
    def __init__(self, fw, counts=(0,) * 7, buttons=0):
        self.fw = fw
        self.state = ctypes.create_string_buffer(fw.shim_knob_report_size())
        fw.knob_report_init(self.state, u8(counts), buttons)

    def build(self, counts, buttons=0, force=0):
        out = (ctypes.c_uint8 * 9)()
        n = self.fw.knob_report_build(self.state, u8(counts), buttons, force, out)
        return bytes(out[:n])


def test_report_only_on_change_or_when_forced(fw):
    r = Reporter(fw)
    assert r.build([0] * 7) == b""
    assert r.build([0] * 7, force=1) == bytes([1] + [0] * 8)
    assert r.build([1, 0, 0, 0, 0, 0, 0]) == bytes([1, 1, 0, 0, 0, 0, 0, 0, 0])
    assert r.build([1, 0, 0, 0, 0, 0, 0]) == b""  # the delta was delivered
    assert r.build([1, 0, 0, 0, 0, 0, 0], buttons=0b0000100) == bytes([1] + [0] * 7 + [4])
    assert r.build([1, 0, 0, 0, 0, 0, 0], buttons=0b0000100) == b""
    assert r.build([1, 0, 0, 0, 0, 0, 0], buttons=0) == bytes([1] + [0] * 8)  # release reported


def test_report_deltas_survive_counter_wrap(fw):
    r = Reporter(fw, counts=(250, 3, 0, 0, 0, 0, 128))
    rep = r.build([5, 250, 0, 0, 0, 0, 127])  # +11, -9, ..., -1
    assert list(rep[1:8]) == [11, 256 - 9, 0, 0, 0, 0, 255]


def test_report_minus_128_goes_out_as_minus_127_plus_the_rest(fw):
    r = Reporter(fw)
    assert r.build([128, 0, 0, 0, 0, 0, 0])[1] == 0x81  # -127 (-128 is outside the descriptor)
    assert r.build([128, 0, 0, 0, 0, 0, 0])[1] == 0xFF  # the remaining -1


def test_report_vectors(fw, vectors):
    for v in vectors["hid"]["reports"]:
        r = Reporter(fw)
        assert r.build([d & 0xFF for d in v["deltas"]], v["buttons"]).hex() == v["bytes"], v["name"]
    assert fw.shim_const(b"KNOB_REPORT_SIZE") == vectors["hid"]["report_size"]


def parse_hid_descriptor(desc: bytes) -> dict:
    """A small HID report-descriptor parser: input fields per report id."""
    reports, glob, i = {}, {}, 0
    while i < len(desc):
        prefix = desc[i]
        size = (0, 1, 2, 4)[prefix & 3]
        data = desc[i + 1 : i + 1 + size]
        i += 1 + size
        tag, kind = prefix >> 4, (prefix >> 2) & 3
        value = int.from_bytes(data, "little", signed=tag in (1, 2) and kind == 1)
        if kind == 1:  # global
            glob[{0: "page", 1: "lmin", 2: "lmax", 7: "size", 8: "id", 9: "count"}.get(tag, tag)] = value
        elif kind == 0 and tag == 8:  # main: Input
            reports.setdefault(glob.get("id"), []).append(
                dict(bits=glob["size"] * glob["count"], size=glob["size"], count=glob["count"],
                     lmin=glob.get("lmin"), lmax=glob.get("lmax"), const=bool(value & 1),
                     relative=bool(value & 4), page=glob.get("page")))
    return reports


def test_hid_descriptor_describes_the_report_the_firmware_builds(fw, vectors):
    desc = bytes(ctypes.cast(fw.shim_hid_descriptor, ctypes.POINTER(ctypes.c_uint8 * 64)).contents)
    n = ctypes.c_size_t.in_dll(fw, "shim_hid_descriptor_len").value
    desc = desc[:n]
    assert desc.hex() == vectors["hid"]["report_descriptor"]
    reports = parse_hid_descriptor(desc)
    assert list(reports) == [1]
    deltas, buttons, pad = reports[1]
    assert deltas == dict(bits=56, size=8, count=7, lmin=-127, lmax=127, const=False,
                          relative=True, page=0xFF00)
    assert (buttons["size"], buttons["count"], buttons["lmin"], buttons["lmax"]) == (1, 7, 0, 1)
    assert pad["const"] and pad["bits"] == 1
    assert sum(f["bits"] for f in reports[1]) // 8 + 1 == fw.shim_const(b"KNOB_REPORT_SIZE")
