"""Intersection curves of the 3D image (intersect.glsl): where two sheets cross, a dark curve is
drawn along the true crossing line, continuous and at subpixel position, instead of the
z-buffer's staircase; nothing is inked where sheets only meet at mesh edges or occlude."""

import numpy as np
import pytest

from exhibit import scenes
from exhibit.render import RenderOptions
from exhibit.render.quality import Quality
from exhibit.surfaces.mesh import Material, Mesh4D, Surface
from tests.render.conftest import square

SIZE = (240, 160)
BLACK = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
GREY = (0.8, 0.8, 0.8)
#: Sheet B is the plane z = A x + B y: it crosses the plane z = 0 along A x + B y = 0, a line
#: slanted on screen (so the colour boundary alone is a staircase).
SLOPE = (0.4, 0.25)


def crossing_planes(one_surface: bool) -> Mesh4D:
    a = square("a", (0, 0, 0, 0), (1, 0, 0, 0), (0, 1, 0, 0), GREY, half=1.0, n=6)
    # One surface: B is a different sheet of the same surface, 0.5 away in w (as where a
    # projected surface passes through itself); two surfaces: different parts at the same w.
    w = 0.5 if one_surface else 0.0
    b = square("b", (0, 0, 0, w), (1, 0, SLOPE[0], 0), (0, 1, SLOPE[1], 0), GREY, half=1.0, n=5)
    if not one_surface:
        return Mesh4D(surfaces=[a, b])
    merged = Surface(
        "ab",
        np.concatenate([a.positions, b.positions]),
        np.concatenate([a.normals, b.normals]),
        np.concatenate([a.triangles, b.triangles + len(a.positions)]),
        Material(color=GREY),
    )
    return Mesh4D(surfaces=[merged])


FXAA = Quality("f", "fxaa")


def draw(gl, mesh, intersections: bool, quality=FXAA):
    gpu = gl.renderer.upload(mesh)
    view = scenes.get("hopf").view.replace(angles=(0.0,) * 6, half_height=1.2)
    # Line widths as at 720 px.
    options = RenderOptions(
        hud=False,
        silhouettes=False,
        curves=False,
        background=BLACK,
        intersections=intersections,
        line_scale=1.0,
    )
    image = gl.frame(gpu, view, SIZE, options, None, quality)
    ct = gl.renderer.clip_transform(view, SIZE)
    gpu.release()
    return image, ct


def line_x(ct, rows: np.ndarray) -> np.ndarray:
    """Pixel x of the true crossing line at the centres of the given pixel rows."""
    ys = np.linspace(-1.0, 1.0, 400)
    xs = -SLOPE[1] * ys / SLOPE[0]
    points = np.stack([xs, ys, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    pixels, ok = ct.to_pixels(points, *SIZE)
    assert ok.all()
    order = np.argsort(pixels[:, 1])
    return np.interp(rows + 0.5, pixels[order, 1], pixels[order, 0])


def luma(image):
    return image.astype(float) @ np.array([0.299, 0.587, 0.114]) / 255.0


@pytest.mark.parametrize("one_surface", [False, True], ids=["two-parts", "one-surface"])
def test_the_crossing_is_a_continuous_curve_on_the_true_line(gl, one_surface):
    mesh = crossing_planes(one_surface)
    inked, ct = draw(gl, mesh, True)
    plain, _ = draw(gl, mesh, False)
    rows = np.arange(SIZE[1] // 2 - 30, SIZE[1] // 2 + 25)
    xs = line_x(ct, rows)
    cols = np.arange(SIZE[0])
    lum_inked, lum_plain = luma(inked), luma(plain)
    for y, x0 in zip(rows, xs):
        near = np.abs(cols + 0.5 - x0) <= 4
        # Darkening against the picture without curves: ink along the line, about a pixel's
        # worth in every row (a 1 px core, a 1 px antialiased rim)...
        dark = np.clip(lum_plain[y] - lum_inked[y], 0.0, None) * near
        assert dark.sum() > 0.8 * lum_plain[y][near].min(), f"row {y}: no curve near x={x0:.1f}"
        # ...centred on the true line to a fraction of a pixel (a staircase is off by up to 0.5
        # px and jumps from row to row)...
        centre = (dark * (cols + 0.5)).sum() / dark.sum()
        assert abs(centre - x0) < 0.25, f"row {y}: curve at {centre:.2f}, line at {x0:.2f}"
    # ...and nothing inked away from it (the sheets' mesh edges, their outer contours).
    far = np.abs(cols[None, :] + 0.5 - line_x(ct, np.arange(SIZE[1]))[:, None]) > 3
    assert (np.clip(lum_plain - lum_inked, 0.0, None)[far] < 0.02).all()
    # The picture without curves has no ink there at all: the colour boundary is a staircase.
    for y, x0 in zip(rows, xs):
        assert lum_plain[y][np.abs(cols + 0.5 - x0) <= 2].min() > 0.25


def test_no_curve_without_a_crossing(gl):
    """Two parallel sheets, one occluding the other, and a single sheet's mesh edges: no ink."""
    a = square("a", (0, 0, 0, 0), (1, 0, 0, 0), (0, 1, 0, 0), GREY, half=1.0, n=6)
    b = square("b", (0.3, 0.2, -0.4, 0.5), (1, 0, 0.1, 0), (0, 1, 0.05, 0), GREY, half=0.8, n=5)
    mesh = Mesh4D(surfaces=[a, b])
    inked, _ = draw(gl, mesh, True)
    plain, _ = draw(gl, mesh, False)
    assert np.array_equal(inked, plain)


def test_every_antialiasing_inks_the_crossing(gl):
    mesh = crossing_planes(False)
    for quality in (Quality("m", "msaa"), Quality("n", "none"), Quality("s", "fxaa", scale=0.5)):
        inked, _ = draw(gl, mesh, True, quality)
        plain, _ = draw(gl, mesh, False, quality)
        assert (luma(plain) - luma(inked)).max() > 0.15, quality.name


def components(mask: np.ndarray) -> list[int]:
    """Sizes of the 8-connected components of a boolean image, largest first."""
    seen = np.zeros_like(mask)
    sizes = []
    for start in zip(*np.nonzero(mask)):
        if seen[start]:
            continue
        seen[start] = True
        stack, size = [start], 0
        while stack:
            y, x = stack.pop()
            size += 1
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    q = (y + dy, x + dx)
                    if (
                        0 <= q[0] < mask.shape[0]
                        and 0 <= q[1] < mask.shape[1]
                        and mask[q]
                        and not seen[q]
                    ):
                        seen[q] = True
                        stack.append(q)
        sizes.append(size)
    return sorted(sizes, reverse=True)


def test_the_hopf_tori_crossings_at_the_kiosks_mesh_size(gl):
    """The attract timeline's hypersphere (Figure 7: the sensor at distance 3) at the kiosk's
    resolution 48: where the tori pass through each other the crossing is inked as long,
    unbroken curves; without them there is no ink, only the staircase between two colours."""
    import math

    scene = scenes.get("hopf")
    gpu = gl.renderer.upload(scene.build({}, 48))
    view = scene.view.replace(
        angles=(0.0, 0.0, 0.0, math.radians(20), 0.0, 0.0), half_height=2.2
    ).with_sensor_distance(3.0)
    size = (640, 360)
    options = dict(hud=False, silhouettes=False, curves=False, line_scale=1.0)
    inked = gl.frame(gpu, view, size, RenderOptions(**options), None, Quality("f", "fxaa"))
    plain = gl.frame(
        gpu, view, size, RenderOptions(intersections=False, **options), None, Quality("f", "fxaa")
    )
    gpu.release()
    ink = luma(plain) - luma(inked) > 0.1
    sizes = components(ink)
    assert ink.sum() > 300, ink.sum()
    # The red torus passes through the grey one along an arc some 250 px long: one unbroken
    # curve. (Near the outline, where the surfaces are lit at grazing angles and dark, the ink
    # darkens them by less than the threshold here, so the fainter curves count in pieces.)
    assert sizes[0] > 250, sizes[:10]
