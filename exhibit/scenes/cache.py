"""On-disk cache of built meshes, so the kiosk starts without re-meshing.

A mesh is stored under a key made of the scene's name, its resolved parameters, the resolution,
the scene's own version (e.g. the hash of its TOML file) and the code version (a hash of the
geometry, surfaces and scenes sources), so any change that could change the mesh misses the cache.
Nothing in the cache is trusted: the kiosk runs for months, and one bad file (a power cut mid-
write, a full disk, a stray symlink or FIFO, tampering) must cost a rebuild, never a crash loop.
An entry is read only if it is a regular file (never through a symlink, never a FIFO or device)
of at most MAX_CACHE_BYTES, and used only if Mesh4D.from_bytes accepts every part of it; any
failure at all logs a warning and rebuilds, and the rebuilt mesh replaces the entry. Writes go to
a fresh, exclusively created temporary file in the cache folder (fsynced, then renamed over the
entry), so a reader sees the old file or the new one, and no temporary file is left behind.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import stat
import time
from pathlib import Path
from collections.abc import Mapping

from exhibit import __version__
from exhibit.scenes.base import Scene
from exhibit.schema import files
from exhibit.surfaces.mesh import Mesh4D

log = logging.getLogger(__name__)
_PACKAGE = Path(__file__).resolve().parent.parent
#: Largest cache file read or written (256 MiB); a default-resolution mesh is 0.1 to 2 MB.
MAX_CACHE_BYTES = 256 << 20
#: Temporary files older than this (seconds) are debris of a killed writer and are removed.
STALE_TMP_S = 3600.0


def cache_dir() -> Path:
    """$EXHIBIT_CACHE_DIR, else $XDG_CACHE_HOME/exhibit/meshes, else ~/.cache/exhibit/meshes."""
    if os.environ.get("EXHIBIT_CACHE_DIR"):
        return Path(os.environ["EXHIBIT_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "exhibit" / "meshes"


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    digest = hashlib.sha256(__version__.encode())
    for folder in ("geometry", "surfaces", "scenes"):
        for path in sorted((_PACKAGE / folder).glob("*.py")):
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def cache_key(scene: Scene, params: Mapping[str, float], resolution: int) -> str:
    description = json.dumps(
        {
            "scene": scene.name,
            "params": dict(sorted(params.items())),
            "resolution": resolution,
            "scene_version": scene.version,
            "code": code_version(),
        },
        sort_keys=True,
    )
    return hashlib.sha256(description.encode()).hexdigest()[:24]


def entry_path(
    scene: Scene,
    overrides: Mapping[str, object] | None = None,
    resolution: int | None = None,
    directory: Path | None = None,
) -> Path:
    """Where the cache keeps the scene's mesh with these parameters at ``resolution``."""
    params = scene.resolve(overrides)
    resolution = int(resolution or scene.default_resolution)
    folder = Path(directory) if directory else cache_dir()
    return folder / f"{scene.name}-{cache_key(scene, params, resolution)}.npz"


def entry_problem(path: Path) -> str | None:
    """Why the cache holds no usable entry at ``path`` (`exhibit prepare` checks what it
    stored: a cache folder that is a file, a link to a device, read-only or full stores
    nothing, and build_cached only warns), or None when a regular, non-empty file is there."""
    try:
        info = os.lstat(path)
    except OSError as exc:
        why = files.check_file_ref(path.parent, want_dir=True)
        if why is not None:
            return f"mesh cache {why}"
        return (
            f"nothing stored in the mesh cache {path.parent} "
            f"({exc.strerror or exc}: is it read-only or full?)"
        )
    if not stat.S_ISREG(info.st_mode) or info.st_size == 0:
        return f"the mesh cache entry {path} is not a complete file"
    return None


def build_cached(
    scene: Scene,
    overrides: Mapping[str, object] | None = None,
    resolution: int | None = None,
    directory: Path | None = None,
) -> tuple[Mesh4D, bool]:
    """The scene's mesh from the cache if present and valid, else built and stored.

    Returns (mesh, hit). A bad entry or a cache that cannot be written (read-only disk) only
    costs the rebuild and a warning.
    """
    params = scene.resolve(overrides)
    resolution = int(resolution or scene.default_resolution)
    path = entry_path(scene, params, resolution, directory)
    folder = path.parent
    try:
        data = files.read_regular(path, MAX_CACHE_BYTES, follow=False)
        return Mesh4D.from_bytes(data), True
    except (FileNotFoundError, NotADirectoryError):
        pass  # no entry (or no cache folder: a file in its way), nothing to warn about yet
    except Exception as exc:  # noqa: BLE001 - no cache file is worth a crash
        log.warning("mesh cache %s is unusable (%s); rebuilding", path, exc)
    mesh = scene.build(params, resolution)
    try:
        store(folder, path, mesh.to_bytes())
    except Exception as exc:  # noqa: BLE001 - the cache is an optimisation
        log.warning("could not write the mesh cache %s: %s", path, exc)
    return mesh, False


def store(folder: Path, path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (exhibit.schema.files.write_atomic, fsynced: the
    rename must not reach the disk before the data), healing whatever is there: a symlink, FIFO
    or bad file in the entry's place is replaced, never followed. Leftovers of writers killed
    mid-write go first."""
    if len(data) > MAX_CACHE_BYTES:
        raise ValueError(f"{len(data)} bytes, more than the {MAX_CACHE_BYTES} a read accepts")
    folder.mkdir(parents=True, exist_ok=True)
    _sweep(folder)
    files.write_atomic(path, data, mode=0o644, heal=True)


def _sweep(folder: Path) -> None:
    """Remove temporary files a writer killed mid-write (power cut, OOM) left over an hour ago."""
    cutoff = time.time() - STALE_TMP_S
    with os.scandir(folder) as entries:
        for entry in entries:
            try:
                if (
                    entry.name.endswith(".tmp")
                    and not entry.is_dir(follow_symlinks=False)
                    and entry.stat(follow_symlinks=False).st_mtime < cutoff
                ):
                    os.unlink(entry.path)
            except OSError:
                pass  # gone already, or not ours to remove
