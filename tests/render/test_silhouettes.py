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


def _figure_15_slice(gl, ats, size=(320, 240)):
    """Figure 15's scene (the ball touches the pipe at t = 0 along x = 0, y² + z² = 1), the live
    slice alone at each t in ``ats``: glowing pixels, the view, the surface."""
    scene, preset = scenes.figure(15)
    mesh = scene.build(preset.params, resolution=32)
    mesh.curves.clear()
    mesh.markers.clear()
    gpu = gl.renderer.upload(mesh)
    images = [
        gl.image(gpu, preset.view.replace(slice_axis=3, slice_at=at), size, SLICE_ONLY, samples=0)
        for at in ats
    ]
    gpu.release()
    return images, preset.view.replace(slice_axis=3), mesh.surfaces[0]


SLICE_ONLY = RenderOptions(
    surfaces=False,
    curves=False,
    hud=False,
    silhouettes=False,
    pinch_points=False,
    background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    line_scale=1.0,
)


def _segment_pixels(segments, view, size):
    ct = clip_transform(view, size[0] / size[1])
    t = np.linspace(0.0, 1.0, 5)[None, :, None]
    samples = segments[:, :1] + t * (segments[:, 1:] - segments[:, :1])
    pixels, ok = ct.to_pixels(samples.reshape(-1, 4), *size)
    return pixels[ok]


def _nearest(a, b):
    return np.linalg.norm(a[:, None] - b[None], axis=-1).min(axis=1)


def test_the_live_slice_glows_at_exact_tangency(gl):
    """At t = 0 the hyperplane is tangent to Figure 15's surface along the circle x = 0,
    y² + z² = 1: h = t keeps its sign across it, so a sign-change test draws nothing. The
    geometry shader's touching() (geometry/touching.py in numpy, the reference here) draws the
    circle in the slice's colour, all of it but the ends at the two singular points (0, ±1, 0,
    0)."""
    from exhibit.geometry.touching import tangential_gradient, touching_segments
    from exhibit.render.passes.silhouettes import SLICE_COLOR

    size = (320, 240)
    (image,), view, surface = _figure_15_slice(gl, [0.0], size)
    colour = np.abs(image.astype(float) - 255 * np.asarray(SLICE_COLOR)).max(axis=-1) < 40
    glow = np.argwhere(colour)[:, ::-1] + 0.5
    # the numpy mirror: segments on the circle, to the chord's height over the surface
    axis = np.eye(4)[3]
    segments = touching_segments(
        surface.positions,
        surface.triangles,
        surface.positions @ axis,
        tangential_gradient(axis, surface.normals),
        surface.singular,
    )
    x, y, z, t = segments.reshape(-1, 4).T
    assert np.sqrt(x**2 + t**2 + (np.hypot(y, z) - 1) ** 2).max() < 0.01
    expected = _segment_pixels(segments, view, size)
    assert len(glow) > 300 and len(expected) > 300
    # The two singular points lie on the slice too: the mesh reaches them exactly (a vertex on
    # each since it follows the surface there, with h = 0), and the sign-change rule glows
    # there; the touching segments stop short of them.
    singular, _ = clip_transform(view, size[0] / size[1]).to_pixels(
        np.array([[0.0, 1.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0]]), *size
    )
    glow = glow[_nearest(glow, singular) > 4.0]
    assert np.quantile(_nearest(glow, expected), 0.99) <= 3.0
    assert np.quantile(_nearest(expected, glow), 0.99) <= 2.5
    # the projected circle is in the slice's colour, except next to the singular points
    phi = np.linspace(0, 2 * np.pi, 240, endpoint=False)
    phi = phi[np.abs(np.sin(phi)) > np.sin(0.15)]
    circle = np.stack([0 * phi, np.cos(phi), np.sin(phi), 0 * phi], 1)
    pixels, ok = clip_transform(view, size[0] / size[1]).to_pixels(circle, *size)
    assert ok.all() and _nearest(pixels, glow).max() <= 2.0


@pytest.mark.parametrize("at", [-0.05, 0.05])
def test_the_live_slice_off_tangency_is_the_sign_change_rule(gl, at):
    """At t = ±0.05 the hyperplane is clearly off tangency: the glow is the sign changes' alone
    (marching triangles, zero_set_segments), with no touching segment added."""
    from exhibit.geometry.touching import tangential_gradient, touching_segments

    size = (320, 240)
    (image,), view, surface = _figure_15_slice(gl, [at], size)
    glow = np.argwhere(image.max(axis=-1) > 60)[:, ::-1] + 0.5
    axis = np.eye(4)[3]
    h = surface.positions @ axis - at
    gradient = tangential_gradient(axis, surface.normals)
    assert len(touching_segments(surface.positions, surface.triangles, h, gradient)) == 0
    expected = _segment_pixels(
        zero_set_segments(surface.positions, surface.triangles, h), view, size
    )
    assert len(glow) > 300 and len(expected) > 100
    assert _nearest(glow, expected).max() <= 3.5
    assert np.quantile(_nearest(expected, glow), 0.99) <= 2.5
