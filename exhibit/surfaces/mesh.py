"""Mesh4D: the polygonized scene in R^4 — built once, cached on disk, uploaded to the GPU once.

A mesh has parts of three kinds, each with its material:

* ``Surface``: triangles with per-vertex 4D positions and two unit 4D normals spanning the normal
  plane (parametric tangents are converted with ⊗ when the part is made, so the renderer has one
  path: Lemma 1(c)); vertices at singular points (dependent normals) are flagged.
* ``Curve``: a 4D polyline (fibres, axes, silhouette curves, wire meshes) with unit tangents.
* ``Marker``: a labelled 4D point (e.g. the initial colliding point).
"""

from __future__ import annotations

import io
import json
import zipfile
from dataclasses import dataclass, field

import numpy as np

from exhibit.geometry.normals import complement_plane

STYLES = ("solid", "wire")


@dataclass(frozen=True)
class Material:
    """How a part looks: RGB colour in [0, 1], solid or wire, and line width in pixels."""

    color: tuple[float, float, float] = (0.7, 0.7, 0.7)
    style: str = "solid"
    line_width: float = 2.0

    def __post_init__(self) -> None:
        color = tuple(float(c) for c in self.color)
        if len(color) != 3 or not all(0.0 <= c <= 1.0 for c in color):
            raise ValueError(f"colour must be three numbers in [0, 1], got {self.color!r}")
        if self.style not in STYLES:
            raise ValueError(f"style must be one of {STYLES}, got {self.style!r}")
        if not self.line_width > 0:
            raise ValueError(f"line width must be positive, got {self.line_width}")
        object.__setattr__(self, "color", color)
        object.__setattr__(self, "line_width", float(self.line_width))

    def to_json(self) -> dict:
        return {"color": list(self.color), "style": self.style, "line_width": self.line_width}


@dataclass
class Surface:
    name: str
    positions: np.ndarray  # (V, 4) float64
    normals: np.ndarray  # (V, 2, 4) float64, orthonormal pairs (zero at singular points)
    triangles: np.ndarray  # (T, 3) int32
    material: Material = field(default_factory=Material)
    singular: np.ndarray | None = None  # (V,) bool
    #: How the part was made (kind, max_residual, singular_points, seconds, ...), for `inspect`.
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.positions = np.ascontiguousarray(self.positions, dtype=np.float64).reshape(-1, 4)
        self.normals = np.ascontiguousarray(self.normals, dtype=np.float64).reshape(-1, 2, 4)
        self.triangles = np.ascontiguousarray(self.triangles, dtype=np.int32).reshape(-1, 3)
        if self.normals.shape[0] != self.positions.shape[0]:
            raise ValueError(f"{self.name}: {len(self.normals)} normal pairs for "
                             f"{len(self.positions)} vertices")
        if len(self.triangles) and (self.triangles.min() < 0
                                    or self.triangles.max() >= len(self.positions)):
            raise ValueError(f"{self.name}: triangle index out of range")
        if self.singular is None:
            self.singular = ~np.any(self.normals[:, 0] != 0, axis=1)
        self.singular = np.asarray(self.singular, dtype=bool).reshape(-1)

    @classmethod
    def from_normals(cls, name, positions, n1, n2, triangles, material=None) -> "Surface":
        """From two normals per vertex (e.g. ∇f1, ∇f2); they are orthonormalised here."""
        t1, t2 = complement_plane(n1, n2)
        m1, m2 = complement_plane(t1, t2)
        return cls(name, positions, np.stack([m1, m2], axis=1), triangles,
                   material or Material())

    @classmethod
    def from_tangents(cls, name, positions, t1, t2, triangles, material=None) -> "Surface":
        """From two tangents per vertex (parametric ∂/∂s, ∂/∂t), turned into normals with ⊗."""
        m1, m2 = complement_plane(t1, t2)
        return cls(name, positions, np.stack([m1, m2], axis=1), triangles,
                   material or Material())


@dataclass
class Curve:
    name: str
    points: np.ndarray  # (K, 4)
    material: Material = field(default_factory=Material)
    closed: bool = False

    def __post_init__(self) -> None:
        self.points = np.ascontiguousarray(self.points, dtype=np.float64).reshape(-1, 4)
        self.closed = bool(self.closed)

    @property
    def tangents(self) -> np.ndarray:
        """Unit tangents by central differences along the polyline (one-sided at open ends)."""
        p = self.points
        if len(p) < 2:
            return np.zeros_like(p)
        if self.closed:
            d = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
        else:
            d = np.gradient(p, axis=0)
        length = np.linalg.norm(d, axis=1, keepdims=True)
        return np.where(length > 0, d / np.where(length > 0, length, 1.0), 0.0)

    def segments(self) -> np.ndarray:
        """(S, 2, 4) line segments, including the closing one for a closed curve."""
        p = self.points
        if len(p) < 2:
            return np.zeros((0, 2, 4))
        ends = np.roll(p, -1, axis=0) if self.closed else p[1:]
        starts = p if self.closed else p[:-1]
        return np.stack([starts, ends], axis=1)


@dataclass
class Marker:
    name: str
    position: np.ndarray  # (4,)
    material: Material = field(default_factory=lambda: Material(color=(1.0, 1.0, 0.2)))
    label: str = ""

    def __post_init__(self) -> None:
        self.position = np.asarray(self.position, dtype=np.float64).reshape(4)


@dataclass
class Mesh4D:
    surfaces: list[Surface] = field(default_factory=list)
    curves: list[Curve] = field(default_factory=list)
    markers: list[Marker] = field(default_factory=list)

    @property
    def triangle_count(self) -> int:
        return sum(len(s.triangles) for s in self.surfaces)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Component-wise min and max over every point of every part."""
        arrays = ([s.positions for s in self.surfaces] + [c.points for c in self.curves]
                  + [m.position[None] for m in self.markers])
        arrays = [a for a in arrays if len(a)]
        if not arrays:
            return np.zeros(4), np.zeros(4)
        stacked = np.concatenate(arrays)
        return stacked.min(axis=0), stacked.max(axis=0)

    # ------------------------------------------------------------------ persistence (npz)

    def to_bytes(self) -> bytes:
        """Serialise to an .npz archive (arrays) with a JSON manifest (names, materials)."""
        arrays: dict[str, np.ndarray] = {}
        manifest = {"format": 1, "surfaces": [], "curves": [], "markers": []}
        for i, s in enumerate(self.surfaces):
            arrays[f"s{i}_positions"] = s.positions
            arrays[f"s{i}_normals"] = s.normals
            arrays[f"s{i}_triangles"] = s.triangles
            arrays[f"s{i}_singular"] = s.singular
            manifest["surfaces"].append({"name": s.name, "material": s.material.to_json(),
                                         "info": s.info})
        for i, c in enumerate(self.curves):
            arrays[f"c{i}_points"] = c.points
            manifest["curves"].append({"name": c.name, "material": c.material.to_json(),
                                       "closed": c.closed})
        for i, m in enumerate(self.markers):
            arrays[f"m{i}_position"] = m.position
            manifest["markers"].append({"name": m.name, "material": m.material.to_json(),
                                        "label": m.label})
        arrays["manifest"] = np.frombuffer(json.dumps(manifest).encode(), dtype=np.uint8)
        buffer = io.BytesIO()
        np.savez_compressed(buffer, **arrays)
        return buffer.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> "Mesh4D":
        """Inverse of to_bytes; raises ValueError for anything that is not such an archive."""
        try:
            with np.load(io.BytesIO(data), allow_pickle=False) as archive:
                manifest = json.loads(bytes(archive["manifest"]).decode())
                if manifest.get("format") != 1:
                    raise ValueError(f"unknown mesh format {manifest.get('format')!r}")
                mesh = cls()
                for i, s in enumerate(manifest["surfaces"]):
                    mesh.surfaces.append(Surface(
                        s["name"], archive[f"s{i}_positions"], archive[f"s{i}_normals"],
                        archive[f"s{i}_triangles"], Material(**s["material"]),
                        archive[f"s{i}_singular"], dict(s.get("info", {}))))
                for i, c in enumerate(manifest["curves"]):
                    mesh.curves.append(Curve(c["name"], archive[f"c{i}_points"],
                                             Material(**c["material"]), c["closed"]))
                for i, m in enumerate(manifest["markers"]):
                    mesh.markers.append(Marker(m["name"], archive[f"m{i}_position"],
                                               Material(**m["material"]), m["label"]))
                return mesh
        except (OSError, KeyError, TypeError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            raise ValueError(f"not a mesh archive: {exc}") from None
