"""`exhibit render --timeline` and `--takeover`: the running kiosk played for a curator's review
(frames, an MP4, a contact sheet, a takeover frame), and one-line errors with exit code 2.

The renders run as a user runs them, in a child process (a second EGL context created and
released in this process can crash Mesa when the suite's own context draws again)."""

from __future__ import annotations

import json
import os
import stat
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from exhibit.cli import main
from exhibit.commands._review import sheet_size

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "configs"
SIZE = (320, 180)
FPS = 4
#: Two captions the German catalogue translates (the hypersphere timeline's first two).
FIRST = "Three doughnuts on the surface of a 4D ball, seen from infinitely far away in 4D."
SECOND = "Now the 4D viewpoint moves closer: the green doughnut grows far more than the red one."


@pytest.fixture
def german() -> dict:
    return tomllib.loads((SHIPPED / "languages" / "de.toml").read_text())["text"]


@pytest.fixture
def setup(tmp_path, monkeypatch):
    """A two-second timeline of the Hopf tori (its caption changes at t = 1) and a site file
    with a coarse mesh, so the kiosk starts in a moment."""
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    timeline = tmp_path / "tiny.toml"
    timeline.write_text(f"""
name = "Tiny"
scene = "hopf"
[[keyframe]]
t = 0
caption = "{FIRST}"
[[keyframe]]
t = 1
angles = [20, 0, 0, 0, 0, 0]
caption = "{SECOND}"
[[keyframe]]
t = 2
angles = [40, 0, 0, 0, 0, 0]
""")
    site = tmp_path / "site.toml"
    site.write_text("[content]\nresolution = { hopf = 12 }\n")
    return timeline, site


def _render(cli, timeline, site, out, *extra):
    result = cli(
        "render",
        "--timeline",
        str(timeline),
        "--config",
        str(site),
        "--size",
        f"{SIZE[0]}x{SIZE[1]}",
        "--out",
        str(out),
        *extra,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    return result


def fake_ffmpeg(tmp_path, monkeypatch) -> Path:
    """A stand-in ffmpeg on PATH that records its arguments, the frames it was given and the
    size of each WAV among them (JSON in the returned file), and writes an empty output."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    record = tmp_path / "ffmpeg.json"
    fake = bin_dir / "ffmpeg"
    fake.write_text(f"""#!{sys.executable}
import glob, json, os, sys
args = sys.argv[1:]
pattern = args[args.index("-i") + 1]
frames = glob.glob(os.path.join(os.path.dirname(pattern), "frame_*.png"))
audio = [os.path.getsize(a) for a in args if a.endswith(".wav")]
json.dump({{"args": args, "frames": len(frames), "audio_bytes": audio}}, open({str(record)!r}, "w"))
open(args[-1], "wb").close()
""")
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    return record


def _index(folder: Path) -> dict:
    return json.loads((folder / "index.json").read_text())


def test_frames_in_a_folder(gl, cli, setup, tmp_path):
    timeline, site = setup
    out = tmp_path / "frames"
    _render(cli, timeline, site, f"{out}/", "--fps", str(FPS))
    frames = sorted(out.glob("frame_*.png"))
    assert len(frames) == 2 * FPS + 1  # t = 0, 0.25, ... 2.0: the duration's both ends
    index = _index(out)
    assert [f["t"] for f in index["frames"]] == [i / FPS for i in range(2 * FPS + 1)]
    assert [f["caption"] for f in index["frames"]] == [FIRST] * FPS + [SECOND] * (FPS + 1)
    assert index["language"] == "en" and index["fps"] == FPS
    with Image.open(frames[0]) as image:
        assert image.size == SIZE
    # The caption change shows: the caption panel (top left) differs before and after t = 1.
    before, after = (
        np.asarray(Image.open(frames[i]))[: SIZE[1] // 3, : SIZE[0] // 2] for i in (FPS - 1, -1)
    )
    assert (before != after).any(axis=-1).mean() > 0.02


def test_german(gl, cli, setup, tmp_path, german):
    timeline, site = setup
    out = tmp_path / "de"
    _render(cli, timeline, site, f"{out}/", "--fps", "2", "--language", "de")
    index = _index(out)
    assert index["language"] == "de"
    assert [f["caption"] for f in index["frames"]] == [german[FIRST]] * 2 + [german[SECOND]] * 3


def test_contact_sheet(gl, cli, setup, tmp_path):
    timeline, site = setup
    out = tmp_path / "sheet.png"
    _render(cli, timeline, site, out, "--fps", "5")
    with Image.open(out) as sheet:
        assert sheet.size == sheet_size(2, SIZE)[0]  # one tile per caption, two captions


def test_mp4_through_ffmpeg(gl, cli, setup, tmp_path, monkeypatch):
    """The frames go to ffmpeg at --fps (a stand-in ffmpeg records what it was given)."""
    timeline, site = setup
    record = fake_ffmpeg(tmp_path, monkeypatch)
    out = tmp_path / "loop.mp4"
    _render(cli, timeline, site, out, "--fps", str(FPS))
    seen = json.loads(record.read_text())
    assert out.exists() and seen["frames"] == 2 * FPS + 1
    assert seen["args"][seen["args"].index("-framerate") + 1] == str(FPS)


def test_takeover_writes_the_png(gl, cli, tmp_path, monkeypatch):
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    site = tmp_path / "site.toml"
    site.write_text("[content]\nresolution = { hopf = 12 }\n")
    out = tmp_path / "takeover.png"
    result = cli(
        "render",
        "--takeover",
        "hopf",
        "--config",
        str(site),
        "--size",
        "320x180",
        "--after",
        "1",
        "--fps",
        "4",
        "--out",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    with Image.open(out) as image:
        assert image.size == (320, 180)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--timeline", "no-such.toml", "--out", "x.png"], "no-such.toml does not exist"),
        (["--timeline", str(SHIPPED / "kiosk.toml"), "--out", "x.png"], "not a timeline"),
        (["--timeline", str(ROOT / "README.md"), "--out", "x.png"], "not a timeline"),
        (["--timeline", str(SHIPPED / "attract"), "--out", "x.png"], "is not a file"),
        (
            [
                "--timeline",
                str(SHIPPED / "attract" / "01-hypersphere.toml"),
                "--language",
                "xx",
                "--out",
                "x.png",
            ],
            "no catalogue for 'xx'",
        ),
        (
            ["--timeline", str(SHIPPED / "attract" / "01-hypersphere.toml"), "--out", "x.jpg"],
            "must be a folder (ending in /), an .mp4 or a .png",
        ),
        (
            [
                "--timeline",
                str(SHIPPED / "attract" / "01-hypersphere.toml"),
                "--out",
                "/no/such/dir/x.png",
            ],
            "does not exist",
        ),
        (
            [
                "--timeline",
                str(SHIPPED / "attract" / "01-hypersphere.toml"),
                "--fps",
                "0",
                "--out",
                "x/",
            ],
            "argument --fps: must lie in [1, 120], got 0",
        ),
        (["--timeline", str(SHIPPED / "attract" / "01-hypersphere.toml")], "--out is required"),
        (
            ["hopf", "--timeline", str(SHIPPED / "attract" / "01-hypersphere.toml"), "--out", "x/"],
            "takes no scene name",
        ),
        (["--takeover", "nope", "--out", "x.png"], "no scene named 'nope'"),
        (["--takeover", "hopf", "--out", "x.gif"], "must end in .png"),
        (
            ["--takeover", "hopf", "--after", "-1", "--out", "x.png"],
            "argument --after: must lie in [0, 600], got -1",
        ),
        (
            [
                "--takeover",
                "hopf",
                "--timeline",
                str(SHIPPED / "attract" / "01-hypersphere.toml"),
                "--out",
                "x.png",
            ],
            "not both",
        ),
        (["hopf", "--language", "de", "--out", "x.png"], "--language goes with --timeline"),
    ],
)
def test_bad_input_gets_one_line_and_exit_2(capsys, argv, message):
    try:
        code = main(["render", *argv])
    except SystemExit as exc:  # argparse refuses a flag's value itself
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_mp4_without_ffmpeg_says_so(capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("PATH", str(tmp_path))  # no ffmpeg there
    assert (
        main(
            [
                "render",
                "--timeline",
                str(SHIPPED / "attract" / "01-hypersphere.toml"),
                "--out",
                str(tmp_path / "x.mp4"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "needs ffmpeg on PATH" in err and err.count("\n") == 1


needs_speech = pytest.mark.skipif(
    not __import__("exhibit.narration.speech", fromlist=["x"]).available(),
    reason="espeak-ng is not installed (bootstrap.sh installs it)",
)


@needs_speech
def test_narration_beside_the_frames(gl, cli, setup, tmp_path):
    """--narration: DIR/narration.wav as long as the frames, speech within each segment's start
    and end and silence outside them, each segment at its caption's keyframe, the caption held
    on screen while it speaks (the tiny timeline's captions are far too short for their words)."""
    import wave

    timeline, site = setup
    out = tmp_path / "narrated"
    _render(cli, timeline, site, f"{out}/", "--fps", str(FPS), "--narration")
    index = _index(out)
    frames, segments = index["frames"], index["narration"]["segments"]
    assert [s["keyframe"] for s in segments] == [0, 1] and not index["narration"]["failed"]
    assert segments[0]["text"] == FIRST and segments[1]["start"] >= segments[0]["end"] - 0.3
    with wave.open(str(out / "narration.wav")) as w:
        rate = w.getframerate()
        samples = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2").astype(float)
    assert len(samples) / rate == pytest.approx(len(frames) / FPS, abs=1e-3)

    def loudness(a: float, b: float) -> float:
        part = samples[int(a * rate) : int(b * rate)]
        return float(np.sqrt(np.mean(part**2))) if len(part) else 0.0

    for s in segments:
        assert loudness(s["start"], s["end"]) > 300  # speech
        shown = [f for f in frames if s["start"] <= f["t"] < s["end"]]
        assert shown and all(f["caption"] == s["text"] for f in shown)
    # held: the timeline's 2 s take twice as long on the review's clock, and more
    assert frames[-1]["t"] > 4.0 and frames[-1]["timeline_t"] <= 2.0
    assert loudness(segments[-1]["end"] + 0.05, len(samples) / rate) < 30  # silence after


@needs_speech
def test_narration_is_the_mp4s_sound(gl, cli, setup, tmp_path, monkeypatch):
    """With ffmpeg on PATH the MP4 gets the narration as an AAC track (a stand-in ffmpeg
    records its arguments; the real one is used where installed: docs/KIOSK.md)."""
    timeline, site = setup
    record = fake_ffmpeg(tmp_path, monkeypatch)
    _render(cli, timeline, site, tmp_path / "loop.mp4", "--fps", str(FPS), "--narration")
    seen = json.loads(record.read_text())
    assert "aac" in seen["args"] and seen["audio_bytes"][0] > 10_000
    assert seen["frames"] > 4 * FPS  # held while it speaks


def test_narration_needs_a_timeline_and_no_sheet(cli, setup, tmp_path):
    timeline, site = setup
    for args, message in (
        (
            ["render", "hopf", "--narration", "--out", str(tmp_path / "x.png")],
            "goes with --timeline",
        ),
        (
            [
                "render",
                "--timeline",
                str(timeline),
                "--narration",
                "--out",
                str(tmp_path / "s.png"),
            ],
            "a contact sheet has no sound",
        ),
    ):
        result = cli(*args)
        assert result.returncode == 2 and message in result.stderr, result.stderr
        assert "Traceback" not in result.stderr
