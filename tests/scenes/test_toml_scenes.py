"""Curators' TOML scenes: the shipped files load and mesh; every mistake names file and key."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from exhibit import scenes
from exhibit.errors import ExhibitError
from exhibit.scenes.toml_scene import load_scene_file
from exhibit.surfaces import analyse

GOOD = """
name = "slice"
title = "A slice"
caption = "For visitors."
[parameters.a]
default = 0.25
min = -0.45
max = 0.45
[[surface]]
name = "slice"
f1 = "x^2 + y^2 + z^2 + w^2 - 1"
f2 = "x*y - z*w - a"
box = [[-1.1, 1.1], [-1.1, 1.1], [-1.1, 1.1], [-1.1, 1.1]]
"""
BOX = "box = [[-1.1, 1.1], [-1.1, 1.1], [-1.1, 1.1], [-1.1, 1.1]]"


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_shipped_scene_files_are_registered_and_mesh_cleanly():
    assert not scenes.LOAD_ERRORS
    slice_mesh = scenes.get("sphere-slice").build(resolution=16)
    surface = slice_mesh.surfaces[0]
    x, y, z, w = surface.positions.T
    assert np.max(np.abs(x * x + y * y + z * z + w * w - 1)) < 1e-9
    assert np.max(np.abs(x * y - z * w - 0.25)) < 1e-9
    assert analyse(surface.triangles).boundary_edges == 0
    veronese = scenes.get("veronese").build(resolution=12).surfaces[0]
    vx, vy, vz, vw = veronese.positions.T
    # the Veronese surface satisfies (xy)^2 + ... : its points are images of unit vectors
    assert veronese.info["kind"] == "parametric" and np.all(np.isfinite(veronese.positions))
    assert np.max(np.abs(vx)) <= 0.5 + 1e-9


def test_parameters_reach_the_formulas(tmp_path):
    scene = load_scene_file(write(tmp_path, GOOD))
    surface = scene.build({"a": -0.3}, 12).surfaces[0]
    x, y, z, w = surface.positions.T
    assert np.max(np.abs(x * y - z * w + 0.3)) < 1e-9


@pytest.mark.parametrize(
    "change, key, reason",
    [
        (('name = "slice"', 'name = "Bad Name"'), "name", "lower-case"),
        (('title = "A slice"\n', ""), "title", "missing"),
        (
            ('caption = "For visitors."', 'caption = "For visitors."\ncolour = 1'),
            "colour",
            "unknown key",
        ),
        (("default = 0.25", "default = 0.9"), "parameters.a.default", "outside"),
        (("default = 0.25", 'default = "big"'), "parameters.a.default", "must be a number"),
        (("x*y - z*w - a", "x*y - q"), "surface[0].f2", "unknown name 'q'"),
        (("x*y - z*w - a", "__import__('os')"), "surface[0].f2", "not allowed"),
        (("x*y - z*w - a", "x*y +"), "surface[0].f2", "syntax error"),
        (("[-1.1, 1.1], [-1.1, 1.1]]", "[-1.1, 1.1]]"), "surface[0].box", "must have 4 items"),
        (("box = [[-1.1, 1.1]", "box = [[1.1, -1.1]"), "surface[0].box[0]", "below high"),
        (
            ('name = "slice"\nf1', 'name = "slice"\ncolor = [2, 0, 0]\nf1'),
            "surface[0].color",
            "must lie in [0, 1]",
        ),
        (("[[surface]]", '[[surface]]\npoint = ["s", "t", "0", "0"]'), "surface[0]", "either"),
        (
            (BOX, BOX + "\n[view]\nsensor_distance = -2"),
            "view.sensor_distance",
            "must lie in [0.05",
        ),
        ((BOX, BOX + "\n[view]\nangles = [1, 2]"), "view.angles", "list of 6 numbers"),
    ],
)
def test_mistakes_are_named(tmp_path, change, key, reason):
    old, new = change
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(ExhibitError) as info:
        load_scene_file(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {key}:"), message
    assert reason in message


def test_not_toml_and_missing_surface(tmp_path):
    with pytest.raises(ExhibitError, match="not valid TOML"):
        load_scene_file(write(tmp_path, "name = = 1"))
    with pytest.raises(ExhibitError, match="surface: at least one"):
        load_scene_file(write(tmp_path, GOOD.split("[[surface]]")[0]))
    with pytest.raises(ExhibitError, match="cannot read"):
        load_scene_file(tmp_path / "absent.toml")


def test_a_broken_file_is_skipped_and_reported_not_fatal(tmp_path):
    write(tmp_path, "name = = broken", "broken.toml")
    write(tmp_path, GOOD.replace('"slice"', '"extra-slice"', 1), "extra.toml")
    code = (
        "from exhibit import scenes; print('extra-slice' in scenes.names()); "
        "print(len(scenes.LOAD_ERRORS))"
    )
    env = {"EXHIBIT_SCENE_PATH": str(tmp_path), "PATH": "/usr/bin:/bin"}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    ).stdout.split()
    assert out == ["True", "1"]


@pytest.mark.parametrize("name", ["clifford-torus", "complex-square"])
def test_gallery_scenes(name):
    surface = scenes.get(name).build(resolution=12).surfaces[0]
    report = analyse(surface.triangles)
    if name == "clifford-torus":
        assert (report.euler_characteristic, report.boundary_edges) == (0, 0)
        x, y, z, w = surface.positions.T
        np.testing.assert_allclose(x * x + y * y, 0.5, atol=1e-12)
        np.testing.assert_allclose(z * z + w * w, 0.5, atol=1e-12)
    else:
        assert report.euler_characteristic == 1
        x, y, u, v = surface.positions.T
        np.testing.assert_allclose(u + 1j * v, (x + 1j * y) ** 2, atol=1e-12)


BROKEN = {
    "literal.toml": lambda p: p.write_text(GOOD.replace("x*y - z*w - a", "x + " + "9" * 400)),
    "minus.toml": lambda p: p.write_text(GOOD.replace("x*y - z*w - a", "-" * 999 + "x")),
    "zero.toml": lambda p: p.symlink_to("/dev/zero"),
    "fifo.toml": lambda p: os.mkfifo(p),
    "latin1.toml": lambda p: p.write_bytes(GOOD.replace("slice", "caf\xe9").encode("latin-1")),
    "nested.toml": lambda p: p.write_text("x = " + "[" * 50_000 + "]" * 50_000),
}


def test_broken_scene_files_stop_no_command(tmp_path):
    """A curator's broken files (a 400-digit literal, 999 minus signs, /dev/zero, a FIFO, ...)
    are reported by name; --help, scenes and check-config still answer, promptly."""
    for name, make in BROKEN.items():
        make(tmp_path / name)
    write(tmp_path, GOOD.replace('"slice"', '"extra-slice"', 1), "extra.toml")
    env = {**os.environ, "EXHIBIT_SCENE_PATH": str(tmp_path)}

    def exhibit(*args):
        return subprocess.run(
            [sys.executable, "-m", "exhibit", *args],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )

    assert exhibit("--help").returncode == 0
    listed = exhibit("scenes")
    assert listed.returncode == 0 and "extra-slice" in listed.stdout
    assert "Traceback" not in listed.stderr
    for name in BROKEN:
        assert f"skipped {tmp_path / name}" in listed.stderr, (name, listed.stderr)
    checked = exhibit("check-config")
    assert checked.returncode == 2 and "Traceback" not in checked.stdout + checked.stderr
    for name in BROKEN:
        assert str(tmp_path / name) in checked.stdout, name
    for name in ("literal.toml", "minus.toml"):  # formulas: named by their key
        assert f"{tmp_path / name}: surface[0].f2: " in checked.stdout, checked.stdout


@pytest.mark.parametrize(
    "formula, reason",
    [
        ("x/sin(pi)", "division by zero"),
        ("tan(pi/2) + x", "infinite"),
        ("x + sqrt(-1)", ""),
        ("((x^64)^64)^64", "degree"),
        ("sin(" * 200 + "x" + ")" * 200, ""),
        ("log(-1 - x^2)", ""),
    ],
)
def test_formulas_that_cannot_be_built_are_refused_at_load(tmp_path, formula, reason):
    path = write(tmp_path, GOOD.replace("x*y - z*w - a", formula))
    with pytest.raises(ExhibitError) as info:
        load_scene_file(path)
    assert str(info.value).startswith(f"{path}: surface[0].f2: "), str(info.value)
    assert reason in str(info.value)


def test_a_warm_start_remembers_checked_formulas_and_needs_no_sympy(tmp_path):
    """The box check needs sympy (half a second); a pass is remembered beside the mesh cache."""
    env = {**os.environ, "EXHIBIT_CACHE_DIR": str(tmp_path / "cache")}
    code = (
        "import sys; from exhibit import scenes; scenes.load(); "
        "print('sympy' in sys.modules, len(scenes.problems()))"
    )
    runs = [
        subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        ).stdout.split()
        for _ in range(2)
    ]
    assert runs == [["True", "0"], ["False", "0"]]


def test_a_parameter_that_breaks_a_formula_is_an_error_not_a_crash(tmp_path):
    """Checked at the defaults; a visitor's or curator's value can still divide by zero."""
    path = write(tmp_path, GOOD.replace("x*y - z*w - a", "x/(a - 0.4) - y"))
    scene = load_scene_file(path)
    with pytest.raises(ExhibitError, match=r"surface\[0\].f2: cannot be built .*division by zero"):
        scene.build({"a": 0.4}, resolution=6)  # refused by Scene.resolve (below)
    with pytest.raises(ExhibitError, match=r"surface\[0\]: cannot be built .*division by zero"):
        scene.build_mesh({"a": 0.4}, 6)  # and the build itself still says so


LOG_SCENE = GOOD.replace('name = "slice"\ntitle', 'name = "log-slice"\ntitle', 1).replace(
    "x*y - z*w - a", "x*y - z*w - 0.2*log(a)"
)


@pytest.mark.parametrize(
    "formula, value, reason",
    [
        ("x*y - z*w - 0.2*log(a)", -0.3, "log(a): undefined for this argument"),
        ("x/(a - 0.4) - y", 0.4, "division by zero"),
        ("sqrt(10*a + 3 - x^2 - y^2) - z*w", -0.45, "not a finite real number on 100% of the box"),
    ],
)
def test_parameter_values_are_held_to_the_formulas_own_checks(tmp_path, formula, value, reason):
    """Scene.resolve holds a curator's scene at the values asked for to the check its formulas
    passed at the defaults, so a value the kiosk could not build is refused by name up front."""
    path = write(tmp_path, GOOD.replace("x*y - z*w - a", formula))
    scene = load_scene_file(path)
    with pytest.raises(ExhibitError) as info:
        scene.resolve({"a": value})
    message = str(info.value)
    assert message.startswith(f"slice: scene.toml: surface[0].f2: cannot be built at a = {value:g}")
    assert reason in message
    assert scene.resolve({"a": 0.2}) == {"a": 0.2}  # a value it can be built at passes
    assert scene.resolve() == {"a": 0.25}


def test_check_config_refuses_timeline_params_the_scene_cannot_be_built_with(
    tmp_path, monkeypatch, capsys
):
    """Issue 33: params = { a = -0.5 } for a scene using log(a) passed check-config, then the
    kiosk dropped the scene and its timeline; what check-config accepts, the kiosk runs."""
    from exhibit.cli import main

    folder = tmp_path / "scenes"
    folder.mkdir()
    write(folder, LOG_SCENE, "log-slice.toml")
    attract = tmp_path / "attract"
    attract.mkdir()
    timeline = attract / "01-log.toml"
    keyframes = "[[keyframe]]\nt = 0\n[[keyframe]]\nt = 10\nangles = [30, 0, 0, 0, 0, 0]\n"
    site = tmp_path / "kiosk.toml"
    site.write_text(
        '[attract]\ntimelines = "attract"\n[content]\nscenes = ["log-slice"]\n'
        'start_scene = "log-slice"\n[languages]\nshown = ["en"]\n'
    )
    monkeypatch.setenv("EXHIBIT_SCENE_PATH", str(folder))
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    scenes.load(reload=True)
    try:
        timeline.write_text('scene = "log-slice"\nparams = { a = -0.45 }\n' + keyframes)
        assert main(["check-config", str(site)]) == 2
        out = capsys.readouterr().out
        assert (
            f"{timeline}: params: log-slice: log-slice.toml: surface[0].f2: cannot be built at "
            "a = -0.45: column 17: log(a): undefined for this argument" in out
        ), out
        timeline.write_text('scene = "log-slice"\nparams = { a = 0.3 }\n' + keyframes)
        assert main(["check-config", str(site)]) == 0, capsys.readouterr().out
        scene = scenes.get("log-slice")
        assert scene.build({"a": 0.3}, 8).surfaces[0].positions.size  # and it builds
    finally:
        monkeypatch.delenv("EXHIBIT_SCENE_PATH")
        scenes.load(reload=True)
