"""Checks on a triangle mesh: edges, boundary and non-manifold edges, components, Euler
characteristic. Used by `exhibit inspect` and the tests to prove a surface came out closed and
2-manifold."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TopologyReport:
    vertices: int  # vertices used by at least one triangle
    edges: int
    triangles: int
    components: int
    euler_characteristic: int
    boundary_edges: int  # edges with one triangle
    nonmanifold_edges: int  # edges with three or more triangles


def edge_counts(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges (E, 2) and how many triangles use each."""
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    edges.sort(axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique, counts


def connected_components(vertex_count: int, edges: np.ndarray) -> np.ndarray:
    """Component label per vertex (isolated vertices get their own), by union-find with path
    halving, vectorised as repeated pointer jumping."""
    parent = np.arange(vertex_count)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    if len(edges) == 0:
        return parent
    while True:
        a, b = parent[edges[:, 0]], parent[edges[:, 1]]
        low, high = np.minimum(a, b), np.maximum(a, b)
        changed = low != high
        if not changed.any():
            break
        np.minimum.at(parent, high[changed], low[changed])
        while True:  # pointer jumping until every vertex points at a root
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
    return parent


def analyse(triangles: np.ndarray, vertex_count: int | None = None) -> TopologyReport:
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(triangles) == 0:
        return TopologyReport(0, 0, 0, 0, 0, 0, 0)
    used = np.unique(triangles)
    count = int(vertex_count if vertex_count is not None else triangles.max() + 1)
    edges, counts = edge_counts(triangles)
    labels = connected_components(count, edges)
    components = len(np.unique(labels[used]))
    return TopologyReport(
        vertices=len(used),
        edges=len(edges),
        triangles=len(triangles),
        components=components,
        euler_characteristic=int(len(used) - len(edges) + len(triangles)),
        boundary_edges=int(np.sum(counts == 1)),
        nonmanifold_edges=int(np.sum(counts > 2)),
    )
