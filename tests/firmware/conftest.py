"""Fixtures for the firmware tests: the firmware's plain-C modules built for the host, the shared
test vectors, the AVR builds and the simavr harness.

A missing tool skips the tests that need it, naming the Debian packages, except under CI=true,
where it fails: CI installs them through bootstrap.sh."""

from __future__ import annotations

import ctypes
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"
COMMON = FIRMWARE / "common"
VECTORS = FIRMWARE / "vectors" / "protocol.json"
SHIM = Path(__file__).resolve().parent / "c" / "shim.c"
SIMAVR_HEADER = Path("/usr/include/simavr/sim_avr.h")


def require(what: str, tools: list[str], packages: str, files: list[Path] = ()) -> None:
    missing = [t for t in tools if shutil.which(t) is None] + [str(f) for f in files if not f.exists()]
    if not missing:
        return
    msg = f"{what} needs {', '.join(missing)} (Debian: apt-get install {packages})"
    if os.environ.get("CI") == "true":
        pytest.fail(msg)
    pytest.skip(msg)


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    result = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if result.returncode != 0:
        pytest.fail(f"{' '.join(map(str, cmd))} failed:\n{result.stdout}\n{result.stderr}")
    return result


@pytest.fixture(scope="session")
def vectors() -> dict:
    return json.loads(VECTORS.read_text())


@pytest.fixture(scope="session")
def fw(tmp_path_factory) -> ctypes.CDLL:
    """firmware/common/*.c and the ctypes shim, compiled by the host gcc with the firmware's
    warning flags."""
    require("host build of the firmware's C code", ["gcc"], "gcc")
    out = tmp_path_factory.mktemp("fwhost") / "libfwcommon.so"
    sources = sorted(str(p) for p in COMMON.glob("*.c"))
    run(["gcc", "-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", "-pedantic", "-fPIC", "-shared",
         f"-I{COMMON}", *sources, str(SHIM), "-o", str(out)])
    lib = ctypes.CDLL(str(out))
    P = ctypes.POINTER
    u8p, u16p = P(ctypes.c_uint8), P(ctypes.c_uint16)
    sig = {
        "crc16_ccitt": (ctypes.c_uint16, [ctypes.c_char_p, ctypes.c_size_t]),
        "crc16_update": (ctypes.c_uint16, [ctypes.c_uint16, ctypes.c_uint8]),
        "cobs_encode": (ctypes.c_size_t, [ctypes.c_char_p, ctypes.c_size_t, u8p]),
        "cobs_decode": (ctypes.c_int, [ctypes.c_char_p, ctypes.c_size_t, u8p, ctypes.c_size_t]),
        "proto_frame": (ctypes.c_size_t, [ctypes.c_uint8, ctypes.c_uint8, ctypes.c_char_p,
                                          ctypes.c_size_t, u8p]),
        "proto_payload_len": (ctypes.c_int, [ctypes.c_uint8]),
        "shim_const": (ctypes.c_long, [ctypes.c_char_p]),
        "shim_pack": (ctypes.c_long, [ctypes.c_uint8, P(ctypes.c_long), u8p]),
        "shim_parse": (ctypes.c_int, [ctypes.c_char_p, ctypes.c_size_t, u8p]),
        "shim_rx_stream": (ctypes.c_long, [ctypes.c_char_p, ctypes.c_size_t, u8p, ctypes.c_size_t,
                                           P(ctypes.c_uint32)]),
        "shim_filter_run": (None, [ctypes.c_uint8, u16p, ctypes.c_size_t, u16p]),
        "shim_axis_scale": (ctypes.c_int, [ctypes.c_uint16] * 4),
        "calib_pack": (None, [u16p, u8p]),
        "calib_unpack": (ctypes.c_int, [u8p, u16p]),
        "calib_choose": (ctypes.c_uint8, [u16p, u16p, ctypes.c_uint16, u16p]),
        "shim_gesture_run": (None, [u8p, ctypes.c_size_t, ctypes.c_uint8, ctypes.c_uint16, u8p]),
        "shim_debounce_run": (None, [ctypes.c_uint8, ctypes.c_uint8, u8p, ctypes.c_size_t, u8p]),
        "shim_sched_run": (None, [ctypes.c_uint16, ctypes.c_uint16, u8p, ctypes.c_size_t, u8p]),
        "shim_quad_run": (None, [ctypes.c_uint8, ctypes.c_uint8, ctypes.c_uint8, u8p, ctypes.c_size_t,
                                 P(ctypes.c_int8), u8p, u16p]),
        "shim_knob_report_size": (ctypes.c_size_t, []),
        "knob_report_init": (None, [ctypes.c_void_p, u8p, ctypes.c_uint8]),
        "knob_report_build": (ctypes.c_int, [ctypes.c_void_p, u8p, ctypes.c_uint8, ctypes.c_int, u8p]),
    }
    for name, (res, args) in sig.items():
        f = getattr(lib, name)
        f.restype, f.argtypes = res, args
    return lib


def u8(values) -> ctypes.Array:
    values = list(values)
    return (ctypes.c_uint8 * max(len(values), 1))(*values)


def u16(values) -> ctypes.Array:
    values = list(values)
    return (ctypes.c_uint16 * max(len(values), 1))(*values)


@pytest.fixture(scope="session")
def avr_build(tmp_path_factory) -> Path:
    """Both firmwares built by `make` in firmware/ (warnings are errors), into a temporary
    directory. Returns that directory; the make output is in build.log."""
    require("the AVR firmware build", ["make", "avr-gcc", "avr-g++", "avr-objcopy", "avr-size"],
            "make gcc-avr binutils-avr avr-libc arduino-core-avr",
            [Path("/usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h")])
    build = tmp_path_factory.mktemp("fwbuild")
    result = run(["make", "-C", str(FIRMWARE), f"BUILD={build}", "-j2", "all"])
    (build / "build.log").write_text(result.stdout + result.stderr)
    return build


@pytest.fixture(scope="session")
def harness(avr_build) -> Path:
    require("the simavr harness", ["gcc", "make", "pkg-config"], "gcc make pkg-config libsimavr-dev libelf-dev",
            [SIMAVR_HEADER])
    run(["make", "-C", str(FIRMWARE), f"BUILD={avr_build}", "sim"])
    return avr_build / "sim" / "harness"
