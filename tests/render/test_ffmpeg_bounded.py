"""ffmpeg bounded (issue 40, item 5): an MP4 export whose ffmpeg hangs is stopped, with one line
naming ffmpeg and where it stopped, and nothing written; one that writes bytes that are not
UTF-8 is a one-line error (once `internal error: UnicodeDecodeError`); and no ffmpeg outlives
the command that started it.

ffmpeg is a fake on PATH (where _media runs it from) that writes its pid; limits are made small
through exhibit.tools; time bounds are 10 times generous."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from PIL import Image

from exhibit import tools
from exhibit.commands._media import encode_mp4, ffmpeg_limit_s
from exhibit.errors import ExhibitError
from tests.processes import alive, gone, outlived, pids

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def ffmpeg(tmp_path, monkeypatch):
    """ffmpeg(body): a fake ffmpeg first on PATH that writes its pid to ``tmp_path/pids`` and
    runs ``body``; returns the pid file (what is left of them is killed at the end)."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    record = tmp_path / "pids"

    def make(body: str) -> Path:
        fake = bin_dir / "ffmpeg"
        fake.write_text(f'#!/bin/sh\necho $$ >> "{record}"\n{body}\n')
        fake.chmod(0o755)
        return record

    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    yield make
    for pid in map(int, record.read_text().split()) if record.exists() else ():
        if alive(pid):
            os.kill(pid, signal.SIGKILL)


@pytest.fixture
def frames(tmp_path) -> Path:
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(3):
        Image.new("RGB", (64, 32), (i * 80, 0, 0)).save(folder / f"frame_{i:04d}.png")
    return folder


def test_a_silent_ffmpeg_is_stopped_and_named(ffmpeg, frames, tmp_path, monkeypatch):
    record = ffmpeg("exec sleep 1000")
    monkeypatch.setattr(tools, "FFMPEG_STALL_S", 0.5)
    out = tmp_path / "loop.mp4"
    begun = time.monotonic()
    with pytest.raises(ExhibitError) as info:
        encode_mp4(frames, out)
    assert time.monotonic() - begun < 5.0  # 10 x the limit, not for ever
    assert str(info.value) == (
        "ffmpeg did not answer within 0.5 s (before the first of 3 frames); no MP4 was written"
    )
    assert gone(pids(record)[0]) and not out.exists()


def test_where_a_stalled_ffmpeg_stopped(ffmpeg, frames, tmp_path, monkeypatch):
    ffmpeg("printf 'frame=1\\nfps=0.0\\nprogress=continue\\n'; exec sleep 1000")
    monkeypatch.setattr(tools, "FFMPEG_STALL_S", 0.5)
    with pytest.raises(ExhibitError, match=r"within 0\.5 s \(at frame 1 of 3\); no MP4"):
        encode_mp4(frames, tmp_path / "loop.mp4")


def test_an_ffmpeg_that_talks_for_ever_is_stopped_at_its_whole_limit(
    ffmpeg, frames, tmp_path, monkeypatch
):
    ffmpeg("while :; do printf 'frame=2\\nprogress=continue\\n'; sleep 0.05; done")
    monkeypatch.setattr(tools, "FFMPEG_BASE_S", 0.5)
    monkeypatch.setattr(tools, "FFMPEG_S_PER_MPIX", 0.0)
    begun = time.monotonic()
    with pytest.raises(ExhibitError) as info:
        encode_mp4(frames, tmp_path / "loop.mp4")
    assert time.monotonic() - begun < 5.0
    assert str(info.value) == (
        "ffmpeg took over 0.5 s, the most 3 frames may take (at frame 2 of 3); no MP4 was written"
    )


def test_the_whole_limit_grows_with_the_pixels():
    assert ffmpeg_limit_s(0, 0) == tools.FFMPEG_BASE_S
    assert ffmpeg_limit_s(900, 1280 * 720) > ffmpeg_limit_s(900, 320 * 180) > tools.FFMPEG_BASE_S


def test_binary_bytes_from_ffmpeg_are_one_line(ffmpeg, frames, tmp_path):
    ffmpeg(r"printf 'frame_%%04d.png: \377\376 Invalid data\033[0m\n\n' >&2; exit 1")
    with pytest.raises(ExhibitError) as info:
        encode_mp4(frames, tmp_path / "loop.mp4")
    assert str(info.value) == (
        "ffmpeg failed (exit status 1): frame_%04d.png: \ufffd\ufffd Invalid data\ufffd[0m"
    )


def test_the_cli_says_so_in_one_line(ffmpeg, tmp_path):
    """As the tester found it: `exhibit render --frames N --out FILE.mp4` with an ffmpeg that
    writes binary bytes (once `internal error: UnicodeDecodeError`)."""
    pytest.importorskip("moderngl")
    ffmpeg(r"printf '\377\376\375 broken\n' >&2; exit 1")
    out = tmp_path / "a.mp4"
    env = {**os.environ, "EXHIBIT_CACHE_DIR": str(tmp_path / "cache")}
    command = ["render", "hopf", "--resolution", "12", "--frames", "2", "--size", "64x48"]
    result = subprocess.run(
        [sys.executable, "-m", "exhibit", *command, "--out", str(out)],
        capture_output=True,
        env=env,
        cwd=ROOT,
    )
    err = result.stderr.decode("utf-8", "replace")
    if "EGL" in err and result.returncode != 0 and "ffmpeg" not in err:
        pytest.skip(f"no headless GL here: {err.strip()}")
    assert result.returncode == 2, err
    assert err.count("\n") == 1 and "UnicodeDecodeError" not in err and "Traceback" not in err
    assert "ffmpeg failed (exit status 1): \ufffd\ufffd\ufffd broken" in err
    assert not out.exists()


CALLER = """
import sys
from pathlib import Path
from exhibit.commands._media import encode_mp4
encode_mp4(Path(sys.argv[1]), Path(sys.argv[2]))
"""


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_no_ffmpeg_outlives_the_export(ffmpeg, frames, tmp_path, sig):
    record = ffmpeg("exec sleep 1000")
    caller = subprocess.Popen(
        [sys.executable, "-c", CALLER, str(frames), str(tmp_path / "x.mp4")],
        cwd=ROOT,
        stderr=subprocess.DEVNULL,
    )
    assert outlived(caller, record, sig) is None, f"ffmpeg outlived the export ({sig.name})"
