"""`exhibit render` and `exhibit bench render`: outputs, and one-line errors with exit code 2."""

import json

import pytest
from PIL import Image

from exhibit.cli import main
from exhibit.render.quality import software_renderer


@pytest.mark.parametrize(
    "argv, message",
    [
        (["render", "--out", "x.png"], "name a scene or give --figure"),
        (["render", "hopf", "--figure", "6", "--out", "x.png"], "not both"),
        (["render", "nope", "--out", "x.png"], "no scene named 'nope'"),
        (["render", "--figure", "5", "--out", "x.png"], "no figure 5"),
        (["render", "--figure", "six", "--out", "x.png"], "not a whole number"),
        (["render", "hopf", "--size", "640", "--out", "x.png"], "WIDTHxHEIGHT"),
        (["render", "hopf", "--angles", "1,2,3", "--out", "x.png"], "expected 6"),
        (["render", "hopf", "--eye", "10,x", "--out", "x.png"], "'x' is not a number"),
        (["render", "hopf", "--sensor-distance", "-2", "--out", "x.png"], "must lie in [0.05"),
        (["render", "hopf", "--param", "axis_length", "--out", "x.png"], "not NAME=VALUE"),
        (["render", "hopf", "--param", "radius=2", "--out", "x.png"], "no parameter 'radius'"),
        (["render", "hopf", "--out", "x.jpg"], "must end in .png"),
        (["render", "hopf", "--out", "/no/such/dir/x.png"], "does not exist"),
        (["render", "hopf"], "--out FILE is required"),
        (["bench", "render", "--triangles", "lots"], "not a count"),
    ],
)
def test_bad_arguments_get_one_line_and_exit_2(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_render_writes_the_png(gl, tmp_path, capsys):
    out = tmp_path / "hopf.png"
    assert (
        main(
            [
                "render",
                "hopf",
                "--size",
                "160x120",
                "--resolution",
                "8",
                "--angles",
                "10,-20,-30,0,0,5",
                "--sensor-distance",
                "3",
                "--eye",
                "20,-60",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    with Image.open(out) as image:
        assert image.size == (160, 120)
    assert capsys.readouterr().out.strip() == str(out)


@pytest.mark.parametrize("name", ["frames", "sweep.gif"])
def test_animation_frames_and_gif(gl, tmp_path, name):
    out = tmp_path / name
    assert (
        main(
            [
                "render",
                "hopf",
                "--frames",
                "3",
                "--size",
                "96x72",
                "--resolution",
                "8",
                "--no-hud",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    if name.endswith(".gif"):
        with Image.open(out) as gif:
            assert gif.n_frames == 3
    else:
        frames = sorted(out.glob("frame_*.png"))
        assert len(frames) == 3
        # The sensor moves in from infinity to 2: the pictures differ.
        with Image.open(frames[0]) as first, Image.open(frames[-1]) as last:
            assert first.tobytes() != last.tobytes()


def test_bench_json_keys(gl, capsys):
    assert (
        main(["bench", "render", "--json", "--size", "96x72", "--triangles", "1k", "--frames", "3"])
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    assert report["size"] == [96, 72] and report["renderer"]
    (row,) = report["results"]
    assert set(row) >= {
        "triangles",
        "pipeline_ms",
        "cpu_baseline_ms",
        "floor_ms",
        "sheets_ms",
        "intersections_ms",
        "sliced_frame_ms",
        "slice_ms",
        "inset_cpu_ms",
        "inset_gpu_ms",
    }
    # intersections_ms and slice_ms are differences of two medians: noise can make them <= 0.
    differences = {"intersections_ms", "slice_ms"}
    assert row["triangles"] > 500 and all(row[k] > 0 for k in row if k not in differences)


def test_bench_kiosk_json(gl):
    """In a child process, as staff run it (a second EGL context created and released in this
    process can crash Mesa when the suite's own context draws multisampled again)."""
    import subprocess
    import sys

    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "exhibit",
            "bench",
            "kiosk",
            "--json",
            "--size",
            "160x90",
            "--frames",
            "3",
            "--scenes",
            "hopf",
            "--levels",
            "fxaa,scale-50",
            "--ssim",
            "--breakdown",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["size"] == [160, 90] and report["renderer"]
    assert [level["name"] for level in report["levels"]] == ["fxaa", "scale-50"]
    for level in report["levels"]:
        assert set(level) >= {"name", "frame_ms", "floor_ms", "antialiasing", "triangles"}
        assert level["frame_ms"] > 0 and level["floor_ms"] > 0 and level["triangles"] > 100
    used = [level["name"] for level in report["levels"] if level["used_here"]]
    assert report["chosen"] in used
    if software_renderer(report["renderer"]):  # no render scales below 1 on software GL
        assert used == ["fxaa"]
    assert 0.5 < report["levels"][0]["ssim"] <= 1 and "ssim_edges" in report["no_antialiasing"]
    assert report["pass_timer"] in ("wall", "gpu")
    fxaa, scaled = report["levels"]  # each level's frame, pass by pass
    scene_passes = ["clear", "surfaces", "intersections", "outlines", "curves", "marks"]
    assert list(fxaa["passes"]) == [*scene_passes, "composite", "hud", "other"]
    assert list(scaled["passes"]) == ["clear", "surfaces", "outlines", "curves", "marks"] + [
        "composite",
        "hud",
        "other",
    ]
    assert fxaa["passes"]["surfaces"] > 0 and fxaa["passes_total_ms"] > 0
    assert fxaa["scenes"]["hopf"]["passes"] == fxaa["passes"]


def test_bench_kiosk_bad_level(capsys):
    assert main(["bench", "kiosk", "--levels", "ultra"]) == 2
    assert "no level 'ultra'" in capsys.readouterr().err
