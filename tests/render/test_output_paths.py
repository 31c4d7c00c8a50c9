"""Every file `exhibit render` writes (a still, --frames as a folder, GIF or MP4, --timeline as
frames, MP4 or a contact sheet, --takeover) goes through the one safe writer
(exhibit.schema.files): a FIFO, a folder named as FILE.png, a dangling link, /proc, a 300-byte
name, an unwritable folder or a symbolic link at the name is refused in one line with exit 2,
before any GL work, and nothing is written through a link (issue 33)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.schema.files import UnsafePath, check_output, output_folder, write_atomic

ROOT = Path(__file__).resolve().parents[2]
TIMELINE = str(ROOT / "configs" / "attract" / "01-hypersphere.toml")
LONG = "a" * 300

#: Each way of writing, as the arguments before --out; every one refuses the same places.
COMMANDS = {
    "still": ["hopf", "--size", "64x36"],
    "frames": ["hopf", "--size", "64x36", "--frames", "2"],
    "gif": ["hopf", "--size", "64x36", "--frames", "2"],
    "sheet": ["--timeline", TIMELINE, "--size", "64x36"],
    "timeline frames": ["--timeline", TIMELINE, "--size", "64x36"],
    "takeover": ["--takeover", "hopf", "--size", "64x36"],
}
#: The name each writes to: a file, or a folder (DIR/).
FILE_NAME = {"still": "x.png", "gif": "x.gif", "sheet": "x.png", "takeover": "x.png"}
FOLDERS = ("frames", "timeline frames")


@pytest.fixture
def place(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    (tmp_path / "victim").write_text("keep")
    return tmp_path


def refused(capsys, argv) -> str:
    try:
        code = main(["render", *argv])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err and "internal error" not in err
    return err


def _hostile(kind: str, place: Path) -> list[tuple[str, str]]:
    """(--out, what the refusal says) for each hostile output of ``kind``."""
    if kind in FOLDERS:
        (place / "dangling").symlink_to(place / "nowhere")
        (place / "file").write_text("x")
        os.mkfifo(place / "fifo")
        return [
            ("dangling/", "dangling symbolic link"),
            ("file/", "not a folder"),
            ("fifo/", "a FIFO, not a folder"),
            ("/proc/self/", "cannot write there"),
            (f"{LONG}/", "File name too long"),
        ]
    name = FILE_NAME[kind]
    stem, suffix = os.path.splitext(name)
    os.mkfifo(place / f"fifo{suffix}")
    (place / f"d{suffix}").mkdir()
    (place / f"link{suffix}").symlink_to(place / "victim")
    (place / f"dangling{suffix}").symlink_to(place / "nowhere")
    cases = [
        (f"fifo{suffix}", "a FIFO"),
        (f"link{suffix}", "is a symbolic link"),
        (f"dangling{suffix}", "is a symbolic link"),
        (f"/proc/self/x{suffix}", "cannot write there"),
        (f"{LONG}{suffix}", "File name too long"),
    ]
    if kind in ("still", "gif", "takeover"):  # --timeline d.png/: a folder of frames, as asked
        cases.append((f"d{suffix}", "a folder, not a file"))
    if kind in ("still", "takeover"):  # --frames N --out d.gif/: the same
        cases.append((f"d{suffix}/", "names a folder"))
    return cases


@pytest.mark.parametrize("kind", list(COMMANDS))
def test_hostile_outputs_are_refused_in_one_line(place, capsys, kind):
    for out, message in _hostile(kind, place):
        err = refused(capsys, [*COMMANDS[kind], "--out", out])
        assert message in err, (out, err)
    assert (place / "victim").read_text() == "keep"
    assert not (place / "nowhere").exists()


@pytest.mark.parametrize("kind", list(COMMANDS))
def test_an_unwritable_folder_is_refused(place, capsys, kind):
    if os.geteuid() == 0:  # root writes through the mode bits; sysfs refuses everyone
        folder = Path("/sys")
    else:
        folder = place / "ro"
        folder.mkdir()
        folder.chmod(0o555)
    out = f"{folder}/x/" if kind in FOLDERS else f"{folder}/{FILE_NAME[kind]}"
    if kind in FOLDERS and os.geteuid() == 0:
        out = f"{folder}/"
    err = refused(capsys, [*COMMANDS[kind], "--out", out])
    assert "cannot" in err


def test_check_output_and_write_atomic_refuse_any_link(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    link = tmp_path / "out.png"
    link.symlink_to(victim)
    with pytest.raises(UnsafePath, match="symbolic link"):
        check_output(link)
    with pytest.raises(UnsafePath, match="symbolic link"):
        write_atomic(link, b"new", links=False)
    write_atomic(link, b"new")  # a config the program owns: the link is replaced, not followed
    assert victim.read_text() == "keep" and not link.is_symlink()


def test_a_long_name_is_written_when_the_system_allows_it(tmp_path):
    name = tmp_path / ("b" * 250 + ".png")  # the temporary name must not be longer
    write_atomic(name, b"png")
    assert name.read_bytes() == b"png"
    assert [p.name for p in tmp_path.iterdir()] == [name.name]


def test_output_folder_is_made_or_refused(tmp_path):
    assert output_folder(tmp_path / "new" / "frames").is_dir()
    (tmp_path / "to").mkdir()
    (tmp_path / "linked").symlink_to(tmp_path / "to")
    assert output_folder(tmp_path / "linked") == tmp_path / "linked"  # a link to a folder: fine
    with pytest.raises(UnsafePath, match="dangling"):
        (tmp_path / "gone").symlink_to(tmp_path / "nowhere")
        output_folder(tmp_path / "gone")
