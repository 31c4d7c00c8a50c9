"""Whether a vertex of a surface lies on a rim of its picture: where the surface turns away
from the eye (its silhouette, where the Lemma 3 outline is drawn over it). There the adjacent
triangles face the eye on one side and away on the other; inside what shows of a sheet they
all face one way. A tag's leader ends off the rims (exhibit.render.object_tags): on a rim the
outline's ink and the sheet behind share the pixel. Pure: numpy only."""

from __future__ import annotations

import numpy as np

from exhibit.geometry.pipeline import ClipTransform


def on_rim(
    positions: np.ndarray, triangles: np.ndarray, vertices: np.ndarray, ct: ClipTransform
) -> np.ndarray:
    """For each index in ``vertices`` (into ``positions``, a surface's (n, 4) points with
    ``triangles`` (k, 3)), whether its triangles do not all turn the same way on the screen
    of ``ct`` (or one of them is behind the eye)."""
    out = np.zeros(len(vertices), dtype=bool)
    for j, v in enumerate(np.asarray(vertices, dtype=int)):
        around = triangles[np.any(triangles == v, axis=1)]
        if not len(around):
            continue
        ndc, ok = ct.to_ndc(positions[around].reshape(-1, 4))
        p = ndc[..., :2].reshape(len(around), 3, 2)
        a, b, c = p[:, 0], p[:, 1], p[:, 2]
        area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        out[j] = not ok.all() or not (np.all(area > 0) or np.all(area < 0))
    return out
