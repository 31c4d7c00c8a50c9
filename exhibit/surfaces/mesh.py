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
import math
import zipfile
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from exhibit.geometry.normals import complement_plane, orthonormal_normals

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
    #: The exact surface behind the mesh when it was just built (the implicit part with its f1,
    #: f2, or the parametrisation), for exact silhouettes; never stored in the cache.
    exact: object = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.positions = np.ascontiguousarray(self.positions, dtype=np.float64).reshape(-1, 4)
        self.normals = np.ascontiguousarray(self.normals, dtype=np.float64).reshape(-1, 2, 4)
        self.triangles = np.ascontiguousarray(self.triangles, dtype=np.int32).reshape(-1, 3)
        if self.normals.shape[0] != self.positions.shape[0]:
            raise ValueError(
                f"{self.name}: {len(self.normals)} normal pairs for {len(self.positions)} vertices"
            )
        if len(self.triangles) and (
            self.triangles.min() < 0 or self.triangles.max() >= len(self.positions)
        ):
            raise ValueError(f"{self.name}: triangle index out of range")
        if self.singular is None:
            self.singular = ~np.any(self.normals[:, 0] != 0, axis=1)
        self.singular = np.asarray(self.singular, dtype=bool).reshape(-1)

    @classmethod
    def from_normals(
        cls,
        name: str,
        positions: np.ndarray,
        n1: ArrayLike,
        n2: ArrayLike,
        triangles: np.ndarray,
        material: Material | None = None,
    ) -> Surface:
        """From two normals per vertex (e.g. ∇f1, ∇f2); they are orthonormalised here."""
        normals = orthonormal_normals(n1, n2)
        return cls(name, positions, normals, triangles, material or Material())

    @classmethod
    def from_tangents(
        cls,
        name: str,
        positions: np.ndarray,
        t1: ArrayLike,
        t2: ArrayLike,
        triangles: np.ndarray,
        material: Material | None = None,
    ) -> Surface:
        """From two tangents per vertex (parametric ∂/∂s, ∂/∂t), turned into normals with ⊗."""
        m1, m2 = complement_plane(t1, t2)
        return cls(name, positions, np.stack([m1, m2], axis=1), triangles, material or Material())


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

    def polyline(self) -> np.ndarray:
        """The points as an open polyline: a closed curve ends where it starts (for export)."""
        return np.vstack([self.points, self.points[:1]]) if self.closed else self.points

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
        arrays = (
            [s.positions for s in self.surfaces]
            + [c.points for c in self.curves]
            + [m.position[None] for m in self.markers]
        )
        arrays = [a for a in arrays if len(a)]
        if not arrays:
            return np.zeros(4), np.zeros(4)
        stacked = np.concatenate(arrays)
        return stacked.min(axis=0), stacked.max(axis=0)

    # ------------------------------------------------------------------ persistence (npz)

    def to_bytes(self) -> bytes:
        """Serialise to an .npz archive (arrays) with a JSON manifest (names, materials)."""
        arrays: dict[str, np.ndarray] = {}
        surfaces: list[dict] = []
        curves: list[dict] = []
        markers: list[dict] = []
        manifest = {"format": 1, "surfaces": surfaces, "curves": curves, "markers": markers}
        for i, s in enumerate(self.surfaces):
            arrays[f"s{i}_positions"] = s.positions
            arrays[f"s{i}_normals"] = s.normals
            arrays[f"s{i}_triangles"] = s.triangles
            assert s.singular is not None  # __post_init__ sets it
            arrays[f"s{i}_singular"] = s.singular
            surfaces.append({"name": s.name, "material": s.material.to_json(), "info": s.info})
        for i, c in enumerate(self.curves):
            arrays[f"c{i}_points"] = c.points
            curves.append({"name": c.name, "material": c.material.to_json(), "closed": c.closed})
        for i, m in enumerate(self.markers):
            arrays[f"m{i}_position"] = m.position
            markers.append({"name": m.name, "material": m.material.to_json(), "label": m.label})
        arrays["manifest"] = np.frombuffer(json.dumps(manifest).encode(), dtype=np.uint8)
        buffer = io.BytesIO()
        np.savez_compressed(buffer, **arrays)  # type: ignore[arg-type]  # numpy's stub types
        # its keyword arrays as allow_pickle
        return buffer.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> Mesh4D:
        """Inverse of to_bytes; ValueError for anything that is not exactly such an archive.

        The bytes come from a disk the kiosk does not control (a cache file), so nothing in them
        is trusted: any failure at all, however exotic, is reported as ValueError, and a mesh is
        only returned once every part has the shapes, types and finite, bounded values the
        renderer assumes (a NaN or 1e308 vertex would otherwise reach the GPU).
        """
        try:
            manifest, arrays = _read_archive(data)
            mesh = cls()
            for i, s in enumerate(manifest["surfaces"]):
                positions = _array(arrays, f"s{i}_positions", "<f8", None, 4)
                n = len(positions)
                triangles = _array(arrays, f"s{i}_triangles", "<i4", None, 3)
                if triangles.size and (triangles.min() < 0 or triangles.max() >= n):
                    raise ValueError(f"s{i}_triangles: index outside 0..{n - 1}")
                mesh.surfaces.append(
                    Surface(
                        s["name"],
                        positions,
                        _array(arrays, f"s{i}_normals", "<f8", n, 2, 4),
                        triangles,
                        _material(s["material"]),
                        _array(arrays, f"s{i}_singular", "|b1", n),
                        s["info"],
                    )
                )
            for i, c in enumerate(manifest["curves"]):
                mesh.curves.append(
                    Curve(
                        c["name"],
                        _array(arrays, f"c{i}_points", "<f8", None, 4),
                        _material(c["material"]),
                        c["closed"],
                    )
                )
            for i, m in enumerate(manifest["markers"]):
                mesh.markers.append(
                    Marker(
                        m["name"],
                        _array(arrays, f"m{i}_position", "<f8", 4),
                        _material(m["material"]),
                        m["label"],
                    )
                )
            return mesh
        except Exception as exc:  # noqa: BLE001 - whatever the bytes provoke means "not a mesh"
            raise ValueError(f"not a mesh archive: {str(exc) or type(exc).__name__}") from None


# ---------------------------------------------------------------------- reading untrusted archives

#: Most bytes the members of one archive may unpack to, checked from the zip directory before
#: anything is inflated (a zip bomb is refused unread). A 512-resolution implicit scene is a few
#: hundred MB; a larger mesh is simply rebuilt instead of loaded.
MAX_UNPACKED_BYTES = 1 << 30
#: Largest |coordinate| accepted: the scenes live within a few units of the origin.
MAX_COORDINATE = 1e6
#: Largest zip central directory (about 10,000 members): zipfile builds an object per entry
#: before anything can be checked, so millions of tiny entries would exhaust memory.
_MAX_DIRECTORY_BYTES = 1 << 20
_PARTS = {
    "surfaces": ("positions", "normals", "triangles", "singular"),
    "curves": ("points",),
    "markers": ("position",),
}
#: key -> type of each part's manifest entry, besides "name" (str) and "material" (dict).
_PART_FIELDS = {"surfaces": ("info", dict), "curves": ("closed", bool), "markers": ("label", str)}


def _read_archive(data: bytes) -> tuple[dict, dict[str, np.ndarray]]:
    """The checked manifest and every array of an archive, by name without ".npy"."""
    _check_directory(data)
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        infos = archive.infolist()
        unpacked = sum(info.file_size for info in infos)
        if unpacked > MAX_UNPACKED_BYTES:
            raise ValueError(
                f"members unpack to {unpacked} bytes, more than the {MAX_UNPACKED_BYTES} allowed"
            )
        arrays = {}
        for info in infos:
            # bz2/lzma inflate without an output bound (one 4 KB read can become gigabytes)
            if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
                raise ValueError(f"{info.filename}: compression method {info.compress_type}")
            name = info.filename.removesuffix(".npy")
            if name == info.filename or name in arrays:
                raise ValueError(f"unexpected member {info.filename!r}")
            arrays[name] = _read_npy(archive, info)
    manifest = _manifest(_array(arrays, "manifest", "|u1", None))
    expected = {"manifest"} | {
        f"{kind[0]}{i}_{array}"
        for kind, names in _PARTS.items()
        for i in range(len(manifest[kind]))
        for array in names
    }
    if set(arrays) != expected:
        raise ValueError(f"members {sorted(set(arrays) ^ expected)} do not match the manifest")
    return manifest, arrays


def _check_directory(data: bytes) -> None:
    """Refuse an archive whose central directory is too big to parse, before zipfile does."""
    end = data.rfind(b"PK\x05\x06", max(0, len(data) - 22 - 0xFFFF))
    if end < 0 or len(data) < end + 22:
        raise ValueError("no zip directory")
    if end >= 20 and data[end - 20 : end - 16] == b"PK\x06\x07":
        raise ValueError("zip64 directory")  # numpy writes none below 65,535 members and 4 GB
    if int.from_bytes(data[end + 12 : end + 16], "little") > _MAX_DIRECTORY_BYTES:
        raise ValueError("zip directory too large")


def _read_npy(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.ndarray:
    """One .npy member, its declared size checked against the member's before reading.

    np.load would allocate whatever shape the header claims; here the array must fill the member
    exactly, and zipfile stops inflating at the member's (capped) declared size.
    """
    with archive.open(info) as fp:
        version = np.lib.format.read_magic(fp)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fp)
        elif version == (2, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fp)
        else:
            raise ValueError(f"{info.filename}: .npy version {version}")
        if fortran or dtype.hasobject or any(n < 0 for n in shape):
            raise ValueError(f"{info.filename}: Fortran order, objects or a negative shape")
        size = math.prod(shape) * dtype.itemsize
        if size > info.file_size:
            raise ValueError(f"{info.filename}: array of {size} bytes in a smaller member")
        raw = bytearray(fp.read(size))
        if len(raw) != size or fp.read(1):
            raise ValueError(f"{info.filename}: member size does not match its array")
    return np.frombuffer(raw, dtype=dtype).reshape(shape)


def _array(arrays: dict, key: str, dtype: str, *shape: int | None) -> np.ndarray:
    """arrays[key], checked for dtype, shape (None: any length) and finite, bounded floats."""
    a = arrays[key]
    if (
        a.dtype != np.dtype(dtype)
        or a.ndim != len(shape)
        or any(want not in (None, got) for want, got in zip(shape, a.shape))
    ):
        raise ValueError(f"{key}: expected {dtype} of shape {shape}, got {a.dtype} {a.shape}")
    if a.dtype.kind == "f" and not np.all(np.abs(a) <= MAX_COORDINATE):  # NaN fails too
        raise ValueError(f"{key}: values not finite or beyond ±{MAX_COORDINATE:g}")
    return a


def _manifest(raw: np.ndarray) -> dict:
    """The JSON manifest, checked for the structure to_bytes writes."""
    manifest = json.loads(raw.tobytes().decode("utf-8"))
    if not isinstance(manifest, dict) or manifest.get("format") != 1:
        raise ValueError("manifest is not a format-1 object")
    for kind, (key, kind_type) in _PART_FIELDS.items():
        parts = manifest.get(kind)
        if not isinstance(parts, list):
            raise ValueError(f"manifest {kind!r}: not a list")
        for part in parts:
            if not (
                isinstance(part, dict)
                and isinstance(part.get("name"), str)
                and isinstance(part.get("material"), dict)
                and isinstance(part.get(key), kind_type)
            ):
                raise ValueError(f"manifest {kind!r}: malformed entry")
    return manifest


def _material(d: dict) -> Material:
    """A Material from its JSON, numbers checked to be finite and in range."""
    color, width = d.get("color"), d.get("line_width")
    numbers = (color if isinstance(color, list) else []) + [width]
    if (
        set(d) != {"color", "style", "line_width"}
        or not isinstance(color, list)
        or not isinstance(width, (int, float))
        or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and abs(x) <= MAX_COORDINATE
            for x in numbers
        )
    ):
        raise ValueError(f"malformed material {d!r:.80}")
    return Material(tuple(color), d["style"], float(width))
