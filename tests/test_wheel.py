"""The exhibit as a user installs it: the built wheel in a fresh venv, run from another folder,
finds its shipped configs, layouts, timelines, scenes and shaders (importlib.resources)."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_the_wheel_runs_outside_the_repository(tmp_path):
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(ROOT)],
        check=True,
        cwd=tmp_path,
        capture_output=True,
    )
    (wheel,) = wheels.glob("exhibit-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for shipped in (
        "exhibit/configs/kiosk.toml",
        "exhibit/configs/devices/knobbox.toml",
        "exhibit/configs/attract/01-hypersphere.toml",
        "exhibit/configs/scenes/veronese.toml",
        "exhibit/systemd/exhibit.service",
        "exhibit/render/shaders/surface.glsl",
    ):
        assert shipped in names, shipped

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    subprocess.run(
        [python, "-m", "pip", "install", "-q", "--no-deps", str(wheel)],
        check=True,
        capture_output=True,
    )
    # the dependencies (numpy, moderngl, ...) come from the test environment's site-packages,
    # added as a plain path, so its editable install of this checkout is not seen
    site = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    Path(site, "deps.pth").write_text(sysconfig.get_path("purelib") + "\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("EXHIBIT_")}
    env["EXHIBIT_CACHE_DIR"] = str(tmp_path / "cache")

    def exhibit(*args):
        return subprocess.run(
            [venv / "bin" / "exhibit", *args],
            cwd=elsewhere,
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )

    where = subprocess.run(
        [python, "-c", "import exhibit; print(exhibit.__file__)"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
    ).stdout
    assert where.startswith(site), where  # the wheel's copy, not the checkout
    checked = exhibit("check-config")
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "site-packages/exhibit/configs/kiosk.toml: OK" in checked.stdout
    listed = exhibit("scenes")
    assert "sphere-slice" in listed.stdout and "veronese" in listed.stdout
    drawn = exhibit(
        "render", "--figure", "6", "--size", "320x240", "--out", str(elsewhere / "f6.png")
    )
    assert drawn.returncode == 0, drawn.stderr
    assert (elsewhere / "f6.png").stat().st_size > 5000
