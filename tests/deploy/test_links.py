"""The one link swap and the one lock (exhibit/schema/links.py), used by `exhibit update`,
`exhibit rollback` and the simulated devices' stable names."""

from __future__ import annotations

import os

import pytest

from exhibit.schema import files, links


def test_replace_link_swaps_in_one_rename_and_leaves_nothing_beside(tmp_path):
    link = tmp_path / "exhibit"
    links.replace_link(link, "a")
    links.replace_link(link, "b")
    assert os.readlink(link) == "b"
    assert sorted(os.listdir(tmp_path)) == ["exhibit"]


def test_replace_link_swaps_the_old_link_in_one_rename(tmp_path, monkeypatch):
    """The new link is made under another name and renamed over the old one: the live name is
    never removed, so a reader finds the old target or the new, never nothing."""
    link = tmp_path / "exhibit"
    links.replace_link(link, "a")
    calls = []
    real_replace = os.replace

    def replace(src, dst):
        calls.append((os.readlink(dst), os.readlink(src)))
        real_replace(src, dst)

    monkeypatch.setattr(os, "unlink", lambda *a, **k: pytest.fail("the live link was removed"))
    monkeypatch.setattr(os, "replace", replace)
    links.replace_link(link, "b")
    assert calls == [("a", "b")]
    assert os.readlink(link) == "b"


def test_a_failed_swap_keeps_the_old_link_and_leaves_no_temporary_one(tmp_path, monkeypatch):
    link = tmp_path / "exhibit"
    links.replace_link(link, "a")

    def replace(src, dst):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="Input/output error"):
        links.replace_link(link, "b")
    assert os.readlink(link) == "a"
    assert sorted(os.listdir(tmp_path)) == ["exhibit"]


@pytest.mark.parametrize("kind", ["folder", "file"])
def test_replace_link_refuses_what_is_not_a_link(tmp_path, kind):
    link = tmp_path / "exhibit"
    link.mkdir() if kind == "folder" else link.write_text("x")
    with pytest.raises(files.UnsafePath, match=f"is a {kind}, not a symbolic link"):
        links.replace_link(link, "a")
    assert sorted(os.listdir(tmp_path)) == ["exhibit"]


def test_a_stale_temporary_name_never_blocks_a_swap(tmp_path):
    (tmp_path / ".exhibit.exhibit-switch").mkdir()  # the fixed name of older versions
    links.replace_link(tmp_path / "exhibit", "a")
    assert os.readlink(tmp_path / "exhibit") == "a"


def test_leftovers_are_cleaned_when_ours_and_named_when_not(tmp_path):
    link = tmp_path / "exhibit"
    (tmp_path / ".exhibit.0123456789ab.exhibit-switch").symlink_to("x")
    (tmp_path / ".exhibit.exhibit-switch").mkdir()
    (tmp_path / ".exhibit.abcdefabcdef.exhibit-switch").write_text("?")
    (tmp_path / ".exhibit.foo.0123456789ab.exhibit-switch").symlink_to("x")  # exhibit.foo's
    lines = links.clean_switch_leftovers(link)
    assert sorted(os.listdir(tmp_path)) == [
        ".exhibit.abcdefabcdef.exhibit-switch",
        ".exhibit.foo.0123456789ab.exhibit-switch",
    ]
    assert lines == [
        f"{tmp_path}/.exhibit.abcdefabcdef.exhibit-switch is a file: not made by exhibit, "
        "left as it is"
    ]


def test_the_lock_names_its_holder_and_goes_with_it(tmp_path):
    path = tmp_path / ".exhibit-lock"
    fd = links.hold_lock(path, "pid 1, exhibit update x\n")
    with pytest.raises(links.Busy) as info:
        links.hold_lock(path, "pid 2, exhibit rollback\n")
    assert info.value.holder == "pid 1, exhibit update x"
    os.close(fd)
    os.close(links.hold_lock(path, "pid 2, exhibit rollback\n"))


@pytest.mark.parametrize("kind", ["a symbolic link", "a folder", "a FIFO"])
def test_the_lock_file_must_be_a_file(tmp_path, kind):
    path = tmp_path / ".exhibit-lock"
    if kind == "a symbolic link":
        path.symlink_to(tmp_path / "elsewhere")
    elif kind == "a folder":
        path.mkdir()
    else:
        os.mkfifo(path)
    with pytest.raises(files.UnsafePath, match=f"is {kind}, not a lock file"):
        links.hold_lock(path, "me")
    assert not (tmp_path / "elsewhere").exists()
