"""The plain checkout at PREFIX (step 2 of docs/DEPLOYMENT.md) becoming a release: the first
`exhibit update` moves it into PREFIX-releases/ (:func:`move`) and makes its venv its own
(:func:`own_venv`). Apart from exhibit/commands/_releases.py, which switches between releases,
since this happens once per kiosk."""

from __future__ import annotations

import errno
import os
import re
import time
from collections.abc import Callable
from pathlib import Path

from exhibit.commands._release_checks import expected_version
from exhibit.errors import ExhibitError
from exhibit.schema import files, links


def check(here: Path, there: Path, prefix: str) -> None:
    """The plain checkout at ``here`` (PREFIX ``prefix``) can move into the releases folder
    ``there`` in one rename."""
    if os.path.ismount(here) or os.stat(here).st_dev != os.stat(there).st_dev:
        raise ExhibitError(
            f"cannot move the checkout {prefix} into {prefix}-releases/: it is a mount "
            f"point or on another file system; nothing was changed (move it there by hand, "
            f"then ln -s {os.path.basename(prefix)}-releases/NAME {prefix})"
        )


def clean_links(folder: Path) -> None:
    """Remove the link a killed :func:`move` left in the releases ``folder`` (NAME ->
    PREFIX-releases/NAME: only ever meant to be seen from PREFIX's folder)."""
    base = folder.name
    try:
        for entry in os.scandir(folder):
            if entry.is_symlink() and os.readlink(entry.path) == f"{base}/{entry.name}":
                os.unlink(entry.path)
    except OSError:
        pass


def move(here: Path, there: Path, prefix: str, out: Callable[[str], None]) -> str:
    """Move the plain folder at ``here`` (PREFIX ``prefix``, a checkout from before releases)
    into the releases folder ``there`` as a release; its name. Its venv is then made its own
    (:func:`own_venv`)."""
    version = expected_version(here) or "old"
    if version.startswith(".") or "/" in version:
        version = "old"
    releases = f"{prefix}-releases"
    name = f"{version}-checkout-{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}"
    target = there / name
    out(f"moving the checkout {prefix} to {releases}/{name}")
    try:
        # a link at the checkout's new place, pointing there as seen from PREFIX's folder,
        # exchanged with the checkout in one step: PREFIX is never missing
        os.symlink(f"{there.name}/{name}", target)
        try:
            links.exchange(here, target)
        except OSError as exc:
            if exc.errno not in (errno.EINVAL, errno.ENOSYS):
                target.unlink()
                raise
            target.unlink()  # no exchange on this file system: two renames
            os.rename(here, target)
            links.replace_link(here, f"{there.name}/{name}")
    except OSError as exc:
        raise ExhibitError(
            f"cannot move {prefix} to {releases}/{name}: "
            f"{exc.strerror or exc}; nothing was switched (a mount point? move it by hand, "
            f"then ln -s {there.name}/{name} {prefix})"
        ) from None
    own_venv(target, prefix, f"{releases}/{name}", out)
    return name


def own_venv(release: Path, was: str, now: str, out: Callable[[str], None]) -> None:
    """Make the venv of a checkout that moved from ``was`` (PREFIX) to ``now``
    (PREFIX-releases/NAME) its own: pip wrote ``was`` into its scripts' ``#!`` lines and its
    editable install (``__editable__*``, ``*.egg-link``, ``easy-install.pth``), so while
    PREFIX names another release, the checkout's `exhibit` would run that release's Python and
    code (a dead one's too, and its ModuleNotFoundError). Each file is replaced at once; one
    that cannot be is named and left (it still works while PREFIX names the checkout)."""
    venv = release / ".venv"
    edits: list[Path] = []
    for bin_file in sorted((venv / "bin").glob("*")):
        if bin_file.is_file() and not bin_file.is_symlink():
            edits.append(bin_file)
    for pattern in ("__editable__*", "*.egg-link", "easy-install.pth"):
        edits.extend(sorted(venv.glob(f"lib/python3*/site-packages/{pattern}")))
    old, new = was.encode(), now.encode()
    names = re.compile(re.escape(old) + rb"(?=[/'\"\n]|$)", re.M)
    for path in edits:
        try:
            data = files.read_regular(path, files.MAX_CONFIG_BYTES, follow=False)
            if path.parent.name == "bin" and not data.startswith(b"#!" + old + b"/"):
                continue
            changed = names.sub(new, data)
            if changed != data:
                files.write_atomic(path, changed, mode=os.stat(path).st_mode & 0o7777)
        except (OSError, ValueError) as exc:
            why = getattr(exc, "strerror", None) or str(exc)
            out(f"note: {path} still names {was} ({why}): it runs only while {was} is this one")
