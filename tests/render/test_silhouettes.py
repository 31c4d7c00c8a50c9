"""Live silhouettes: the GPU's Lemma 3 curve is the CPU geometry's zero set of the silhouette
function, for views the scenes never fixed."""

import numpy as np
import pytest

from exhibit import scenes
from exhibit.geometry import (
    ViewState,
    clip_transform,
    eye_ray,
    sensor_ray,
    silhouette_function,
    zero_set_segments,
)
from exhibit.render import RenderOptions

SIZE = (240, 180)
INK_ONLY = RenderOptions(
    surfaces=False,
    curves=False,
    hud=False,
    pinch_points=False,
    background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    silhouette_width=2.0,
    line_scale=1.0,
)
VIEWS = [
    ViewState(angles=(0.4, -0.7, -0.5, 0.3, -0.4, 0.0), sensor_r=0.0, eye_r=0.0, half_height=1.3),
    ViewState(
        angles=(-0.9, -1.2, -0.3, 0.8, -0.6, 0.3),
        sensor_r=1 / 3,
        eye_r=1 / 7,
        offset=(0.0, 0.0, 0.0, 0.3),
        half_height=1.5,
    ),
]


def cpu_silhouette_pixels(surface, view):
    q = view.to_view(surface.positions)
    n1 = view.vectors_to_view(surface.normals[:, 0])
    n2 = view.vectors_to_view(surface.normals[:, 1])
    s = silhouette_function(n1, n2, sensor_ray(q, view.sensor_r), eye_ray(q, view.eye_r))
    segments = zero_set_segments(surface.positions, surface.triangles, s)
    ct = clip_transform(view, SIZE[0] / SIZE[1])
    t = np.linspace(0.0, 1.0, 5)[None, :, None]
    samples = segments[:, :1] + t * (segments[:, 1:] - segments[:, :1])
    pixels, ok = ct.to_pixels(samples.reshape(-1, 4), *SIZE)
    return pixels[ok]


@pytest.mark.parametrize("index", range(len(VIEWS)))
def test_gpu_silhouette_is_the_cpu_zero_set(gl, index):
    view = VIEWS[index]
    mesh = scenes.get("hopf").build(resolution=24)
    mesh.curves.clear()
    gpu = gl.renderer.upload(mesh)
    image = gl.image(gpu, view, SIZE, INK_ONLY, samples=0)
    gpu.release()
    ink = np.argwhere(image.max(axis=-1) > 20)[:, ::-1] + 0.5  # (x, y) pixel centres
    expected = np.concatenate([cpu_silhouette_pixels(s, view) for s in mesh.surfaces])
    expected = expected[np.all((expected >= 0) & (expected < SIZE), axis=1)]
    assert len(ink) > 200 and len(expected) > 200

    def nearest(a, b):
        d = np.full(len(a), np.inf)
        for chunk in np.array_split(np.arange(len(b)), max(1, len(b) // 2000)):
            d = np.minimum(d, np.linalg.norm(a[:, None] - b[None, chunk], axis=-1).min(axis=1))
        return d

    # Every inked pixel is on the CPU curve, and the CPU curve is inked along its length.
    assert np.quantile(nearest(ink, expected), 0.99) <= 2.5
    assert np.quantile(nearest(expected, ink), 0.99) <= 2.5


@pytest.mark.parametrize("at", [-1.5, 0.0])
def test_gpu_slice_is_the_exact_slice(gl, at):
    """ViewState.slice_axis/slice_at: the glowing curve the silhouette pass draws is the slice
    S ∩ {t = at} that exhibit/surfaces/slice.py refines on the CPU, and without a slice nothing
    is drawn."""
    from exhibit.surfaces.slice import slice_curves

    scene, preset = scenes.figure(17)
    mesh = scene.build(preset.params, resolution=32)
    mesh.curves.clear()
    mesh.markers.clear()
    gpu = gl.renderer.upload(mesh)
    view = preset.view.replace(slice_axis=3, slice_at=at)
    plain = RenderOptions(
        surfaces=False,
        curves=False,
        hud=False,
        silhouettes=False,
        background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        line_scale=1.0,
    )
    image = gl.image(gpu, view, SIZE, plain, samples=0)
    none = gl.image(gpu, preset.view, SIZE, plain, samples=0)
    gpu.release()
    assert none.max() == 0
    glow = np.argwhere(image.max(axis=-1) > 60)[:, ::-1] + 0.5
    points = np.concatenate([c.points for s in mesh.surfaces for c in slice_curves(s, 3, at)])
    ct = clip_transform(view, SIZE[0] / SIZE[1])
    expected, ok = ct.to_pixels(points, *SIZE)
    expected = expected[ok]
    assert len(glow) > 100 and len(expected) > 50
    d_glow = np.linalg.norm(glow[:, None] - expected[None], axis=-1).min(axis=1)
    d_curve = np.linalg.norm(expected[:, None] - glow[None], axis=-1).min(axis=1)
    assert np.quantile(d_glow, 0.99) <= 3.0 and np.quantile(d_curve, 0.99) <= 2.5


def test_the_silhouette_pass_writes_no_depth(gl):
    """moderngl's Context has no depth_mask (it is the framebuffer's): setting the context's
    silently did nothing, so every silhouette segment wrote depth and cut holes into the next
    one at each joint. Drawn alone on a cleared depth buffer, the silhouettes must leave it as
    it was, byte for byte, while their colour is there."""
    mesh = scenes.get("hopf").build(resolution=16)
    mesh.curves.clear()
    gpu = gl.renderer.upload(mesh)
    target = gl.target(SIZE, 0)
    depth, colour = [], []
    for silhouettes in (False, True):
        options = RenderOptions(
            hud=False,
            curves=False,
            surfaces=False,
            intersections=False,
            silhouettes=silhouettes,
            silhouette_width=6.0,
            background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        )
        gl.renderer.render(gpu, VIEWS[0], target.framebuffer, options)
        raw = target.framebuffer.read(attachment=-1, dtype="f4")
        depth.append(np.frombuffer(raw, dtype=np.uint32)[: SIZE[0] * SIZE[1]])
        colour.append(np.frombuffer(target.framebuffer.read(), dtype=np.uint8))
    gpu.release()
    assert (colour[1] > 20).sum() > 500 and colour[0].max() == 0
    assert np.array_equal(depth[0], depth[1])


def test_lemma_2_discs_lie_on_top_of_the_silhouette_ink(gl):
    """The Lemma 2 discs sit on folds where silhouette ink runs too: without depth writes the
    ink a later triangle emits would cover a disc, so the discs (and the slice) are a second
    pass. Drawn with wide ink, the discs keep every yellow pixel they have without ink."""
    scene, preset = scenes.figure(17)
    mesh = scene.build(preset.params, resolution=32)
    mesh.curves.clear()
    mesh.markers.clear()
    gpu = gl.renderer.upload(mesh)

    def yellow(ink_width: float) -> int:
        options = RenderOptions(
            surfaces=False,
            curves=False,
            hud=False,
            pinch_size=14.0,
            silhouette_width=ink_width,
            line_scale=1.0,
            background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        )
        image = gl.image(gpu, preset.view, SIZE, options, samples=0).astype(int)
        r, g, b = image[..., 0], image[..., 1], image[..., 2]
        return int(((r > 200) & (g > 180) & (b < 120)).sum())

    alone, inked = yellow(0.0), yellow(6.0)
    gpu.release()
    assert alone > 100 and inked >= alone, (alone, inked)
