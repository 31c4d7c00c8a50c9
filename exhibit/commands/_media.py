"""What `exhibit render`'s outputs share: sizes, and MP4s through ffmpeg."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from exhibit.errors import ExhibitError

MAX_PIXELS = 8192


def whole_number(text: str, name: str, low: int, high: int) -> int:
    try:
        value = int(text)
    except (TypeError, ValueError):
        raise ExhibitError(f"{name}: {text!r} is not a whole number") from None
    if not low <= value <= high:
        raise ExhibitError(f"{name}: {value} must lie in [{low}, {high}]")
    return value


def parse_size(text: str) -> tuple[int, int]:
    parts = text.lower().split("x")
    if len(parts) != 2:
        raise ExhibitError(f"--size: {text!r} is not WIDTHxHEIGHT (e.g. 1280x720)")
    return (
        whole_number(parts[0], "--size width", 16, MAX_PIXELS),
        whole_number(parts[1], "--size height", 16, MAX_PIXELS),
    )


def need_ffmpeg(instead: str) -> None:
    """An ExhibitError unless ffmpeg is on PATH (``instead``: what to write without it)."""
    if shutil.which("ffmpeg") is None:
        raise ExhibitError(
            "--out: writing .mp4 needs ffmpeg on PATH (Debian: apt-get install "
            f"ffmpeg); use {instead} instead"
        )


def encode_mp4(folder: Path, out: Path, fps: float = 25) -> None:
    """``folder``'s frame_0000.png, frame_0001.png, ... as an H.264 MP4 at ``fps`` (ffmpeg)."""
    result = subprocess.run(
        [
            "ffmpeg",
            "-y",
            "-loglevel",
            "error",
            "-framerate",
            f"{fps:g}",
            "-i",
            str(folder / "frame_%04d.png"),
            "-pix_fmt",
            "yuv420p",
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            str(out),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    if result.returncode != 0:
        raise ExhibitError(f"ffmpeg failed: {result.stderr.strip().splitlines()[-1:]}")
