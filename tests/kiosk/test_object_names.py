"""The objects a label or a claim names: exactly, or as pieces of one object ("NAME 2", ...), or
through an alias its scene declares (exhibit.timelines.object_names); check-config names every
name that is none of these, and every scene declares what it draws."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from exhibit import scenes
from exhibit.cli import main
from exhibit.render.object_tags import _parts
from exhibit.resources import shipped
from exhibit.schema.types import MIN_RESOLUTION
from exhibit.timelines.captions import name_problems
from exhibit.timelines.claims.base import matching
from exhibit.timelines.file import load_timeline, timeline_paths
from exhibit.timelines.object_names import MARKS, object_of, stands_for
from tests.kiosk.support import edit

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
TORI = ("torus Z=-√2/2", "torus Z=0", "torus Z=√2/2")
OFFSET = "offset curve (silhouette along u, v)"


def _names(mesh) -> list[str]:
    return [o.name for o in (*mesh.surfaces, *mesh.curves, *mesh.markers)]


def test_a_name_stands_for_its_object_and_its_pieces_only():
    drawn = [
        "silhouette along x and y",
        "silhouette along x and y 2",
        "silhouette along x and y 7",
        "silhouette along x and y (touching)",
        "pipe of y = x²",
        "tracing surface h = 0",
    ]
    assert matching("silhouette along x and y", drawn) == drawn[:3]
    assert matching("silhouette", drawn) == []
    assert matching("pipe of y = x", drawn) == []  # "²" is no piece number
    assert matching("tracing surface h = 0", drawn) == ["tracing surface h = 0"]
    assert stands_for("slice", "slice 2") and not stands_for("slice", "slices")
    assert object_of("cylinder ring 3", ("cylinder ring",)) == "cylinder ring"
    assert object_of("tracing surface h = 0", ("tracing surface h = 0",)) == (
        "tracing surface h = 0"
    )
    assert object_of("torus Z=0", ("torus",)) is None


def test_torus_no_longer_stands_for_all_three_tori():
    scene = scenes.get("hopf")
    mesh = scene.build({}, MIN_RESOLUTION)
    assert matching("torus", _names(mesh)) == []
    assert _parts(mesh, "torus") == ([], [], [])
    surfaces, _, _ = _parts(mesh, "torus Z=0")
    assert [s.name for s in surfaces] == ["torus Z=0"]


def test_the_live_marks_are_the_renderers():
    from exhibit.render.passes.ids import MARKS as RENDERED

    assert MARKS == RENDERED
    assert all(set(MARKS) <= set(scenes.get(n).objects) for n in scenes.names())


def test_an_alias_works_in_a_label_and_a_claim(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text(
        'scene = "offset-parabola"\n[[keyframe]]\nt = 0\ncaption = "The red outline."\n'
        'while = { visible = ["pipe", "offset curve"], fills = { "offset curve" = 0.001 } }\n'
        'labels = { "offset curve" = "offset curve", "pipe" = "tube" }\n'
        "[[keyframe]]\nt = 10\n"
    )
    timeline = load_timeline(path, scenes.get)
    first = timeline.keyframes[0]
    assert first.labels == ((OFFSET, "offset curve"), ("pipe of y = x²", "tube"))
    assert first.condition is not None
    assert first.condition.claim("visible").names() == ("pipe of y = x²", OFFSET)
    assert first.condition.claim("fills").names() == (OFFSET,)
    scene = scenes.get("offset-parabola")
    assert name_problems(timeline, scene.objects, scene.aliases) == []
    mesh = scene.build({}, MIN_RESOLUTION)
    assert matching(OFFSET, _names(mesh))  # found by the exact rule at run time
    _, curves, _ = _parts(mesh, OFFSET)
    assert curves and all(c.name.startswith(OFFSET) for c in curves)


def test_scenes_json_lists_the_names_a_curator_may_write(capsys):
    assert main(["scenes", "--json"]) == 0
    listing = {s["name"]: s for s in json.loads(capsys.readouterr().out)["scenes"]}
    assert listing["offset-cusp"]["aliases"] == {"offset curve": OFFSET, "pipe": "pipe of y² = x³"}
    assert listing["hopf"]["objects"][:3] == list(TORI)


def test_a_scenes_own_labels_resolve_its_aliases():
    """The Clifford torus's four circles are one object in pieces; "circle b" names it."""
    scene = scenes.get("clifford-torus")
    assert scene.aliases["circle b"] == "circles b = kπ/2"
    (name, words), *_ = scene.labels
    _, curves, _ = _parts(scene.build({}, MIN_RESOLUTION), name)
    assert len(curves) == 4 and words == "lines drawn on it"
    gallery = load_timeline(shipped("configs", "attract", "07-gallery.toml"), scenes.get)
    assert gallery.keyframes[0].labels == (("circles b = kπ/2", "lines drawn on it"),)


def test_a_misspelt_name_loads_and_is_named_where_it_is_written(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text(
        'scene = "hopf"\n[[keyframe]]\nt = 0\ncaption = "Three doughnuts."\n'
        'while = { visible = ["torus", "torus Z=0"] }\n'
        'labels = { "torus Z=O" = "white doughnut" }\n'
        '[[keyframe]]\nt = 5\n[[keyframe]]\nt = 9\ncaption = "One."\n'
        'labels = { "fibre Z=2" = "circle" }\n[[keyframe]]\nt = 15\n'
    )
    timeline = load_timeline(path, scenes.get)  # the kiosk plays it: the tag is skipped
    scene = scenes.get("hopf")
    problems = name_problems(timeline, scene.objects, scene.aliases)
    objects = '"torus Z=-√2/2", "torus Z=0", "torus Z=√2/2", "fibre Z=-1"'
    assert problems[0].startswith(f'{path}: keyframe 0: labels: no object "torus Z=O"; ')
    assert f"; objects are {objects}" in problems[0]
    assert problems[1].startswith(f'{path}: keyframe 0: while.visible: no object "torus"; ')
    assert problems[2].startswith(f'{path}: keyframe 2: labels: no object "fibre Z=2"; ')
    assert len(problems) == 3  # carried to keyframe 1, reported once


@pytest.fixture
def tree(tmp_path):
    shutil.copytree(CONFIGS, tmp_path / "configs")
    return tmp_path / "configs"


def test_check_config_names_a_misspelt_label_and_claim(tree, capsys):
    hypersphere = tree / "attract" / "01-hypersphere.toml"
    edit(hypersphere, '"torus Z=0" = "white doughnut"', '"torus Z=O" = "white doughnut"')
    edit(hypersphere, 'visible = ["torus Z=-√2/2", "torus Z=0"', 'visible = ["torus", "torus Z=0"')
    assert main(["check-config", str(tree / "kiosk.toml")]) == 2
    out = capsys.readouterr().out.splitlines()
    assert any(
        line.startswith(f'{hypersphere}: keyframe 0: labels: no object "torus Z=O"; objects are ')
        for line in out
    ), out
    assert any(
        line.startswith(f'{hypersphere}: keyframe 0: while.visible: no object "torus"; objects ')
        for line in out
    ), out
    assert out[-1] == "2 problem(s) found."


def test_check_config_names_a_scenes_label_for_no_object(monkeypatch, capsys):
    scenes.load()
    hopf = scenes.get("hopf")
    broken = dataclasses.replace(hopf, labels=(("torus", "doughnuts"),))
    monkeypatch.setitem(scenes._REGISTRY, "hopf", broken)
    assert main(["check-config", str(CONFIGS / "kiosk.toml")]) == 2
    out = capsys.readouterr().out.splitlines()
    assert any(
        line.startswith('scene hopf: labels: no object "torus"; objects are "torus Z=-√2/2"')
        for line in out
    ), out


def test_the_shipped_configs_pass_check_config(capsys):
    assert main(["check-config", str(CONFIGS / "kiosk.toml")]) == 0, capsys.readouterr().out


def _shipped_params() -> dict[str, list[dict]]:
    params: dict[str, list[dict]] = {}
    for path in timeline_paths(shipped("configs", "attract")):
        timeline = load_timeline(path, scenes.get)
        params.setdefault(timeline.scene, []).append(dict(timeline.params))
    return params


SLOW = {"offset-cusp"}  # about 5 s at the least resolution (the pipe's singular circle)


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in scenes.names()],
)
def test_every_scene_declares_what_it_draws(name):
    """Built at the least resolution with its defaults and with the shipped timelines'
    parameters, every object drawn is one of Scene.objects or a piece of one, and the scene's
    own labels name objects of it."""
    scene = scenes.get(name)
    runs = [scene.resolve({})] + [scene.resolve(p) for p in _shipped_params().get(name, [])]
    for params in {tuple(sorted(p.items())): p for p in runs}.values():
        mesh = scene.build(params, MIN_RESOLUTION)
        strays = [n for n in _names(mesh) if object_of(n, scene.objects) is None]
        assert not strays, (params, strays, scene.objects)
    assert all(label in scene.objects for label, _ in scene.labels), scene.labels
