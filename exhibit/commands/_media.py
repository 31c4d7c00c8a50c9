"""What `exhibit render`'s outputs share: sizes, the checks on --out and the writes to it (all
through exhibit.schema.files: never through a link, FIFO, device or folder), and MP4s through
ffmpeg (run by exhibit.tools: its own process group, killed with the command, its time
bounded by exhibit.tools.FFMPEG_STALL_S without progress and FFMPEG_BASE_S and
FFMPEG_S_PER_MPIX in all)."""

from __future__ import annotations

import os
import re
import shutil
import struct
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from exhibit import tools
from exhibit.errors import ExhibitError
from exhibit.schema.files import UnsafePath, check_output, output_folder, write_atomic

if TYPE_CHECKING:  # numpy and PIL are imported where a frame is saved
    import numpy as np
    import PIL.Image


MAX_PIXELS = 8192
#: The most a render job may draw, frames x pixels: about 18,000 frames of 1280 x 720 (12
#: minutes at 25 fps; hours of llvmpipe time), or 256 of the largest size. A longer job is
#: refused before it starts, with what it would have drawn.
MAX_JOB_PIXELS = 1 << 34
#: The most frames a render job may draw, whatever their size (each is a kiosk step and a PNG).
MAX_JOB_FRAMES = 50_000


def whole_number(text: str, name: str, low: int, high: int) -> int:
    """A whole number written with the ASCII digits 0-9 (int() reads "１２８０" and "٣")."""
    if not isinstance(text, str) or re.fullmatch(r"\s*[+-]?[0-9]{1,18}\s*", text, re.ASCII) is None:
        raise ExhibitError(f"{name}: {text!r} is not a whole number written with the digits 0-9")
    value = int(text)
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


@contextmanager
def gl_errors(size: tuple[int, int]) -> Iterator[None]:
    """A GL error while drawing frames of ``size`` (a framebuffer the driver will not make, out
    of memory) as one line, exit 2, instead of a traceback: a smaller --size is the fix."""
    import moderngl

    try:
        yield
    except moderngl.Error as exc:
        raise ExhibitError(
            f"--size {size[0]}x{size[1]}: the GL renderer cannot draw it ({exc}); "
            "try a smaller --size"
        ) from None


def check_gl_size(ctx, size: tuple[int, int], samples: int = 0) -> None:
    """An ExhibitError when ``ctx`` cannot draw frames of ``size`` (exhibit.render.offscreen:
    the GL's largest side, and the largest texture a frame needs)."""
    from exhibit.render.offscreen import size_problem

    problem = size_problem(ctx, size, samples)
    if problem is not None:
        raise ExhibitError(f"--size: {problem}")


def out_file(text: str) -> Path:
    """--out FILE checked before any work: a file name in a folder that exists and can be
    written, with nothing but a regular file at the name (no folder, FIFO, device or symbolic
    link); else an ExhibitError naming it and why."""
    try:
        check_output(text)
    except UnsafePath as exc:
        raise ExhibitError(f"--out: {exc}") from None
    return Path(text)


def out_folder(text: str) -> Path:
    """--out DIR checked and made before any work: a folder that can be written (or none yet);
    else an ExhibitError naming it and why (a file, FIFO or dangling link there, read-only)."""
    try:
        return output_folder(text)
    except UnsafePath as exc:
        raise ExhibitError(f"--out: {exc}") from None


def write_out(path: str | os.PathLike, data: bytes | str, sync: bool = True) -> None:
    """``data`` to the output ``path`` through the one safe writer, never through a link there;
    an ExhibitError names the path and why it could not be written."""
    try:
        write_atomic(path, data, links=False, sync=sync)
    except OSError as exc:
        why = exc.strerror or exc
        raise ExhibitError(f"--out: cannot write {os.fspath(path)}: {why}") from None


def save_frame(
    image: np.ndarray | PIL.Image.Image, path: str | os.PathLike, sync: bool = True
) -> None:
    """One picture (an array or a PIL image) as a PNG at ``path`` (:func:`write_out`)."""
    from exhibit.render.offscreen import png_bytes

    write_out(path, png_bytes(image), sync=sync)


def check_job(frames: int, size: tuple[int, int], what: str) -> None:
    """An ExhibitError, before any drawing, when ``frames`` frames of ``size`` are more than
    MAX_JOB_FRAMES or MAX_JOB_PIXELS (``what``: how to make it smaller)."""
    pixels = frames * size[0] * size[1]
    if frames > MAX_JOB_FRAMES or pixels > MAX_JOB_PIXELS:
        raise ExhibitError(
            f"this job would draw {frames} frames of {size[0]}x{size[1]} ({pixels:.3g} pixels), "
            f"over the limit of {MAX_JOB_FRAMES} frames and {MAX_JOB_PIXELS:.3g} pixels: {what}"
        )


def need_ffmpeg(instead: str) -> None:
    """An ExhibitError unless ffmpeg is on PATH (``instead``: what to write without it)."""
    if shutil.which("ffmpeg") is None:
        raise ExhibitError(
            "--out: writing .mp4 needs ffmpeg on PATH (Debian: apt-get install "
            f"ffmpeg); use {instead} instead"
        )


def encode_mp4(folder: Path, out: Path, fps: float = 25, audio: Path | None = None) -> None:
    """``folder``'s frame_0000.png, frame_0001.png, ... as an H.264 MP4 at ``fps`` (ffmpeg),
    with ``audio`` (a WAV) as its AAC sound track if given, encoded in a private folder and
    written to ``out`` by :func:`write_out`."""
    private = Path(tempfile.mkdtemp(prefix="exhibit-mp4-"))
    try:
        encoded = private / "out.mp4"
        _ffmpeg(folder, encoded, fps, audio)
        write_out(out, encoded.read_bytes())
    finally:
        shutil.rmtree(private, ignore_errors=True)


def _frames(folder: Path) -> tuple[int, int]:
    """How many frames ``folder`` holds, and the pixels of each (the first PNG's IHDR; 0 when
    it cannot be read)."""
    names = sorted(folder.glob("frame_*.png"))
    try:
        with open(names[0], "rb") as first:
            head = first.read(24)
        width, height = struct.unpack(">II", head[16:24])
    except (IndexError, OSError, struct.error):
        return len(names), 0
    return len(names), width * height


def ffmpeg_limit_s(frames: int, pixels: int) -> float:
    """The most encoding ``frames`` frames of ``pixels`` pixels may take in all."""
    return tools.FFMPEG_BASE_S + tools.FFMPEG_S_PER_MPIX * frames * pixels / 1e6


def _ffmpeg(folder: Path, out: Path, fps: float, audio: Path | None = None) -> None:
    """ffmpeg, bounded (module docstring): its progress on stdout (-progress) shows it alive;
    a failure is its last message, on one line, whatever bytes it wrote."""
    frames, pixels = _frames(folder)
    sound = ["-i", str(audio), "-c:a", "aac", "-b:a", "96k"] if audio is not None else []
    command = [
        "ffmpeg",
        "-nostdin",
        "-y",
        "-loglevel",
        "error",
        "-nostats",
        "-progress",
        "pipe:1",
        "-framerate",
        f"{fps:g}",
        "-i",
        str(folder / "frame_%04d.png"),
        *sound,
        "-pix_fmt",
        "yuv420p",
        "-vf",
        "pad=ceil(iw/2)*2:ceil(ih/2)*2",
        str(out),
    ]
    try:
        done = tools.run(
            command,
            limit_s=ffmpeg_limit_s(frames, pixels),
            stall_s=tools.FFMPEG_STALL_S,
            max_out=4096,
            max_err=1 << 16,
            tail=True,
        )
    except tools.ToolHung as exc:
        at = re.findall(rb"^frame=\s*(\d+)", exc.out, re.MULTILINE)
        where = (
            f"at frame {int(at[-1])} of {frames}" if at else f"before the first of {frames} frames"
        )
        if exc.stalled:
            why = f"ffmpeg did not answer within {exc.seconds:g} s ({where})"
        else:
            why = f"ffmpeg took over {exc.seconds:g} s, the most {frames} frames may take ({where})"
        raise ExhibitError(f"{why}; no MP4 was written") from None
    except OSError as exc:
        raise ExhibitError(f"cannot run ffmpeg: {exc.strerror or exc}") from None
    if done.code != 0:
        why = tools.last_line(done.err) or "no message"
        raise ExhibitError(f"ffmpeg failed (exit status {done.code}): {why}")
