"""On-disk cache of built meshes, so the kiosk starts without re-meshing.

A mesh is stored under a key made of the scene's name, its resolved parameters, the resolution,
the scene's own version (e.g. the hash of its TOML file) and the code version (a hash of the
geometry, surfaces and scenes sources), so any change that could change the mesh misses the cache.
Files are written atomically; an unreadable file is rebuilt, never trusted.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import tempfile
from pathlib import Path
from typing import Mapping

from exhibit import __version__
from exhibit.scenes.base import Scene
from exhibit.surfaces.mesh import Mesh4D

log = logging.getLogger(__name__)
_PACKAGE = Path(__file__).resolve().parent.parent


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
    description = json.dumps({"scene": scene.name, "params": dict(sorted(params.items())),
                              "resolution": resolution, "scene_version": scene.version,
                              "code": code_version()}, sort_keys=True)
    return hashlib.sha256(description.encode()).hexdigest()[:24]


def build_cached(scene: Scene, overrides: Mapping[str, object] | None = None,
                 resolution: int | None = None, directory: Path | None = None
                 ) -> tuple[Mesh4D, bool]:
    """The scene's mesh from the cache if present and readable, else built and stored.

    Returns (mesh, hit). A cache that cannot be written (read-only disk) only costs the rebuild.
    """
    params = scene.resolve(overrides)
    resolution = int(resolution or scene.default_resolution)
    folder = Path(directory) if directory else cache_dir()
    path = folder / f"{scene.name}-{cache_key(scene, params, resolution)}.npz"
    if path.exists():
        try:
            return Mesh4D.from_bytes(path.read_bytes()), True
        except (OSError, ValueError) as exc:
            log.warning("mesh cache %s is unreadable (%s); rebuilding", path, exc)
    mesh = scene.build(params, resolution)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, delete=False, suffix=".tmp") as tmp:
            tmp.write(mesh.to_bytes())
        os.replace(tmp.name, path)
    except OSError as exc:
        log.warning("could not write the mesh cache %s: %s", path, exc)
    return mesh, False
