"""The geometry shader's Lemma 2 discs: one per point, wherever the point falls on the mesh
(the rule before claimed a point on a shared edge twice or not at all), as its CPU mirror
(exhibit/geometry/lemma2_marks.py) says."""

from __future__ import annotations

import numpy as np
import pytest

from exhibit.geometry import ViewState
from exhibit.render import RenderOptions
from exhibit.surfaces.mesh import Material, Mesh4D, Surface
from tests.geometry.planted_lemma2 import SHIFTS, planted

SIZE = (200, 200)
DISCS_ONLY = RenderOptions(
    surfaces=False,
    curves=False,
    hud=False,
    silhouettes=True,
    silhouette_width=0.0,
    pinch_size=12.0,
    line_scale=1.0,
    background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
)
VIEW = ViewState(angles=(0.0,) * 6, sensor_r=0.0, eye_r=0.0, half_height=1.2)


def blobs(mask: np.ndarray) -> int:
    """Connected components (4-neighbourhood) of a boolean image."""
    seen = np.zeros_like(mask)
    count = 0
    for start in zip(*np.nonzero(mask)):
        if seen[start]:
            continue
        count += 1
        stack = [start]
        seen[start] = True
        while stack:
            y, x = stack.pop()
            for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                ny, nx = y + dy, x + dx
                inside = 0 <= ny < mask.shape[0] and 0 <= nx < mask.shape[1]
                if inside and mask[ny, nx] and not seen[ny, nx]:
                    seen[ny, nx] = True
                    stack.append((ny, nx))
    return count


@pytest.mark.parametrize("shift", SHIFTS)
def test_one_disc_per_lemma_2_point(gl, shift):
    positions, normals, tris = planted(10, shift)
    mesh = Mesh4D([Surface("planted", positions, normals, tris, Material())])
    gpu = gl.renderer.upload(mesh)
    image = gl.image(gpu, VIEW, SIZE, DISCS_ONLY, samples=0).astype(int)
    gpu.release()
    yellow = (image[..., 0] > 200) & (image[..., 1] > 180) & (image[..., 2] < 120)
    assert blobs(yellow) == 1, shift
