"""Views in which a whole component is silhouette (issue 22): s vanishes identically there, so
sign changes find nothing, and the command must say so instead of reporting no silhouette."""

import json

import numpy as np
import pytest

from exhibit import cli
from exhibit.scenes.implicit_scene import mesh_implicit
from exhibit.surfaces.mesh import Material
from exhibit.surfaces.whole_silhouette import whole_silhouette_components


def _json(capsys, *argv):
    assert cli.main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize(
    "argv, name",
    [
        (("offset-parabola", "--along", "x,y"), "pipe of y = x²"),
        (("offset-cusp", "--along", "x,y"), "pipe of y² = x³"),
        (("collision", "--along", "x,t", "--param", "vc=0"), "collision surface"),
    ],
)
def test_a_whole_silhouette_component_is_reported_by_name(capsys, argv, name):
    out = _json(capsys, "silhouette", *argv, "--resolution", "16", "--json")
    assert out["curves"] == []
    assert [c["name"] for c in out["components"] if c["whole_component"]] == [name]
    assert cli.main(["silhouette", *argv, "--resolution", "16"]) == 0
    assert f"the whole of {name} is silhouette" in capsys.readouterr().out


def test_an_ordinary_view_has_no_whole_component(capsys):
    out = _json(
        capsys, "silhouette", "offset-parabola", "--along", "u,v", "--resolution", "16", "--json"
    )
    assert out["curves"] and not any(c["whole_component"] for c in out["components"])


def test_a_planted_torus_is_whole_along_one_pair_and_a_curve_along_another():
    """x² + y² = 1, u² + v² = 1: ∇f1 = 2(x, y, 0, 0), ∇f2 = 2(0, 0, u, v). Along x, y the minor
    (∇f1·e_x)(∇f2·e_y) - (∇f1·e_y)(∇f2·e_x) = 0 identically; along x, u it is 4xu, a curve."""
    part = mesh_implicit(
        "torus",
        "x^2 + y^2 - 1",
        "u^2 + v^2 - 1",
        ("x", "y", "u", "v"),
        {},
        [-1.2] * 4,
        [1.2] * 4,
        12,
        Material(),
    )
    whole = whole_silhouette_components(part.surface, (0, 1))
    assert [c["whole_component"] for c in whole] == [True]
    other = whole_silhouette_components(part.surface, (0, 2))
    assert [c["whole_component"] for c in other] == [False]
    # independent: 4xu / (|∇f1||∇f2|) = xu on the torus
    x, _, u, _ = part.surface.positions.T
    assert other[0]["largest_measure"] == pytest.approx(np.abs(x * u).max(), rel=1e-6)
