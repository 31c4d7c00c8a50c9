"""Hidden surfaces: the nearer part hides the farther one, for surfaces and for curves."""

import math

import numpy as np
import pytest

from exhibit.geometry import ViewState, clip_transform
from exhibit.surfaces.mesh import Curve, Material, Mesh4D
from tests.render.conftest import PLAIN, square

SIZE = (200, 150)
RED, GREEN, BLUE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.3, 1.0)
EX, EY = (1, 0, 0, 0), (0, 1, 0, 0)


def two_squares(order):
    near = square("near", (0.2, 0.0, 0.5, 0.0), EX, EY, RED)  # z = +0.5: towards the eye
    far = square("far", (-0.2, 0.0, -0.5, 0.0), EX, EY, GREEN)  # z = -0.5
    return Mesh4D(surfaces=[near, far] if order == "near first" else [far, near])


def dominant(pixel):
    return int(np.argmax(pixel))


def pixel_of(view, point):
    ((x, y),) = clip_transform(view, SIZE[0] / SIZE[1]).to_pixels(np.array([point]), *SIZE).points
    return int(y), int(x)


@pytest.mark.parametrize("order", ["near first", "far first"])
@pytest.mark.parametrize("eye_r", [0.0, 1 / 6])
def test_the_nearer_square_hides_the_farther(gl, order, eye_r):
    view = ViewState(eye_r=eye_r, half_height=1.0)
    gpu = gl.renderer.upload(two_squares(order))
    image = gl.image(gpu, view, SIZE, PLAIN)
    # Both squares cover x in [-0.3, 0.3]; red is in front there, green shows only at its left.
    assert dominant(image[pixel_of(view, (0.0, 0.0, 0.0, 0.0))]) == 0
    assert dominant(image[pixel_of(view, (-0.6, 0.0, -0.5, 0.0))]) == 1
    # Seen from behind (rotated by pi in the yz-plane) the green square is in front.
    back = view.replace(reading="object", angles=(0.0, math.pi, 0.0, 0.0, 0.0, 0.0))
    image = gl.image(gpu, back, SIZE, PLAIN)
    assert dominant(image[pixel_of(back, (0.0, 0.0, 0.0, 0.0))]) == 1
    gpu.release()


def test_depth_through_the_sensor_projection(gl):
    """Depth is the z of the 3D image: w only scales it (1 / (1 - r w)), never reorders x, y."""
    view = ViewState(sensor_r=0.4, eye_r=1 / 6, half_height=1.2)
    near = square("near", (0.0, 0.0, 0.3, 0.8), EX, EY, RED, half=0.3)  # z/H = 0.3/0.68
    far = square("far", (0.0, 0.0, 0.2, -0.5), EX, EY, GREEN, half=0.6)  # z/H = 0.2/1.2
    gpu = gl.renderer.upload(Mesh4D(surfaces=[far, near]))
    image = gl.image(gpu, view, SIZE, PLAIN)
    assert dominant(image[pixel_of(view, (0.0, 0.0, 0.3, 0.8))]) == 0
    gpu.release()


def test_curves_are_depth_tested_against_surfaces(gl):
    view = ViewState(eye_r=1 / 6, half_height=1.0)
    wall = square("wall", (0.0, 0.0, 0.0, 0.0), EX, EY, RED, half=0.4)
    behind = Curve(
        "behind",
        np.array([[-0.9, 0.1, -0.3, 0.0], [0.9, 0.1, -0.3, 0.0]]),
        Material(color=BLUE, line_width=4.0),
    )
    front = Curve(
        "front",
        np.array([[-0.9, -0.15, 0.3, 0.0], [0.9, -0.15, 0.3, 0.0]]),
        Material(color=GREEN, line_width=4.0),
    )
    gpu = gl.renderer.upload(Mesh4D(surfaces=[wall], curves=[behind, front]))
    image = gl.image(gpu, view, SIZE, PLAIN)
    assert dominant(image[pixel_of(view, (0.0, 0.1, -0.3, 0.0))]) == 0  # hidden by the wall
    assert dominant(image[pixel_of(view, (0.7, 0.1, -0.3, 0.0))]) == 2  # beside it: visible
    assert dominant(image[pixel_of(view, (0.0, -0.15, 0.3, 0.0))]) == 1  # in front of it
    gpu.release()


@pytest.mark.parametrize("eye_r", [0.0, 1 / 6])
def test_coincident_curves_do_not_fight(gl, eye_r):
    """Two curves along the same line in the picture (Figure 6: a Hopf fibre seen edge-on lies
    along the y axis) are drawn one over the other, never speckled: each capsule's depth is the
    line's own depth (not stretched over the quad's end caps), and the earlier curve of the mesh
    lies a hair in front of the later ones."""
    view = ViewState(
        eye_r=eye_r, half_height=1.0, angles=(0.4, 0.3, 0.0, 0.0, 0.0, 0.0)
    )  # the line recedes from the eye
    a, b = np.array([-0.9, -0.6, -0.7, 0.0]), np.array([0.8, 0.7, 0.6, 0.0])
    fine = Curve(
        "fibre", a + np.linspace(0, 1, 37)[:, None] * (b - a), Material(color=GREEN, line_width=5.0)
    )
    coarse = Curve(
        "axis",
        np.array([a - 0.05 * (b - a), b + 0.05 * (b - a)]),
        Material(color=RED, line_width=5.0),
    )
    gpu = gl.renderer.upload(Mesh4D(curves=[fine, coarse]))
    image = gl.image(gpu, view, SIZE, PLAIN, samples=0).astype(int)
    gpu.release()
    ct = clip_transform(view, SIZE[0] / SIZE[1])
    (x0, y0), (x1, y1) = ct.to_pixels(np.array([a, b]), *SIZE).points
    red = green = 0
    for t in np.linspace(0.05, 0.95, 200):  # along the shared stretch, on the line itself
        x, y = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
        pixel = image[int(y), int(x)]  # pixel i spans [i, i + 1)
        red += pixel[0] > 128 and pixel[1] < 64
        green += pixel[1] > 128 and pixel[0] < 64
    assert green == 200 and red == 0
