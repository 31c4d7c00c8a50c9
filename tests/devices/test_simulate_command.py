"""`exhibit simulate controller --link PATH`: a link that cannot be made is one line and exit 2,
checked before the simulator starts; nothing but an old symlink is ever replaced by it."""

from __future__ import annotations

import os
import stat

import pytest

from exhibit.cli import main


@pytest.mark.parametrize(
    "where, fragment",
    [
        ("missing/ctl", "does not exist"),
        ("file/ctl", "is not a folder"),
        ("folder", "something other than a symlink"),
        ("fifo", "something other than a symlink"),
        ("file", "something other than a symlink"),
    ],
)
def test_a_link_that_cannot_be_made_is_one_line(tmp_path, capsys, where, fragment):
    (tmp_path / "file").write_text("keep")
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    link = tmp_path / where
    assert main(["simulate", "controller", "--duration", "0.1", "--link", str(link)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "internal error" not in err and err.count("\n") == 1
    assert f"--link {link}" in err and fragment in err
    assert (tmp_path / "file").read_text() == "keep"
    assert stat.S_ISFIFO(os.lstat(tmp_path / "fifo").st_mode)
    assert (tmp_path / "folder").is_dir()


def test_a_link_without_a_name_is_refused(capsys):
    with pytest.raises(SystemExit) as stop:  # a usage error, from argparse
        main(["simulate", "controller", "--duration", "0.1", "--link", ""])
    assert stop.value.code == 2
    for text in (".", "..", "/"):
        assert main(["simulate", "controller", "--duration", "0.1", "--link", text]) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and err.count("give the name of the symlink") == 4


def test_an_old_link_is_replaced(tmp_path, capsys):
    link = tmp_path / "ctl"
    link.symlink_to(tmp_path / "gone")
    assert main(["simulate", "controller", "--duration", "0.1", "--link", str(link)]) == 0
    assert capsys.readouterr().out.startswith("/dev/pts/")
