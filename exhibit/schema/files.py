"""Reading the files people write, without trusting them.

A config path can name a FIFO (reading blocks forever), /dev/zero (never ends), a 4 GB log or a
file in another encoding. Each is refused with a reason instead: the file is opened without
blocking, must be a regular file (a symlink to one is fine: deployments link configs), is read
up to a size cap, and must be UTF-8 TOML. Numbers inside texts are ASCII digits only
(:func:`parse_int`: "²", "①" or "٣" are not numbers), JSON from a file or a database row is
bounded in size and depth (:func:`loads_json`), and every file exhibit writes goes through
:func:`write_atomic`, which never writes through a device, FIFO or folder (and outputs a person
names are checked before the work that fills them: :func:`check_output`, :func:`output_folder`).

Why one module of this size: it is the one file-safety module (ARCHITECTURE.md): every read and
write of a file exhibit does not own goes through these few functions, which share their checks.
Changing what a name points at (a link swap, the one-at-a-time lock, an exchange) is apart, in
:mod:`exhibit.schema.links`.
"""

from __future__ import annotations

import json
import errno
import os
import re
import secrets
import stat
import tomllib
from pathlib import Path
from typing import Any

from exhibit.errors import ConfigError
import contextlib

#: The most a config, timeline, layout or scene file may hold.
MAX_CONFIG_BYTES = 1 << 20


def kind_of(mode: int) -> str:
    """What a file of ``mode`` is, as a message names it ("a FIFO", "a folder")."""
    for test, name in (
        (stat.S_ISREG, "a file"),
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "a special file"


class NotAFile(ValueError):
    """What :func:`read_regular` found instead of a regular file: ``kind`` is "a FIFO", "a
    folder", "a character device", "a symbolic link"..."""

    def __init__(self, kind: str):
        super().__init__(f"{kind}, not a regular file")
        self.kind = kind


class TooLarge(ValueError):
    """A file over :func:`read_regular`'s limit: ``size`` bytes (None: it grew while read)."""

    def __init__(self, size: int | None, limit: int):
        what = f"{size} bytes is" if size is not None else "it grew while being read,"
        super().__init__(f"{what} over the {limit}-byte limit")
        self.size, self.limit = size, limit


def read_regular(path: str | os.PathLike, limit: int, follow: bool = True) -> bytes:
    """The bytes of the regular file at ``path``, of at most ``limit`` bytes: the one way
    exhibit reads a file it did not just write. Opened non-blocking, so a FIFO in its place is
    refused by fstat instead of hanging the read, and read to at most ``limit`` + 1 bytes, so
    /dev/zero or a growing file cannot fill the memory. ``follow=False``: a symbolic link is
    refused too (a cache entry pointing at /dev/zero). Raises NotAFile, TooLarge, or the
    OSError of the open (FileNotFoundError, PermissionError...)."""
    flags = os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | (0 if follow else os.O_NOFOLLOW)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        if exc.errno == errno.ELOOP and not follow:
            raise NotAFile("a symbolic link") from None
        raise
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise NotAFile(kind_of(info.st_mode))
        if info.st_size > limit:
            raise TooLarge(info.st_size, limit)
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:
            raise TooLarge(None, limit)
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_bytes(path: str | Path, limit: int = MAX_CONFIG_BYTES) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes; ConfigError names the file."""
    path = Path(path)
    try:
        return read_regular(path, limit)
    except NotAFile as exc:
        raise ConfigError(f"{path}: cannot read: {exc.kind}, not a file") from None
    except TooLarge as exc:
        raise ConfigError(f"{path}: cannot read: {exc}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None


def read_text(path: str | Path, limit: int = MAX_CONFIG_BYTES) -> str:
    data = read_bytes(path, limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start})") from None


def read_toml(path: str | Path, limit: int = MAX_CONFIG_BYTES) -> dict:
    """The parsed TOML document; any failure is a ConfigError naming the file."""
    text = read_text(path, limit)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    except (RecursionError, ValueError, OverflowError, MemoryError) as exc:
        # arrays nested thousands deep, numbers beyond any use
        raise ConfigError(f"{path}: not valid TOML: {type(exc).__name__}") from None


def check_file_ref(path: Path, want_dir: bool = False, limit: int = MAX_CONFIG_BYTES) -> str | None:
    """Why ``path`` cannot be used as a referenced file (or folder), or None when it can."""
    try:
        info = path.stat()
    except OSError as exc:
        what = "folder" if want_dir else "file"
        if isinstance(exc, FileNotFoundError):
            return f"{what} {path} does not exist"
        return f"{what} {path}: {exc.strerror or exc}"
    if want_dir:
        return (
            None
            if stat.S_ISDIR(info.st_mode)
            else f"{path} is {kind_of(info.st_mode)}, not a folder"
        )
    if not stat.S_ISREG(info.st_mode):
        return f"{path} is {kind_of(info.st_mode)}, not a file"
    if info.st_size > limit:
        return f"{path} is {info.st_size} bytes, over the {limit}-byte limit"
    return None


# ---------------------------------------------------------------------- numbers in texts

_ASCII_INT = re.compile(r"[0-9]{1,18}", re.ASCII)


def parse_int(text: str, low: int, high: int) -> int:
    """The whole number ``text`` writes in ASCII digits (no sign, no spaces), in [low, high].

    str.isdigit() and int() accept superscripts, circled and Arabic-Indic digits ("²", "①",
    "٣"), and int() then fails on some of them: a file's text is read with this instead.
    ValueError says why, in words fit for ``file: key: reason``."""
    if not isinstance(text, str) or _ASCII_INT.fullmatch(text) is None:
        raise ValueError(f"expected a whole number written with the digits 0-9, got {text!r}")
    value = int(text)
    if not low <= value <= high:
        raise ValueError(f"must lie in [{low}, {high}], got {value}")
    return value


# ---------------------------------------------------------------------- JSON from files and rows

#: The most JSON text :func:`loads_json` parses by default, and how deep it may nest.
MAX_JSON_BYTES = 1 << 16
MAX_JSON_DEPTH = 32


def json_depth(text: str) -> int:
    """How deep the arrays and objects of a JSON text nest (brackets inside strings ignored)."""
    depth = deepest = 0
    in_string = escaped = False
    for c in text:
        if in_string:
            if escaped:
                escaped = False
            elif c == "\\":
                escaped = True
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth -= 1
    return deepest


def loads_json(text: Any, max_bytes: int = MAX_JSON_BYTES, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """``json.loads`` of a text of at most ``max_bytes`` characters nested at most ``max_depth``
    deep; ValueError otherwise (never RecursionError or MemoryError), with a short reason."""
    if isinstance(text, (bytes, bytearray)):
        try:
            text = bytes(text).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ValueError(f"not UTF-8 (byte {exc.start})") from None
    if not isinstance(text, str):
        raise ValueError(f"not JSON text but {type(text).__name__}")
    if len(text) > max_bytes:
        raise ValueError(f"JSON of {len(text)} characters is over the {max_bytes} limit")
    if json_depth(text) > max_depth:
        raise ValueError(f"JSON nested more than {max_depth} deep")
    try:
        return json.loads(text)
    except (ValueError, RecursionError, OverflowError, MemoryError) as exc:
        raise ValueError(f"not valid JSON ({type(exc).__name__})") from None


# ---------------------------------------------------------------------- writing files


class UnsafePath(OSError):
    """A path :func:`write_atomic` refuses; the message names the file or folder and why. An
    OSError, so callers that already report a folder they cannot write report this too."""


def split_target(path: str | os.PathLike) -> tuple[str, str]:
    """(folder, name) of a file to write; UnsafePath for "", ".", "/", "dir/" and the like."""
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if text == "":
        raise UnsafePath("an empty file name")
    folder, name = os.path.split(text)
    if text.endswith("/") or name in ("", ".", ".."):
        raise UnsafePath(f"{text}: names a folder, not a file")
    return folder or ".", name


def open_folder(
    folder: str | os.PathLike, root: str | os.PathLike | None = None, create: bool = False
) -> int:
    """A descriptor of ``folder`` (O_DIRECTORY; close it). With ``root``, ``folder`` must lie
    below it, and each component below ``root`` is opened with O_NOFOLLOW (created with
    ``create``): a symlink there, even to a folder inside the root, is refused, so nothing is
    ever written outside it. UnsafePath names the component; OSError for the rest."""
    dflags = os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC
    if root is None:
        if create:
            os.makedirs(folder, exist_ok=True)
        return os.open(folder, dflags)
    root_text = os.path.abspath(os.fspath(root))
    rel = os.path.relpath(os.path.abspath(os.fspath(folder)), root_text)
    if rel == ".." or rel.startswith("../"):
        raise UnsafePath(f"{folder} is not below {root_text}")
    fd = os.open(root_text, dflags)
    here = root_text
    try:
        for part in [] if rel == "." else rel.split("/"):
            here = os.path.join(here, part)
            try:
                info = os.stat(part, dir_fd=fd, follow_symlinks=False)
            except FileNotFoundError:
                if not create:
                    raise
                os.mkdir(part, 0o755, dir_fd=fd)
                info = os.stat(part, dir_fd=fd, follow_symlinks=False)
            if stat.S_ISLNK(info.st_mode):
                raise UnsafePath(
                    f"{here} is a symbolic link (to {os.readlink(part, dir_fd=fd)})"
                    f": refusing to write through it"
                )
            if not stat.S_ISDIR(info.st_mode):
                raise UnsafePath(f"{here} is {kind_of(info.st_mode)}, not a folder")
            try:
                child = os.open(part, dflags | os.O_NOFOLLOW, dir_fd=fd)
            except OSError as exc:
                raise OSError(exc.errno, exc.strerror, here) from None
            os.close(fd)
            fd = child
    except BaseException:
        os.close(fd)
        raise
    return fd


def _check_at(dir_fd: int, name: str, shown: str, links: bool = True) -> None:
    """UnsafePath when ``name`` in the folder exists and is not a regular file: a folder, FIFO,
    device, socket, or a symbolic link to one (a unit masked by a link to /dev/null, say). A
    link to a regular file, or a dangling one, is replaced by the rename, never written through;
    ``links=False`` refuses any symbolic link there (an output a person named: whatever the link
    points at, they may have meant it). A name the system refuses (over 255 bytes, a loop of
    links in its folders) is UnsafePath too, with the system's reason."""
    try:
        info = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise UnsafePath(f"{shown}: {exc.strerror or exc}") from None
    link = ""
    if stat.S_ISLNK(info.st_mode):
        if not links:
            try:
                to = os.readlink(name, dir_fd=dir_fd)
            except OSError:
                to = "?"
            raise UnsafePath(
                f"{shown} is a symbolic link (to {to}): refusing to write through it or replace it"
            )
        try:
            info = os.stat(name, dir_fd=dir_fd)
        except OSError:
            return  # dangling (or a loop): the rename replaces the link itself
        link = "a symbolic link to "
    if not stat.S_ISREG(info.st_mode):
        raise UnsafePath(
            f"{shown} is {link}{kind_of(info.st_mode)}, not a file: refusing to replace it"
        )


def check_target(
    path: str | os.PathLike, root: str | os.PathLike | None = None, links: bool = True
) -> None:
    """What :func:`write_atomic` checks before writing, without writing or creating anything:
    UnsafePath for a bad name, a symlinked folder below ``root``, or something at ``path`` that
    is not a regular file (nor a link to one; with ``links=False`` no link at all). A folder
    that does not exist yet is fine (it would be created); one that cannot be opened (a loop of
    links, a file in the way) is UnsafePath."""
    folder, name = split_target(path)
    try:
        fd = open_folder(folder, root)
    except FileNotFoundError:
        return
    except UnsafePath:
        raise
    except OSError as exc:
        raise UnsafePath(f"{folder}: {exc.strerror or exc}") from None
    try:
        _check_at(fd, name, os.fspath(path), links)
    finally:
        os.close(fd)


def _probe(fd: int, shown: str) -> None:
    """UnsafePath unless a file can be created in the folder ``fd`` (created and removed: the
    one test that holds for root, read-only mounts and /proc alike)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
    tmp = f".exhibit-probe.{secrets.token_hex(6)}.tmp"
    try:
        os.close(os.open(tmp, flags, 0o600, dir_fd=fd))
    except OSError as exc:
        raise UnsafePath(f"{shown}: cannot write there: {exc.strerror or exc}") from None
    with contextlib.suppress(OSError):
        os.unlink(tmp, dir_fd=fd)


def check_output(path: str | os.PathLike) -> None:
    """An output file a person named (``exhibit render --out FILE``), checked before the work
    that fills it: a file name (not "dir/"), in a folder that exists and can be written, with
    nothing at the name but a regular file (no folder, FIFO, device, nor a symbolic link of any
    kind: it is never written through). UnsafePath says which and why, in one line."""
    folder, name = split_target(path)
    shown = os.fspath(path)
    try:
        fd = open_folder(folder)
    except FileNotFoundError:
        raise UnsafePath(f"folder {folder} does not exist") from None
    except OSError as exc:
        raise UnsafePath(f"{folder}: {exc.strerror or exc}") from None
    try:
        _check_at(fd, name, shown, links=False)
        _probe(fd, folder)
    finally:
        os.close(fd)


def output_folder(path: str | os.PathLike, create: bool = True) -> Path:
    """An output folder a person named (``exhibit render --frames N --out DIR``), checked and
    (``create``) made before the work that fills it: UnsafePath when something else is there (a
    file, a FIFO, a device, a dangling symbolic link) or it cannot be written (read-only,
    /proc). A link to a folder is followed: the trailing name says it is meant as a folder."""
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if text == "":
        raise UnsafePath("an empty folder name")
    folder = Path(text)
    try:
        info = os.lstat(folder)
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise UnsafePath(f"{text}: {exc.strerror or exc}") from None
    if info is not None and stat.S_ISLNK(info.st_mode):
        try:
            info = os.stat(folder)
        except OSError as exc:
            why = "a dangling symbolic link" if isinstance(exc, FileNotFoundError) else None
            raise UnsafePath(
                f"{text} is {why}" if why else f"{text}: {exc.strerror or exc}"
            ) from None
    if info is not None and not stat.S_ISDIR(info.st_mode):
        raise UnsafePath(f"{text} is {kind_of(info.st_mode)}, not a folder")
    if info is None:
        if not create:
            raise UnsafePath(f"folder {text} does not exist")
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError as exc:
            raise UnsafePath(f"{text}: cannot make the folder: {exc.strerror or exc}") from None
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError as exc:
        raise UnsafePath(f"{text}: {exc.strerror or exc}") from None
    try:
        _probe(fd, text)
    finally:
        os.close(fd)
    return folder


def write_atomic(
    path: str | os.PathLike,
    data: bytes | str,
    mode: int = 0o644,
    root: str | os.PathLike | None = None,
    sync: bool = True,
    make_folder: bool = False,
    heal: bool = False,
    links: bool = True,
) -> None:
    """Replace the file at ``path`` with ``data`` at once: a reader sees the old file or the new
    one, never a part. The one way exhibit writes a file.

    Refused with UnsafePath (an OSError naming the path): an empty or folder-like name, and
    anything at ``path`` that is not a regular file: a device such as /dev/null, a FIFO, a
    folder, or a symlink to one (a symlink to a file is replaced, not followed). With ``root``
    (exhibit install --root), the folders below it are walked
    with O_NOFOLLOW (:func:`open_folder`), so a symlinked etc/ cannot lead outside. The data goes
    to a temporary ``.NAME.RANDOM.tmp`` in the same folder, created with O_EXCL|O_NOFOLLOW
    (nothing planted there is written through), given ``mode`` on the descriptor whatever the
    umask, fsynced (``sync``: files rewritten every few seconds pass False, since losing the last
    one to a power cut is harmless and wearing the flash is not), then renamed over the name.
    The temporary name does not end in .prom or .json, so a collector globbing ``*.prom`` never
    reads it half written. ``make_folder`` creates missing folders. ``heal`` (a cache entry,
    never a file a person made): whatever is at ``path`` is replaced by the rename, not refused
    (a FIFO, a device node or a link planted there; an empty folder is removed first). Raises
    OSError (a missing or read-only folder, a full disk), leaving no temporary file behind.
    ``links=False``: a symbolic link at ``path`` is refused too, not replaced (an output a person
    named, :func:`check_output`)."""
    folder, name = split_target(path)
    shown = os.fspath(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    fd = open_folder(folder, root, create=make_folder)
    try:
        if not heal:
            _check_at(fd, name, shown, links)
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
        for _ in range(100):
            tmp = f".{name[:40]}.{secrets.token_hex(6)}.tmp"  # as short as NAME_MAX needs
            try:
                out = os.open(tmp, flags, 0o600, dir_fd=fd)
                break
            except FileExistsError:
                continue
        else:
            raise FileExistsError(f"no free temporary name next to {shown}")
        try:
            try:
                os.fchmod(out, mode)  # the service's UMask would make it private
                view = memoryview(data)
                while view:
                    view = view[os.write(out, view) :]
                if sync:
                    os.fsync(out)
            finally:
                os.close(out)
            if not heal:
                _check_at(fd, name, shown, links)  # nothing swapped in meanwhile
            try:
                os.replace(tmp, name, src_dir_fd=fd, dst_dir_fd=fd)
            except IsADirectoryError:
                if not heal:
                    raise
                os.rmdir(name, dir_fd=fd)  # an empty folder in its place; a full one stays
                os.replace(tmp, name, src_dir_fd=fd, dst_dir_fd=fd)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp, dir_fd=fd)
            raise
    finally:
        os.close(fd)
