"""The render suite's fixtures: ``gl``, the session's headless EGL renderer (tests/conftest.py)
with ctx.error checked around every test, and small meshes for pixel checks."""

from __future__ import annotations

import numpy as np
import pytest

from exhibit.render import RenderOptions
from exhibit.surfaces.mesh import Marker, Material, Mesh4D, Surface
from tests.xvfb import unavailable  # noqa: F401 - the render tests import it from here

#: Plain pictures for pixel checks: flat black background, no HUD, no silhouettes.
PLAIN = RenderOptions(
    silhouettes=False, pinch_points=False, hud=False, background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
)


@pytest.fixture
def gl(headless):
    """The headless renderer, asserting no GL error before and after the test."""
    headless.activate()
    assert headless.ctx.error == "GL_NO_ERROR"
    yield headless
    assert headless.ctx.error == "GL_NO_ERROR"


def square(name, center, u, v, color, half=0.5, n=4) -> Surface:
    """A flat n x n grid square in 4D spanned by unit vectors u, v around center."""
    center, u, v = (np.asarray(a, dtype=float) for a in (center, u, v))
    s = np.linspace(-half, half, n + 1)
    S, T = np.meshgrid(s, s, indexing="ij")
    positions = center + S.reshape(-1, 1) * u + T.reshape(-1, 1) * v
    basis = np.linalg.svd(np.stack([u, v]))[2][2:]  # the two unit normals
    normals = np.broadcast_to(basis, (len(positions), 2, 4))
    tris = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = (
                i * (n + 1) + j,
                (i + 1) * (n + 1) + j,
                (i + 1) * (n + 1) + j + 1,
                i * (n + 1) + j + 1,
            )
            tris += [(a, b, c), (a, c, d)]
    return Surface(name, positions, normals, np.array(tris), Material(color=color))


def marker_mesh(point, color=(1.0, 0.0, 0.0)) -> Mesh4D:
    return Mesh4D(
        markers=[Marker("m", np.asarray(point, float), Material(color=color, line_width=2.0))]
    )
