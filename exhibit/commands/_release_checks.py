"""What makes a folder in PREFIX-releases/ a release, and the pruning that keeps only releases
(`exhibit update`; docs/DEPLOYMENT.md, "8. Updating"). Apart from exhibit/commands/_releases.py,
which switches between releases, because these look at one release's files.

A release runs when its `.venv/bin/exhibit --version` prints ``exhibit VERSION``, VERSION being
the ``__version__`` of its own exhibit/__init__.py (:func:`expected_version`): a 0-byte file, a
venv that pip was killed filling, or one that prints anything else, is not a release. While
`./bootstrap.sh update` makes one, it holds an flock on :data:`BUILDING` in it and removes the
file when the release is made; such a file that nobody holds is what a killed bootstrap left.
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
from collections.abc import Callable
from pathlib import Path

from exhibit.schema import files

#: The file ./bootstrap.sh update holds locked in a release while it makes it (bootstrap.sh).
BUILDING = ".exhibit-building"
#: What a release being removed is renamed to first, so a half-removed one is never taken for
#: a release.
REMOVING = re.compile(r"\..+\.exhibit-removing")


def expected_version(release: Path) -> str | None:
    """The ``__version__`` of the release folder ``release``'s exhibit/__init__.py, or None."""
    try:
        text = files.read_regular(release / "exhibit/__init__.py", files.MAX_CONFIG_BYTES)
    except (OSError, ValueError):
        return None
    match = re.search(r'^__version__ = "([^"\n]+)"', text.decode("utf-8", "replace"), re.M)
    return match.group(1) if match else None


def being_built(release: Path) -> bool | None:
    """Whether ./bootstrap.sh update is making ``release`` now (True: it holds
    :data:`BUILDING`), was killed making it (False: the file is there, held by nobody), or
    neither (None: no such file)."""
    try:
        fd = os.open(release / BUILDING, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except FileNotFoundError:
        return None
    except OSError:
        return True  # something odd there: leave the release alone
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)
    return False


def prune(
    folder: Path,
    shown: str,
    held: set[str],
    keep: int,
    runs: Callable[[str], str],
    out: Callable[[str], None],
) -> None:
    """Remove the oldest releases in ``folder`` (``shown`` as the kiosk sees it) beyond
    ``keep``, counting only releases that run (``runs(name)``: why not, or ""), never one in
    ``held`` (the current, the previous, the one being installed) nor one being made; never
    fails: a release that cannot be removed is kept, with a line saying why. What a killed
    bootstrap left (:func:`being_built` False) and does not run is removed; anything else that
    does not run is not counted, and named."""
    try:
        names, removing = [], []
        for p in folder.iterdir():
            if not p.is_dir() or p.is_symlink():
                continue
            if REMOVING.fullmatch(p.name):
                removing.append(p)
            elif not p.name.startswith(".") and p.name != "previous":
                names.append(p)
        old = sorted(
            (p for p in names if p.name not in held),
            key=lambda p: p.stat().st_mtime,
            reverse=True,
        )
    except OSError as exc:
        out(f"note: old releases not pruned: {exc.strerror or exc}")
        return
    for path in removing:  # left by a prune that was killed
        _remove(path, f"{shown}/{path.name}", out)
    kept = len(held & {p.name for p in names})
    for path in old:
        release = f"{shown}/{path.name}"
        building = being_built(path)
        if building:
            continue  # ./bootstrap.sh update is making it: not ours
        why = runs(path.name)
        if why and building is False:
            out(f"removing {release}, which a killed ./bootstrap.sh update left half-made")
        elif why:
            out(f"note: {release} does not run ({why}): not counted as a release; left there")
            continue
        elif kept < keep:
            kept += 1
            continue
        else:
            out(f"removing the old release {release}")
        mounted = _mounted(path)
        if mounted:
            out(f"note: kept the old release {release}: {mounted}")
            continue
        gone = path.with_name(f".{path.name}.exhibit-removing")
        try:
            os.rename(path, gone)
        except OSError as exc:
            out(f"note: kept the old release {release}: {exc.strerror or exc}")
            continue
        _remove(gone, release, out)


def _remove(path: Path, shown: str, out: Callable[[str], None]) -> None:
    why = _mounted(path)
    if not why:
        try:
            shutil.rmtree(path)
            return
        except OSError as exc:
            why = exc.strerror or str(exc)
    out(f"note: could not remove all of {shown} (now {path.name}): {why}; left there")


def _mounted(path: Path) -> str:
    """Why ``path`` must not be removed: it or a folder in it is a mount point (rmtree would
    empty the mounted file system), or ""."""
    if os.path.ismount(path):
        return "it is a mount point"
    try:
        device = os.lstat(path).st_dev
    except OSError as exc:
        return exc.strerror or str(exc)
    for folder, subfolders, _ in os.walk(path):
        for sub in subfolders:
            inner = os.path.join(folder, sub)
            try:
                if os.lstat(inner).st_dev != device or os.path.ismount(inner):
                    return f"{inner} in it is a mount point"
            except OSError:
                continue
    return ""
