"""Helpers shared by the sag and vertex-distance tests: the cusp's pipe meshed as the scene
meshes it, and its sag as `inspect` measures it (a test module imports no other test module)."""

import math

from exhibit.scenes.implicit_scene import mesh_implicit
from exhibit.scenes.offsets import PIPE, XYUV, _box
from exhibit.surfaces import implicit
from exhibit.surfaces.metrics import surface_sag
from exhibit.surfaces.mesh import Material

V = ("x", "y", "z", "w")


def cusp_pipe(resolution, monkeypatch=None, follow=True):
    if not follow:
        assert monkeypatch is not None
        monkeypatch.setattr(implicit, "SAG_TOLERANCE", math.inf)  # the mesh as it was
    lo, hi = _box((-0.05, 1.45), (-1.75, 1.75), 1.0)
    return mesh_implicit(
        "pipe of y² = x³", PIPE, "v^2 - u^3", XYUV, {"r": 1.0}, lo, hi, resolution, Material()
    )


def sag_of(part):
    s = part.surface
    return surface_sag(
        (part.f1, part.f2),
        s.positions,
        s.triangles,
        s.info["cell_size"],
        part.result.singular_positions,
    )
