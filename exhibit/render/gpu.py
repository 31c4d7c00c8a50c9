"""A Mesh4D on the GPU: vertex buffers written once, so a frame only changes uniforms.

Surfaces go up as interleaved float32 (position, n1, n2: 48 bytes a vertex) with an index
buffer; curves, wire meshes and markers go up as one instance buffer of segments (p0, p1, style),
each drawn as a screen-space quad. Nothing here depends on the view.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import moderngl
import numpy as np

from exhibit.geometry.lemma2_marks import marking_vertices
from exhibit.geometry.touching import critical_values, near_critical
from exhibit.surfaces.mesh import Curve, Mesh4D, Surface
from exhibit.surfaces.metrics import unique_edges

if TYPE_CHECKING:
    from exhibit.geometry.view import ViewState

#: NDC depth by which curves are pulled towards the viewer (surfaces are also pushed back by a
#: slope-scaled polygon offset), so a curve lying on a surface is not half-buried in it.
LINE_BIAS = 2e-4
#: Texture units of the curves' surface depth (single-sampled, multisampled): apart, since
#: samplers of two types may not share a unit.
CENTRE_UNITS = (5, 6)
#: The slice curve drawn live, 4 px wide at 720 px (a little wider than the curve in the
#: inset: it lies on a shaded surface).
SLICE_WIDTH = 4.0
#: Markers are discs this many times their material's line width across (at least MARKER_MIN px).
MARKER_SCALE = 3.5
MARKER_MIN = 7.0
MARKER_OUTLINE = (0.05, 0.05, 0.07)


#: The per-vertex attributes of a surface, as uploaded: name, float count.
SURFACE_ATTRIBUTES = (("in_pos", 4), ("in_n1", 4), ("in_n2", 4), ("in_mark", 1))


def surface_vertices(surface: Surface) -> np.ndarray:
    """(V, 13) float32: position, n1, n2 — the per-vertex data of the Lemma 1(c) pipeline —
    and 1 where the vertex may mark Lemma 2 points (not next to a singular point, 0 there:
    exhibit/geometry/lemma2_marks.py)."""
    mark = marking_vertices(surface.positions, surface.normals, surface.triangles)
    return np.ascontiguousarray(
        np.concatenate(
            [surface.positions, surface.normals[:, 0], surface.normals[:, 1], mark[:, None]],
            axis=1,
        ),
        dtype=np.float32,
    )


#: Depth layers of curves (curves.glsl's LAYER_STEP): the mesh's first wire meshes and curves
#: lie a hair in front of its later ones, where they coincide on screen; the rest share the last.
LAYERS = 20
CURVE_ATTRIBUTES = ("in_p0", "in_p1", "in_style", "in_layer")


def segment_rows(
    starts: np.ndarray,
    ends: np.ndarray,
    color: tuple[float, float, float],
    width: float,
    layer: int = 0,
) -> np.ndarray:
    """One instance row per segment: p0 (4), p1 (4), rgb and width, depth layer."""
    n = len(starts)
    style = np.tile(np.array([*color, width, min(layer, LAYERS - 1)], dtype=np.float64), (n, 1))
    return np.concatenate([starts, ends, style], axis=1)


#: Vertices in GpuMesh.sample.
SURFACE_SAMPLE = 256


def surface_sample(gpu: GpuMesh) -> np.ndarray:
    """About SURFACE_SAMPLE of the surfaces' vertices (a zero point for a mesh without any),
    taken once and kept on the mesh."""
    if gpu.sample is None:
        points = [s.positions for s in gpu.mesh.surfaces if len(s.positions)]
        sample = np.concatenate(points) if points else np.zeros((1, 4))
        gpu.sample = sample[:: max(1, len(sample) // SURFACE_SAMPLE)]
    return gpu.sample


def mesh_sag(surface: Surface) -> float:
    """How far the surface's triangles may lie from the true surface: the largest edge length
    times the turn of the normal plane along the edge, over 8 (a chord of length l on a circle
    of radius R sags l²/8R = l·θ/8, θ = l/R the turn of its normal). Curves lie on the true
    surface (they are refined onto it), the triangles only within this of it: near a fold of
    the 3D image, where the sheet is seen edge-on, that is the difference between a curve on
    the outline and a curve behind it (centre_test.glsl). Edges at a singular vertex (zero
    normals) are left out."""
    edges = unique_edges(surface.triangles)
    if not len(edges):
        return 0.0
    n = surface.normals
    a, b = n[edges[:, 0]], n[edges[:, 1]]
    # The normal planes' projectors; their difference is sin of the largest principal angle.
    pa = np.einsum("eki,ekj->eij", a, a)
    pb = np.einsum("eki,ekj->eij", b, b)
    regular = (np.abs(np.einsum("eii->e", pa) - 2) < 1e-3) & (
        np.abs(np.einsum("eii->e", pb) - 2) < 1e-3
    )
    if not regular.any():
        return 0.0
    sine = np.linalg.norm(pa - pb, axis=(1, 2))[regular] / np.sqrt(2.0)
    p = surface.positions
    length = np.linalg.norm(p[edges[regular, 0]] - p[edges[regular, 1]], axis=1)
    return float((length * np.arcsin(np.clip(sine, 0.0, 1.0))).max() / 8.0)


def silhouette_key(surface: GpuSurface, view: ViewState, slice_width: float) -> str:
    """The silhouette program a surface is drawn with: with the slice's tangency test only
    when a slice is drawn near one of the surface's critical values (geometry/touching.py)."""
    if (
        slice_width
        and view.slice_axis is not None
        and near_critical(surface.critical[view.slice_axis], view.slice_at, surface.longest_edge)
    ):
        return "silhouette_slice"
    return "silhouette"


def wire_rows(surface: Surface, color: tuple[float, float, float], layer: int = 0) -> np.ndarray:
    """A wire surface's edges, each once, as instance rows in ``color``."""
    edges = unique_edges(surface.triangles)
    p = surface.positions
    return segment_rows(p[edges[:, 0]], p[edges[:, 1]], color, surface.material.line_width, layer)


def curve_rows(
    curve: Curve, color: tuple[float, float, float], layer: int = 0
) -> np.ndarray | None:
    """A curve's segments as instance rows in ``color`` (None for a curve with none)."""
    segments = curve.segments()
    if not len(segments):
        return None
    return segment_rows(segments[:, 0], segments[:, 1], color, curve.material.line_width, layer)


@dataclass
class GpuSurface:
    name: str
    color: tuple[float, float, float]
    vbo: moderngl.Buffer
    ibo: moderngl.Buffer
    triangle_count: int
    #: Vertex arrays the passes bound to their programs on first use, by "pass:variant"
    #: (exhibit.render.passes.shared.surface_array); freed with the mesh.
    vaos: dict[str, moderngl.VertexArray] = field(default_factory=dict)
    #: Per axis, the sorted coordinates near which a slice may touch the surface, and the
    #: longest edge: the slice's pass runs the tangency test only there (geometry/touching.py).
    critical: tuple[np.ndarray, ...] = ()
    longest_edge: float = 0.0


@dataclass
class GpuMesh:
    """Buffers and vertex arrays for one Mesh4D; release() frees them."""

    mesh: Mesh4D
    surfaces: list[GpuSurface]
    lines: moderngl.Buffer | None
    line_count: int
    markers: moderngl.Buffer | None
    marker_count: int
    #: The curves' and markers' vertex arrays, made by the passes that draw them on first use
    #: (exhibit.render.passes.shared.segment_array); freed with the mesh.
    vaos: dict[str, moderngl.VertexArray] = field(default_factory=dict)
    #: Largest distance of any point from the origin (for the 4D depth colour ramp).
    radius: float = 1.0
    #: A few hundred of the surfaces' vertices (surface_sample): the renderer's depth scale for
    #: intersections, the HUD's picture box.
    sample: np.ndarray | None = None
    #: Per object tag: its candidate points, colour and kept anchor (exhibit.render.object_tags),
    #: kept with the mesh so a new mesh never inherits another's.
    tag_anchors: dict = field(default_factory=dict)
    #: Buffers a pass made for this mesh on first use (the object-id pass's curves), freed
    #: with it.
    buffers: dict[str, moderngl.Buffer] = field(default_factory=dict)
    #: How far its triangles may lie from the true surfaces (mesh_sag, the largest over them):
    #: a curve within it of a sheet is on that sheet, not behind it (centre_test.glsl).
    sag: float = 0.0

    @property
    def triangle_count(self) -> int:
        return sum(s.triangle_count for s in self.surfaces)

    def release(self) -> None:
        for s in self.surfaces:
            for vao in s.vaos.values():
                vao.release()
            s.vbo.release()
            s.ibo.release()
        for vao in self.vaos.values():
            vao.release()
        for buf in (self.lines, self.markers, *self.buffers.values()):
            if buf is not None:
                buf.release()
        self.buffers = {}
        self.surfaces, self.vaos, self.lines, self.markers = [], {}, None, None


def attribute_format(
    program: moderngl.Program, attributes: Iterable[tuple[str, int]]
) -> tuple[str, list[str]]:
    """'4f 4f 4f 1f'-style format for (name, float count) attributes, skipping those the
    program does not use (or its compiler removed)."""
    parts, used = [], []
    for name, count in attributes:
        if name in program:
            parts.append(f"{count}f")
            used.append(name)
        else:
            parts.append(f"{4 * count}x")
    return " ".join(parts), used


def upload(ctx: moderngl.Context, mesh: Mesh4D) -> GpuMesh:
    """Write the mesh to GPU buffers once; each pass binds vertex arrays of its own programs to
    them on first use (exhibit.render.passes.shared), kept in ``vaos`` and freed with them."""
    surfaces: list[GpuSurface] = []
    rows: list[np.ndarray] = []
    for surface in mesh.surfaces:
        if surface.material.style == "wire":
            rows.append(wire_rows(surface, surface.material.color, len(rows)))
            continue
        if len(surface.triangles) == 0:
            continue
        vbo = ctx.buffer(surface_vertices(surface).tobytes())
        ibo = ctx.buffer(np.ascontiguousarray(surface.triangles, dtype=np.int32).tobytes())
        gpu = GpuSurface(surface.name, surface.material.color, vbo, ibo, len(surface.triangles))
        gpu.critical = critical_values(surface.positions, surface.normals)
        p, t = surface.positions, surface.triangles
        gpu.longest_edge = float(
            max(np.linalg.norm(p[t[:, k]] - p[t[:, (k + 1) % 3]], axis=1).max() for k in range(3))
        )
        surfaces.append(gpu)
    for curve in mesh.curves:
        row = curve_rows(curve, curve.material.color, len(rows))
        if row is not None:
            rows.append(row)
    lines = markers = None
    line_count = marker_count = 0
    if rows:
        data = np.concatenate(rows).astype(np.float32)
        lines = ctx.buffer(data.tobytes())
        line_count = len(data)
    if mesh.markers:
        marker_rows = []
        for m in mesh.markers:
            width = max(MARKER_SCALE * m.material.line_width, MARKER_MIN)
            p = m.position[None]
            marker_rows.append(segment_rows(p, p, MARKER_OUTLINE, width + 3.0))
            marker_rows.append(segment_rows(p, p, m.material.color, width))
        data = np.concatenate(marker_rows).astype(np.float32)
        markers = ctx.buffer(data.tobytes())
        marker_count = len(data)
    arrays = (
        [s.positions for s in mesh.surfaces]
        + [c.points for c in mesh.curves]
        + [m.position[None] for m in mesh.markers]
    )
    radius = max([float(np.linalg.norm(a, axis=1).max()) for a in arrays if len(a)] + [1e-6])
    gpu_mesh = GpuMesh(mesh, surfaces, lines, line_count, markers, marker_count, radius=radius)
    solid = [s for s in mesh.surfaces if s.material.style != "wire" and len(s.triangles)]
    gpu_mesh.sag = max((mesh_sag(s) for s in solid), default=0.0)
    return gpu_mesh
