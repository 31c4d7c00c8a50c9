"""Both firmwares build with `make` in firmware/ (warnings are errors), produce .elf and .hex,
report flash and RAM use, and fit their chips."""

import re
import subprocess

from .conftest import FIRMWARE

LIMITS = {"controller": (30720, 2048), "knobbox": (28672, 2560)}


def hex_image(path) -> bytes:
    """The flash image in an Intel HEX file (contiguous from 0, as avr-objcopy writes it), with
    every record's checksum verified."""
    image = bytearray()
    lines = path.read_text().split()
    for line in lines:
        rec = bytes.fromhex(line[1:])
        assert line[0] == ":" and sum(rec) & 0xFF == 0, line
        if rec[3] == 0:
            addr = int.from_bytes(rec[1:3], "big")
            assert addr == len(image), "gap in the image"
            image += rec[4 : 4 + rec[0]]
    assert lines[-1] == ":00000001FF"
    return bytes(image)


def test_make_builds_both_boards_and_reports_sizes(avr_build):
    log = (avr_build / "build.log").read_text()
    assert "warning" not in log.lower()
    for board, (flash_max, ram_max) in LIMITS.items():
        assert (avr_build / board / f"{board}.elf").stat().st_size > 0
        m = re.search(rf"^{board}: flash (\d+) of (\d+) bytes .*RAM (\d+) of (\d+) bytes", log, re.M)
        assert m, f"no size line for {board} in:\n{log}"
        flash, flash_total, ram, ram_total = map(int, m.groups())
        assert (flash_total, ram_total) == (flash_max, ram_max)
        assert flash == len(hex_image(avr_build / board / f"{board}.hex"))  # the number is the image
        assert flash < flash_max * 0.8 and ram < ram_max * 0.6  # room for the stack and growth


def test_warnings_are_errors_for_our_code():
    make = (FIRMWARE / "Makefile").read_text()
    assert re.search(r"^WARN := -Wall -Wextra -Werror$", make, re.M)
    assert make.count("$(WARN)") >= 4  # controller, knob box common + sketch, harness


def test_knobbox_image_carries_the_hid_descriptor_and_isrs(avr_build, vectors):
    elf = avr_build / "knobbox" / "knobbox.elf"
    flash = hex_image(avr_build / "knobbox" / "knobbox.hex")
    assert bytes.fromhex(vectors["hid"]["report_descriptor"]) in flash
    syms = subprocess.run(["avr-nm", str(elf)], capture_output=True, text=True, check=True).stdout
    for vector in ("__vector_10", "__vector_11", "__vector_32"):  # USB general, USB endpoint, Timer3
        assert re.search(rf" T {vector}$", syms, re.M), vector


def test_controller_enables_the_watchdog(avr_build):
    """wdt_enable writes WDTCSR (0x60) with WDE set; the simavr test checks it fires."""
    dis = subprocess.run(["avr-objdump", "-d", str(avr_build / "controller" / "controller.elf")],
                         capture_output=True, text=True, check=True).stdout
    assert re.search(r"sts\s+0x0060, r\d+", dis)
