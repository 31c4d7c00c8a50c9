"""Fixtures the kiosk-frame checks share."""

import os

import pytest


@pytest.fixture(scope="module")
def mesh_cache(tmp_path_factory):
    """One mesh cache for a test module (each scene built once, at its shipped resolution),
    not the user's: the kiosks the module builds find their meshes there."""
    folder = tmp_path_factory.mktemp("meshes")
    before = os.environ.get("EXHIBIT_CACHE_DIR")
    os.environ["EXHIBIT_CACHE_DIR"] = str(folder)
    yield folder
    if before is None:
        os.environ.pop("EXHIBIT_CACHE_DIR", None)
    else:
        os.environ["EXHIBIT_CACHE_DIR"] = before
