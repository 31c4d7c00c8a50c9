"""The mesh cache: hits after the first build, misses on any change, survives corruption."""

import logging
from dataclasses import replace

import numpy as np

from exhibit import scenes
from exhibit.scenes.cache import build_cached


def test_second_build_is_a_hit_with_the_same_mesh(tmp_path):
    scene = scenes.get("collision")
    first, hit1 = build_cached(scene, {"rs": 0.7, "vc": 0.2}, 12, tmp_path)
    second, hit2 = build_cached(scene, {"rs": 0.7, "vc": 0.2}, 12, tmp_path)
    assert (hit1, hit2) == (False, True)
    np.testing.assert_array_equal(first.surfaces[0].positions, second.surfaces[0].positions)
    assert second.markers[0].label == first.markers[0].label
    assert second.surfaces[0].info["kind"] == "implicit"


def test_parameters_resolution_and_version_change_the_key(tmp_path):
    scene = scenes.get("hopf")
    build_cached(scene, None, 8, tmp_path)
    assert not build_cached(scene, {"axis_length": 2}, 8, tmp_path)[1]
    assert not build_cached(scene, None, 9, tmp_path)[1]

    assert not build_cached(replace(scene, version="edited"), None, 8, tmp_path)[1]
    assert build_cached(scene, None, 8, tmp_path)[1]


def test_corrupt_cache_file_is_rebuilt(tmp_path):
    scene = scenes.get("hopf")
    build_cached(scene, None, 8, tmp_path)
    (path,) = tmp_path.glob("hopf-*.npz")
    path.write_bytes(b"not a mesh")
    mesh, hit = build_cached(scene, None, 8, tmp_path)
    assert not hit and len(mesh.surfaces) == 3
    assert build_cached(scene, None, 8, tmp_path)[1]


def test_unwritable_cache_only_costs_the_rebuild(tmp_path, caplog):
    """...and says so once, naming the entry it could not write."""
    blocked = tmp_path / "file"
    blocked.write_text("in the way")
    caplog.set_level(logging.WARNING)
    mesh, hit = build_cached(scenes.get("hopf"), None, 8, blocked / "meshes")
    assert not hit and len(mesh.surfaces) == 3
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "could not write the mesh cache" in warnings[0].getMessage()
    assert str(blocked / "meshes" / "hopf-") in warnings[0].getMessage()
