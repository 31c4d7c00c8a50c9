"""`exhibit simulate controller --firmware ...` as staff use it: the firmware in simavr behind a
stable link, read by `exhibit devices` and `exhibit monitor` exactly as they read a board; and
one-line errors for a wrong file or a missing harness.

A busy machine makes these commands start and run slowly: the waits end on what the commands
print, their own clocks (monitor's lines) judge their durations, and the wall clock only
bounds a hang (HANG_S)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest

from exhibit.cli import main

EXHIBIT = [sys.executable, "-m", "exhibit.cli"]
HANG_S = 120  # wall seconds: a command that has not finished by then hung


@pytest.mark.parametrize("make, fragment", [
    (lambda d: d / "missing.elf", "missing.elf: cannot read the firmware"),
    (lambda d: (d / "c.hex").write_text(":00000001FF\n") and d / "c.hex", "not an ELF file"),
    (lambda d: (d / "x.elf").write_bytes(b"\x7fELF" + bytes(14) + b"\x3e\x00") and d / "x.elf",
     "an ELF file for machine 62, not for the AVR"),
])
def test_a_wrong_firmware_file_is_one_line(tmp_path, capsys, make, fragment):
    path = make(tmp_path)
    assert main(["simulate", "controller", "--firmware", str(path), "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1, err


def test_a_missing_harness_says_how_to_build_it(avr_build, tmp_path, capsys):
    elf = avr_build / "controller" / "controller.elf"
    code = main(["simulate", "controller", "--firmware", str(elf), "--harness",
                 str(tmp_path / "nope"), "--duration", "1"])
    err = capsys.readouterr().err
    assert code == 2 and "make -C firmware sim" in err and "libsimavr-dev" in err, err


def test_options_that_need_the_firmware_or_the_protocol_simulator(tmp_path, capsys):
    assert main(["simulate", "controller", "--eeprom", str(tmp_path / "e"), "--duration", "1"]) == 2
    assert "go with --firmware" in capsys.readouterr().err
    assert main(["simulate", "controller", "--firmware", "x.elf", "--protocol-version", "2",
                 "--duration", "1"]) == 2
    assert "leave out --firmware" in capsys.readouterr().err


@pytest.mark.slow
def test_simulated_firmware_serves_devices_and_monitor(avr_build, harness, tmp_path):
    """The issue's acceptance check: `exhibit devices` and `exhibit monitor` see the board's
    hello, monitor its live axes, through the --link name."""
    link = tmp_path / "exhibit-controller"
    script = tmp_path / "moves.txt"
    script.write_text("wait 1.5\naxis 1 0.8\nwait 600\n")
    env = {**os.environ, "EXHIBIT_SIM_HARNESS": str(harness)}
    sim = subprocess.Popen(EXHIBIT + ["simulate", "controller", "--firmware",
                                      str(avr_build / "controller" / "controller.elf"),
                                      "--script", str(script), "--link", str(link),
                                      "--duration", str(2 * HANG_S)],  # Ctrl-C ends it
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        tty = sim.stdout.readline().strip()
        assert tty.startswith("/dev/pts/"), tty
        assert os.path.realpath(link) == tty
        common = ["--only", "--device", f"controller=serial://{link}", "--json"]
        # --wait ends early once the board answers
        devices = subprocess.run(EXHIBIT + ["devices", *common, "--wait", "60"], text=True,
                                 capture_output=True, timeout=HANG_S)
        assert devices.returncode == 0, devices.stderr
        doc = json.loads(devices.stdout)
        board = next(d for d in doc["configured"] if d["name"] == "controller")
        assert board["state"] == "connected" and "firmware 1.1.0" in board["detail"], board
        monitor = subprocess.run(EXHIBIT + ["monitor", *common, "--rate", "4", "--duration", "4"],
                                 text=True, capture_output=True, timeout=HANG_S)
        assert monitor.returncode == 0, monitor.stderr
        lines = [json.loads(line) for line in monitor.stdout.splitlines()]
        assert any(line["devices"]["controller"] == "connected" for line in lines)
        # the board's hello, as monitor shows it too
        assert any("firmware 1.1.0" in line["details"]["controller"] for line in lines), lines
        last = lines[-1]
        assert any(last["angles_deg"]) or last["sensor_r"] > 0, last  # live axes move the view
        assert len(lines) <= 4 * 4 + 1  # 4 lines a second, ended after 4 s by its own clock
    finally:
        sim.send_signal(signal.SIGINT)  # Ctrl-C
        out, err = sim.communicate(timeout=10)
    assert sim.returncode == 0, err
    assert not link.exists()  # the stable name goes with the simulator


@pytest.mark.parametrize("url, fragment", [
    ("sim://controller?firmware=/nonexistent/controller.elf", "cannot read the firmware"),
    ("sim://knobbox?firmware=x.elf", "firmware= runs the controller firmware"),
])
def test_sim_url_with_a_bad_firmware_is_one_line(capsys, url, fragment):
    assert main(["monitor", "--only", "--device", f"controller={url}", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.slow
def test_sim_url_runs_the_firmware_for_monitor(avr_build, harness, tmp_path):
    """sim://controller?firmware=ELF: the exhibit's own backend starts the firmware in simavr."""
    script = tmp_path / "moves.txt"
    script.write_text("wait 1\naxis 1 0.8\nwait 600\n")
    url = f"sim://controller?firmware={avr_build / 'controller' / 'controller.elf'}&script={script}"
    # monitor until it shows the board connected and the held stick moving the view (where the
    # config maps it), however long a busy machine takes to get there; then Ctrl-C
    monitor = subprocess.Popen(EXHIBIT + ["monitor", "--only", "--device", f"controller={url}",
                                          "--json", "--rate", "4", "--duration", str(HANG_S)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        lines = []
        for text in monitor.stdout:
            lines.append(json.loads(text))
            line = lines[-1]
            if line["devices"]["controller"] == "connected" and (
                    any(line["angles_deg"]) or line["sensor_r"] > 0):
                break
        else:
            pytest.fail(f"monitor ended without a connected, moving board: {lines[-1:]}")
    finally:
        monitor.send_signal(signal.SIGINT)
        _, err = monitor.communicate(timeout=HANG_S)
    assert monitor.returncode == 130, err  # Ctrl-C, as staff stop it
