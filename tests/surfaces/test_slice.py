"""Slices S ∩ {x_a = c} (exhibit/surfaces/slice.py, `exhibit slice`): for the collision along t
every point lies on the moving cylinder and the moving sphere at the moment c, checked against
their own equations (not the scene's code), and the number of curves is the one the geometry
says: 0 before the first contact, 1 while the ball meets the pipe from one side, 2 while the ball
sticks out of the pipe on both sides (the paper's "hole")."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from exhibit import scenes
from exhibit.surfaces.exact_silhouette import RefineStats
from exhibit.surfaces.slice import slice_curves, traced_slice

T = 3  # the collision's axes are x, y, z, t


def expected_curves(p: dict, c: float) -> int:
    """Components of {cylinder at c} ∩ {sphere at c}: the sphere's centre is d = |c|·v from the
    pipe's axis; two loops while the pipe passes through the ball, one while they overlap from
    one side, none apart (or the ball wholly inside the pipe)."""
    d = abs(c) * math.hypot(p["vc"], p["vs"])
    rc, rs = p["rc"], p["rs"]
    if d >= rc + rs or d <= rc - rs:
        return 0
    return 2 if d < rs - rc else 1


def margin(p: dict, c: float) -> float:
    """How far (in d) the moment is from a change of topology."""
    d = abs(c) * math.hypot(p["vc"], p["vs"])
    return min(abs(d - (p["rc"] + p["rs"])), abs(d - abs(p["rs"] - p["rc"])))


def random_cases(seed: int, count: int):
    rng = np.random.default_rng(seed)
    cases = []
    while len(cases) < count:
        p = {
            "rc": rng.uniform(0.6, 1.4),
            "rs": rng.uniform(0.6, 1.6),
            "vc": rng.uniform(0.0, 1.2),
            "vs": rng.uniform(0.3, 1.2),
        }
        v = math.hypot(p["vc"], p["vs"])
        t0 = (p["rc"] + p["rs"]) / v
        times = [
            c
            for c in rng.uniform(-1.1 * t0, 1.1 * t0, 12)
            if margin(p, c) > 0.12 * min(p["rc"], p["rs"])
        ]
        cases.append((p, times[:4]))
    return cases


@pytest.fixture(scope="module")
def collision():
    scenes.load()
    return scenes.get("collision")


@pytest.mark.parametrize("p, times", random_cases(7, 4))
def test_collision_slices_lie_on_the_pipe_and_the_ball_at_that_moment(collision, p, times):
    mesh = collision.build(p)
    for c in times:
        stats = RefineStats()
        curves = [curve for s in mesh.surfaces for curve in slice_curves(s, T, c, stats)]
        assert len(curves) == expected_curves(p, c), (p, c, stats)
        assert stats.dropped == 0
        for curve in curves:
            x, y, z, t = curve.points.T
            assert np.all(t == c)
            pipe = np.hypot(y - p["vc"] * c, z) - p["rc"]
            ball = np.sqrt(x**2 + y**2 + (z + p["vs"] * c) ** 2) - p["rs"]
            assert np.abs(pipe).max() <= 1e-6 and np.abs(ball).max() <= 1e-6
            assert curve.closed and len(curve.points) >= 8


def test_the_first_contact_opens_one_small_loop_around_the_colliding_point(collision):
    p = {"rc": 1.0, "rs": 1.2, "vc": 0.0, "vs": 1.0}
    mesh = collision.build(p)
    t0 = -(p["rc"] + p["rs"])  # v = 1
    assert [c for s in mesh.surfaces for c in slice_curves(s, T, t0 - 0.02)] == []
    loops = [c for s in mesh.surfaces for c in slice_curves(s, T, t0 + 0.02)]
    assert len(loops) == 1
    contact = np.array([0.0, 0.0, p["rc"], t0])  # on the line between the centres, z = rc
    assert np.linalg.norm(loops[0].points[:, :3] - contact[:3], axis=1).max() < 0.5


def test_refinement_moves_points_from_the_mesh_onto_the_exact_curve(collision):
    mesh = collision.build({})
    surface = mesh.surfaces[0]
    traced = traced_slice(surface, T, 0.0)
    refined = slice_curves(surface, T, 0.0)
    x, y, z, _ = np.concatenate([c.points for c in traced]).T
    before = np.abs(np.hypot(y, z) - 1.0).max()
    x, y, z, _ = np.concatenate([c.points for c in refined]).T
    after = np.abs(np.hypot(y, z) - 1.0).max()
    assert before > 1e-4 and after < 1e-9


def test_a_parametric_surface_is_refined_in_its_parameters():
    """The Hopf tori lie on the unit hypersphere: their slices at w = c stay on it."""
    scenes.load()
    mesh = scenes.get("hopf").build({})
    stats = RefineStats()
    curves = [c for s in mesh.surfaces for c in slice_curves(s, 3, 0.3, stats)]
    assert curves and stats.dropped == 0 and stats.max_residual <= 1e-9
    points = np.concatenate([c.points for c in curves])
    assert np.abs(points[:, 3] - 0.3).max() <= 1e-9
    assert np.abs(np.linalg.norm(points, axis=1) - 1.0).max() <= 1e-6


def test_a_mesh_without_its_exact_surface_refines_nothing(collision):
    surface = collision.build({}).surfaces[0]
    surface.exact = None
    stats = RefineStats()
    assert slice_curves(surface, T, 0.0, stats) == [] and stats.dropped > 0


def test_the_command_prints_the_curves_as_json(cli):
    out = cli("slice", "collision", "--axis", "t", "--at", "0", "--param", "rs=1.3", "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["axis"] == "t" and data["at"] == 0.0 and len(data["curves"]) == 2
    assert data["dropped"] == 0 and data["max_residual"] <= 1e-9
    assert all(point[3] == 0.0 for curve in data["curves"] for point in curve)


@pytest.mark.parametrize(
    "args, message",
    [
        (("--axis", "w", "--at", "0"), "'w' is not an axis of this scene (axes: x, y, z, t)"),
        (("--axis", "t", "--at", "nan"), "argument --at: must be a number"),
        (("--axis", "t", "--at", "1e400"), "argument --at: must be a number"),
    ],
)
def test_bad_arguments_get_one_line(cli, args, message):
    out = cli("slice", "collision", *args)
    assert out.returncode == 2 and message in out.stderr and "Traceback" not in out.stderr
