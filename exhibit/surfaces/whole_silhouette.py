"""Components on which the silhouette function vanishes identically: the whole component is
silhouette.

Seen along two axes that every tangent plane meets (e.g. the offset pipes along x, y: ∇(v - u²)
has no x, y part, so s = (∇f1·e_x)(∇f2·e_y) - (∇f1·e_y)(∇f2·e_x) is 0 everywhere), each tangent
plane projects to a line and there is no curve to trace: sign changes find nothing. Reporting
"no silhouette" there would be wrong, so such components are found and named instead.
"""

from __future__ import annotations

import numpy as np

from exhibit.geometry.silhouette import silhouette_function_normalized
from exhibit.surfaces.mesh import Surface
from exhibit.surfaces.topology import connected_components, edge_counts

#: |s| / (|n1 ∧ n2| |e_a ∧ e_b|) at or below this at every regular vertex of a component (the
#: sine of the angle between the normal plane and the projection's kernel, so scale-free): the
#: whole component is silhouette. Round-off leaves about 1e-16 there; a true curve leaves O(1).
WHOLE_TOLERANCE = 1e-9


def component_labels(surface: Surface) -> np.ndarray:
    """Component index 0, 1, ... per vertex (vertices in no triangle get -1)."""
    labels = np.full(len(surface.positions), -1)
    if len(surface.triangles) == 0:
        return labels
    edges, _ = edge_counts(surface.triangles)
    roots = connected_components(len(surface.positions), edges)
    used = np.unique(np.asarray(surface.triangles, dtype=np.int64))
    _, index = np.unique(roots[used], return_inverse=True)
    labels[used] = index.reshape(-1)
    return labels


def whole_silhouette_components(surface: Surface, along: tuple[int, int]) -> list[dict]:
    """One entry per mesh component of ``surface``: {"name", "component", "whole_component",
    "largest_measure"}; whole where the normalized silhouette function is at most
    WHOLE_TOLERANCE at every regular vertex (at least three of them)."""
    labels = component_labels(surface)
    count = int(labels.max()) + 1 if len(labels) else 0
    e = np.eye(4)
    with np.errstate(all="ignore"):
        measure = np.abs(
            silhouette_function_normalized(
                surface.normals[:, 0], surface.normals[:, 1], e[along[0]], e[along[1]]
            )
        )
    regular = np.linalg.norm(surface.normals.reshape(len(labels), -1), axis=1) > 0
    if surface.singular is not None:
        regular &= ~np.asarray(surface.singular, dtype=bool)
    out = []
    for k in range(count):
        mine = (labels == k) & regular & np.isfinite(measure)
        largest = float(measure[mine].max()) if mine.any() else float("nan")
        name = surface.name if count == 1 else f"{surface.name} (component {k + 1})"
        out.append(
            {
                "name": name,
                "component": k + 1,
                "whole_component": bool(mine.sum() >= 3 and largest <= WHOLE_TOLERANCE),
                "largest_measure": largest if mine.any() else None,
            }
        )
    return out
