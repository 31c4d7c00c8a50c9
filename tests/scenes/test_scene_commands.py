"""`exhibit scenes`, `inspect`, `collide` and `silhouette` as installers and curators use them."""

import json

import pytest

from exhibit.cli import main
from exhibit.scenes import collision


def run_json(capsys, *args):
    assert main(list(args)) == 0
    return json.loads(capsys.readouterr().out)


def test_scenes_json_lists_names_titles_parameters(capsys):
    listing = run_json(capsys, "scenes", "--json")["scenes"]
    names = {s["name"] for s in listing}
    assert {"hopf", "offset-parabola", "offset-cusp", "collision"} <= names
    collision_entry = next(s for s in listing if s["name"] == "collision")
    assert [p["name"] for p in collision_entry["parameters"]] == ["rc", "rs", "vc", "vs"]
    assert all(s["title"] and s["caption"] for s in listing)


def test_inspect_reports_every_key(capsys):
    parts = run_json(
        capsys,
        "inspect",
        "collision",
        "--param",
        "rs=0.7",
        "--param",
        "vc=0.2",
        "--resolution",
        "16",
        "--json",
    )["parts"]
    keys = {
        "name",
        "kind",
        "vertices",
        "triangles",
        "components",
        "euler_characteristic",
        "boundary_edges",
        "nonmanifold_edges",
        "max_residual",
        "singular_points",
        "seconds",
        "boundary_box_distance",
        "singular_gap",
        "box_diagonal",
        "max_vertex_distance",
        "max_sag",
        "lemma2_exclusion",
    }
    assert set(parts[0]) == keys
    assert parts[0]["boundary_box_distance"] == 0.0  # closed
    assert parts[0]["components"] == 2 and parts[0]["euler_characteristic"] == 4
    assert parts[0]["max_residual"] <= 1e-9 and parts[0]["boundary_edges"] == 0


@pytest.mark.parametrize("figure, components", [(15, 1), (16, 2), (17, 1)])
def test_collide_matches_the_paper_and_the_closed_form(capsys, figure, components):
    p = collision.FIGURE_PARAMS[figure]
    out = run_json(
        capsys,
        "collide",
        "--rc",
        str(p["rc"]),
        "--rs",
        str(p["rs"]),
        "--vc",
        str(p["vc"]),
        "--vs",
        str(p["vs"]),
        "--resolution",
        "24",
        "--json",
    )
    expected = collision.initial_colliding_point_closed_form(p)
    for key in ("t", "x", "y", "z"):
        assert out["colliding_point"][key] == pytest.approx(expected[key], abs=1e-8)
    assert out["components"] == components


def test_silhouette_json_gives_the_offset_curve(capsys):
    out = run_json(
        capsys, "silhouette", "offset-parabola", "--along", "u,v", "--resolution", "20", "--json"
    )
    assert out["axes"] == ["x", "y", "u", "v"]
    assert len(out["curves"]) >= 2
    assert all(len(point) == 4 for curve in out["curves"] for point in curve)


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["inspect", "nowhere"], "no scene named 'nowhere'"),
        (["inspect", "hopf", "--param", "radius=2"], "no parameter 'radius'"),
        (["inspect", "hopf", "--param", "axis_length"], "NAME=VALUE"),
        (["inspect", "hopf", "--resolution", "big"], "whole number"),
        (["inspect", "collision", "--param", "rs=-1"], "must lie in"),
        (["collide", "--rc", "1", "--rs", "x", "--vc", "0", "--vs", "1"], "--rs must be a number"),
        (["collide", "--rc", "1", "--rs", "1", "--vc", "0", "--vs", "0"], "nothing moves"),
        *[
            (
                [command, "collision", *extra, "--param", "vc=0", "--param", "vs=0"],
                "collision: vc and vs cannot both be 0",
            )
            for command, extra in (
                ("inspect", []),
                ("slice", ["--axis", "t", "--at", "0"]),
                ("render", []),
                ("silhouette", ["--along", "x,y"]),
            )
        ],
        (["silhouette", "offset-parabola", "--along", "u,q"], "'q' is not an axis"),
        (["silhouette", "offset-parabola", "--along", "u"], "two different axis names"),
    ],
)
def test_bad_input_gets_one_line_and_exit_2(cli, args, fragment):
    result = cli(*args)
    assert result.returncode == 2, result.stderr
    assert fragment in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("resolution", ["16", "24"])
def test_inspect_reports_the_cut_and_the_singular_gap_of_the_cusp(capsys, resolution):
    """The pipe of y² = x³ leaves its box (cut exactly on the faces) and pinches along a circle
    of singular points (the mesh reaches it to 0.5% of the box diagonal)."""
    part = run_json(capsys, "inspect", "offset-cusp", "--resolution", resolution, "--json")[
        "parts"
    ][0]
    assert part["boundary_edges"] > 0 and part["boundary_box_distance"] <= 1e-9
    assert 0 <= part["singular_gap"] <= 0.005 * part["box_diagonal"]


def test_silhouette_json_reports_the_refinement(capsys):
    out = run_json(
        capsys, "silhouette", "offset-cusp", "--along", "u,v", "--resolution", "20", "--json"
    )
    assert out["refined"] > 100 and out["excluded"] > 0 and out["dropped"] >= 0
    assert 0 < out["max_residual"] <= 1e-9


def test_a_timeline_of_a_collision_with_nothing_moving_is_refused_by_file_and_key(tmp_path, capsys):
    """vc = vs = 0 lie in their ranges, but give no collision surface (the closed form divides
    by the speed): the timeline is refused at load, so check-config names it and the kiosk
    never builds it."""
    from exhibit.errors import ConfigError
    from exhibit import scenes
    from exhibit.timelines.file import load_timeline

    attract = tmp_path / "attract"
    attract.mkdir()
    path = attract / "still.toml"
    path.write_text(
        'scene = "collision"\nparams = { vc = 0, vs = 0 }\n'
        "[[keyframe]]\nt = 0\n[[keyframe]]\nt = 10\n"
    )
    with pytest.raises(ConfigError) as caught:
        load_timeline(path, scenes.get)
    assert caught.value.problems == [
        f"{path}: params: collision: vc and vs cannot both be 0: with no motion the cylinder "
        "and sphere never move, so there is no collision surface"
    ]
    site = tmp_path / "kiosk.toml"
    site.write_text(f'[attract]\ntimelines = "{attract}"\n')
    assert main(["check-config", str(site)]) == 2
    assert f"{path}: params: collision: vc and vs cannot both be 0" in capsys.readouterr().out


@pytest.mark.parametrize(
    "command",
    [
        ["inspect"],
        ["slice", "--axis", "w", "--at", "0"],
        ["silhouette", "--along", "x,y"],
        ["render"],
    ],
)
def test_a_scene_whose_file_failed_to_load_says_why(cli, tmp_path, monkeypatch, command):
    """Every command that takes a scene name (through scenes.get) says why a scene file of
    that name did not load, as `exhibit scenes` does, not just "no scene named"."""
    (tmp_path / "broken-scene.toml").write_text('name = "broken-scene"\ntitle = \n')
    (tmp_path / "misnamed.toml").write_text('name = "renamed"\ntitle = "A scene"\n')
    monkeypatch.setenv("EXHIBIT_SCENE_PATH", str(tmp_path))
    result = cli(command[0], "broken-scene", *command[1:])
    assert result.returncode == 2, result.stderr
    assert (
        f"scene 'broken-scene' failed to load: {tmp_path / 'broken-scene.toml'}: not valid "
        "TOML" in result.stderr
    )
    assert "Traceback" not in result.stderr and len(result.stderr.strip().splitlines()) == 1
    if command[0] == "inspect":  # named inside the file, not by the file's name
        result = cli("inspect", "renamed")
        assert result.returncode == 2
        assert f"scene 'renamed' failed to load: {tmp_path / 'misnamed.toml'}: " in result.stderr
        assert "Traceback" not in result.stderr


SCALES = (1e-6, 1e-3, 1.0, 1e3, 1e6)


@pytest.mark.parametrize("vc, vs", [(1.0, 1.0), (0.0, 1.0), (-5.0, 0.1), (5.0, -5.0), (1e-6, 0.0)])
@pytest.mark.parametrize("rc", SCALES)
def test_collide_finds_first_contact_at_every_scale(capsys, rc, vc, vs):
    """Moving bodies always touch: over twelve decades of radii and the speeds' range the
    command gives the closed form's first contact (it said "never touch" for rc = 1e-6,
    rs = 1e6, where the closed form has t0 = -707106.8)."""
    for rs in SCALES:
        p = {"rc": rc, "rs": rs, "vc": vc, "vs": vs}
        out = run_json(
            capsys,
            "collide",
            *[f"--{k}={v!r}" for k, v in p.items()],
            "--resolution",
            "8",
            "--json",
        )
        expected = collision.initial_colliding_point_closed_form(p)
        point = out["colliding_point"]
        assert point is not None, p
        assert point["t"] == pytest.approx(expected["t"], rel=1e-9), p
        for key in ("x", "y", "z"):
            assert point[key] == pytest.approx(expected[key], rel=1e-9, abs=1e-9 * (rc + rs)), (
                p,
                key,
            )
