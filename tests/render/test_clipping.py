"""Clipping at the sensor hyperplane: with the sensor at distance 2 and closer, every triangle is
drawn exactly where its clipped 4D polygon projects, and none spans the screen."""

import numpy as np
import pytest

from exhibit import scenes
from exhibit.geometry import clip_transform

SIZE = (240, 180)
RESOLUTION = 20


@pytest.fixture(scope="module")
def hopf_gpu(headless):
    scene, preset = scenes.figure(8)
    mesh = scene.build(preset.params, RESOLUTION)
    gpu = headless.renderer.upload(mesh)
    yield mesh, gpu, preset.view
    gpu.release()


def rendered_boxes(ids):
    """{triangle: (xmin, ymin, xmax, ymax)} over its pixel centres."""
    ys, xs = np.nonzero(ids)
    tri = ids[ys, xs] - 1
    order = np.unique(tri)
    index = np.searchsorted(order, tri)
    boxes = np.empty((len(order), 4))
    boxes[:, :2], boxes[:, 2:] = np.inf, -np.inf
    cx, cy = xs + 0.5, ys + 0.5
    np.minimum.at(boxes[:, 0], index, cx)
    np.minimum.at(boxes[:, 1], index, cy)
    np.maximum.at(boxes[:, 2], index, cx)
    np.maximum.at(boxes[:, 3], index, cy)
    return dict(zip(order.tolist(), boxes))


def clip_polygon(points, planes):
    """Sutherland-Hodgman in homogeneous 4D: keep where plane · (p, 1) >= 0 for every plane."""
    poly = [np.append(p, 1.0) for p in points]
    for plane in planes:
        out = []
        for i, a in enumerate(poly):
            b = poly[(i + 1) % len(poly)]
            da, db = plane @ a, plane @ b
            if da >= 0:
                out.append(a)
            if (da >= 0) != (db >= 0):
                out.append(a + (b - a) * (da / (da - db)))
        poly = out
        if not poly:
            return None
    return np.array(poly)[:, :4]


def expected_box(ct, triangle_points):
    """Pixel bounding box of the triangle's clipped image (sensor, front, near, far planes)."""
    m = ct.matrix
    planes = [ct.clip_planes[0], ct.clip_planes[1], m[2] + m[3], m[3] - m[2]]
    poly = clip_polygon(triangle_points, planes)
    if poly is None:
        return None
    clip = np.concatenate([poly, np.ones((len(poly), 1))], axis=1) @ m.T
    w = np.maximum(clip[:, 3], 1e-9)
    x = (clip[:, 0] / w + 1) * 0.5 * SIZE[0]
    y = (1 - clip[:, 1] / w) * 0.5 * SIZE[1]
    return np.array([x.min(), y.min(), x.max(), y.max()])


def misplaced(mesh, view, ids):
    """Triangles with a pixel outside the CPU's exact clipped image (by more than 1 px)."""
    ct = clip_transform(view, SIZE[0] / SIZE[1])
    triangles = np.concatenate([s.positions[s.triangles] for s in mesh.surfaces])
    bad = []
    for tri, box in rendered_boxes(ids).items():
        want = expected_box(ct, triangles[tri])
        if want is None or np.any(box[:2] < want[:2] - 1) or np.any(box[2:] > want[2:] + 1):
            bad.append(tri)
    return bad


@pytest.mark.parametrize("distance", [2.0, 1.7, 1.4])
def test_triangles_are_clipped_exactly_at_the_sensor(gl, hopf_gpu, distance):
    mesh, gpu, view = hopf_gpu
    view = view.with_sensor_distance(distance).replace(front_distance=float("inf"))
    ids = gl.ids(gpu, view, SIZE)
    assert len(np.unique(ids)) > 50
    assert misplaced(mesh, view, ids) == []


def test_no_triangle_spans_the_screen_at_distance_2(gl, hopf_gpu):
    mesh, gpu, view = hopf_gpu
    boxes = np.array(list(rendered_boxes(gl.ids(gpu, view, SIZE)).values()))
    extent = np.maximum(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1])
    assert extent.max() < 0.5 * SIZE[0]


def test_the_check_catches_a_stretched_triangle(gl, hopf_gpu):
    """misplaced() can fail: one triangle's id painted across the picture (what a per-vertex
    divide by 1 - r w does to a triangle crossing the sensor hyperplane) is reported."""
    mesh, gpu, view = hopf_gpu
    view = view.with_sensor_distance(1.4).replace(front_distance=float("inf"))
    ids = gl.ids(gpu, view, SIZE)
    victim = int(np.bincount(ids.ravel())[1:].argmax()) + 1
    ids[SIZE[1] // 2, :] = victim
    assert misplaced(mesh, view, ids) == [victim - 1]


def test_triangles_are_clipped_exactly_at_the_tilted_front_plane(gl, hopf_gpu):
    mesh, gpu, view = hopf_gpu  # Figure 8: sensor at 2, front plane at 0.6 pitched by 0.5
    assert np.isfinite(view.front_distance)
    assert misplaced(mesh, view, gl.ids(gpu, view, SIZE)) == []
