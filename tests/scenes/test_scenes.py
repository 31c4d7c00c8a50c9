"""The scene registry: names, parameters, presets, figures; errors name what was wrong."""

import pytest

from exhibit import scenes
from exhibit.scenes import palette
from exhibit.errors import ExhibitError
from exhibit.surfaces import analyse


def test_hopf_scene_has_the_parts_of_figures_6_to_8():
    mesh = scenes.get("hopf").build(resolution=16)
    # green, grey and red doughnuts (in the palette every visitor tells apart)
    assert [s.material.color for s in mesh.surfaces] == [palette.GREEN, palette.GREY, palette.RED]
    assert len(mesh.curves) == 6  # two pole fibres, four axes
    for surface in mesh.surfaces:
        report = analyse(surface.triangles)
        assert report.boundary_edges == 0 and report.euler_characteristic == 0


@pytest.mark.parametrize("number, distance", [(6, float("inf")), (7, 3.0), (8, 2.0)])
def test_figures_6_to_8_place_the_sensor(number, distance):
    scene, preset = scenes.figure(number)
    assert scene.name == "hopf"
    assert preset.view.sensor_distance == pytest.approx(distance)


def test_errors_name_the_problem():
    with pytest.raises(ExhibitError, match="no scene named 'nope'.*hopf"):
        scenes.get("nope")
    hopf = scenes.get("hopf")
    with pytest.raises(ExhibitError, match="no parameter 'radius'"):
        hopf.resolve({"radius": 1})
    with pytest.raises(ExhibitError, match="not a number"):
        hopf.resolve({"axis_length": "long"})
    with pytest.raises(ExhibitError, match="must lie in"):
        hopf.resolve({"axis_length": "-3"})
    with pytest.raises(ExhibitError, match="no figure 99"):
        scenes.figure(99)
