"""The kiosk config: the shipped one is valid; each kind of mistake is named with file, key and
reason, every problem at once, exit code 2."""

import shutil
from pathlib import Path

import pytest

from exhibit.cli import main
from exhibit.kiosk.config import ConfigError, load_kiosk_config
from tests.kiosk.support import edit

CONFIGS = Path(__file__).resolve().parents[2] / "configs"


@pytest.fixture
def tree(tmp_path):
    """A copy of configs/ to break."""
    shutil.copytree(CONFIGS, tmp_path / "configs")
    return tmp_path / "configs"


def test_shipped_config_is_valid():
    config = load_kiosk_config(CONFIGS / "kiosk.toml")
    assert config.start_scene in config.scenes and config.quit_keys
    assert config.reduced_motion is False


def test_reduced_motion_is_read_from_a_site_file(tmp_path, capsys):
    site = tmp_path / "site.toml"
    site.write_text("[accessibility]\nreduced_motion = true\n")
    config = load_kiosk_config(site)
    assert config.reduced_motion is True
    assert config.sources["accessibility.reduced_motion"] == (True, site)
    assert main(["check-config", str(site)]) == 0
    site.write_text('[accessibility]\nreduced_motion = "yes"\n')
    assert main(["check-config", str(site)]) == 2
    assert (
        f"{site}: accessibility.reduced_motion: must be true or false, got 'yes'"
        in capsys.readouterr().out
    )


KIOSK = [
    ("fullscreen = true ", "fullscreen = 1 ", "display.fullscreen", "true or false"),
    ("monitor = 0 ", "monitor = -1 ", "display.monitor", "must lie in"),
    ("size = [1280, 720]", "size = [1280]", "display.size", "list of 2 whole numbers"),
    ("samples = 4 ", "samples = 4.5 ", "display.samples", "whole number"),
    ("fps_limit = 60 ", "fps_limit = 1000 ", "display.fps_limit", "must lie in"),
    ("[display]", "[display]\nbrightness = 3", "display.brightness", "unknown key"),
    ("[content]", "[screen]\nx = 1\n[content]", "screen", "unknown key"),
    ('start_scene = "hopf"', 'start_scene = "sun"', "content.start_scene", "not one of"),
    ('scenes = ["hopf",', 'scenes = ["moon", "hopf",', "content.scenes", "no scene named 'moon'"),
    ("resolution = { hopf = 48", "resolution = { hopf = 2", "content.resolution.hopf", "[4, 512]"),
    (
        'config = "devices/default.toml"',
        'config = "devices/absent.toml"',
        "devices.config",
        "does not exist",
    ),
    ('timelines = "attract"', 'timelines = "nowhere"', "attract.timelines", "does not exist"),
    ("idle_timeout_s = 90 ", "idle_timeout_s = 1 ", "attract.idle_timeout_s", "must lie in"),
    ("blend_s = 2.0 ", 'blend_s = "slow" ', "attract.blend_s", "a number"),
    ("drift_px = 12 ", "drift_px = 1e9 ", "burn_in.drift_px", "must lie in"),
    ('quit_keys = "ctrl+alt+shift+q"', 'quit_keys = "q"', "maintenance.quit_keys", "at least two"),
    ('level = "auto" ', 'level = "ultra" ', "quality.level", 'one of "auto", "msaa"'),
    ('lowest = "auto" ', "lowest = 3 ", "quality.lowest", "must be one of"),
    (
        'antialiasing = "auto" ',
        'antialiasing = "smaa" ',
        "quality.antialiasing",
        'one of "auto", "msaa", "fxaa", "none"',
    ),
    (
        "caption_cap_height = 0.024",
        "caption_cap_height = 0.02",
        "text.caption_cap_height",
        "from 1/45 (0.0222: 24 px at 1080p",
    ),
    (
        "title_cap_height = 0.034",
        "title_cap_height = 0.023",
        "text.title_cap_height",
        "must be larger than text.caption_cap_height (0.024), got 0.023",
    ),
    ("infinity_beyond = 1000", "infinity_beyond = 0", "text.infinity_beyond", "must lie in"),
    ('mesh = "auto" ', 'mesh = "tiny" ', "quality.mesh", "must be one of"),
    ('effects = "auto" ', 'effects = "none" ', "quality.effects", "must be one of"),
    (
        'render_scale = "auto" ',
        "render_scale = 0.1 ",
        "quality.render_scale",
        'must be "auto" or a number in [0.25, 1]',
    ),
    ('render_scale = "auto" ', "render_scale = nan ", "quality.render_scale", "must be"),
    ('target_fps = "auto" ', "target_fps = 1000 ", "quality.target_fps", "[10, 240]"),
    ("step_interval_s = 4 ", "step_interval_s = 0 ", "quality.step_interval_s", "must lie in"),
    ("calm_s = 1.5 ", "calm_s = -1 ", "quality.calm_s", "must lie in"),
    ("headroom = 0.7 ", "headroom = 1.5 ", "quality.headroom", "must lie in"),
    ("[quality]", "[quality]\nsharpness = 2", "quality.sharpness", "unknown key"),
    (
        "reduced_motion = false ",
        'reduced_motion = "yes" ',
        "accessibility.reduced_motion",
        "must be true or false, got 'yes'",
    ),
    (
        "reduced_motion = false ",
        "reduced_motion = 1 ",
        "accessibility.reduced_motion",
        "must be true or false, got 1",
    ),
    (
        "[accessibility]",
        "[accessibility]\nlarge_text = true",
        "accessibility.large_text",
        "unknown key",
    ),
]


@pytest.mark.parametrize("old, new, key, reason", KIOSK, ids=[k[2] for k in KIOSK])
def test_kiosk_mistakes(tree, old, new, key, reason):
    edit(tree / "kiosk.toml", old, new)
    with pytest.raises(ConfigError) as info:
        load_kiosk_config(tree / "kiosk.toml")
    assert any(
        p.startswith(f"{tree / 'kiosk.toml'}: {key}") and reason in p for p in info.value.problems
    ), info.value.problems


LINKED = [
    (
        "attract/01-hypersphere.toml",
        'scene = "hopf"',
        'scene = "sun"',
        "scene",
        "no scene named 'sun'",
    ),
    (
        "attract/01-hypersphere.toml",
        "t = 7\n",
        "t = -7\n",
        "keyframe[1].t",
        "must lie in [0, 86400]",
    ),
    ("attract/01-hypersphere.toml", "t = 15\n", "t = 5\n", "keyframe[2].t", "later than"),
    (
        "attract/01-hypersphere.toml",
        "sensor_distance = 3\n",
        "sensor_distance = -3\n",
        "keyframe[2].sensor_distance",
        "must lie in [0.05",
    ),
    (
        "attract/01-hypersphere.toml",
        'caption = "Closer still."',
        'caption = "Closer still."\nease = "bounce"',
        "keyframe[5].ease",
        "'smooth', 'linear' or 'hold'",
    ),
    (
        "attract/01-hypersphere.toml",
        'preset = "figure-6"',
        'preset = "figure-60"',
        "preset",
        "no preset",
    ),
    ("attract/05-collision-16.toml", "rs = 0.7", "rs = -0.7", "params", "must lie in"),
    (
        "attract/01-hypersphere.toml",
        "angles = [0, 0, 0, 20, 0, 0]",
        "angles = [0, 20]",
        "keyframe[1].angles",
        "list of 6 numbers",
    ),
]


@pytest.mark.parametrize("file, old, new, key, reason", LINKED, ids=[k[3] for k in LINKED])
def test_linked_file_mistakes(tree, file, old, new, key, reason):
    edit(tree / file, old, new)
    with pytest.raises(ConfigError) as info:
        load_kiosk_config(tree / "kiosk.toml")
    assert any(
        p.startswith(f"{tree / file}: {key}") and reason in p for p in info.value.problems
    ), info.value.problems


def test_a_bad_device_config_is_reported(tree):
    edit(tree / "devices/default.toml", 'url = "keyboard://"', 'url = "telepathy://"')
    with pytest.raises(ConfigError) as info:
        load_kiosk_config(tree / "kiosk.toml")
    assert any("telepathy" in p for p in info.value.problems)


def test_not_toml_and_unreadable(tree):
    (tree / "kiosk.toml").write_text("[display\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_kiosk_config(tree / "kiosk.toml")
    with pytest.raises(ConfigError, match="cannot read"):
        load_kiosk_config(tree / "absent.toml")


def test_every_problem_is_reported_at_once(tree, capsys):
    edit(tree / "kiosk.toml", "monitor = 0 ", "monitor = -1 ")
    edit(tree / "kiosk.toml", "blend_s = 2.0 ", "blend_s = -2.0 ")
    assert main(["check-config", str(tree / "kiosk.toml")]) == 2
    out = capsys.readouterr().out
    assert "display.monitor" in out and "attract.blend_s" in out and "2 problem(s)" in out


def test_environment_overrides_paths(tree, monkeypatch, tmp_path):
    monkeypatch.setenv("EXHIBIT_ATTRACT_DIR", str(tmp_path / "elsewhere"))
    with pytest.raises(ConfigError, match=r"attract.timelines \(from \$EXHIBIT_ATTRACT_DIR\)"):
        load_kiosk_config(tree / "kiosk.toml")
    monkeypatch.delenv("EXHIBIT_ATTRACT_DIR")
    monkeypatch.setenv("EXHIBIT_CONFIG", str(tree / "kiosk.toml"))
    assert load_kiosk_config().path == tree / "kiosk.toml"


def test_run_refuses_a_bad_config_without_traceback(tree, cli):
    edit(tree / "kiosk.toml", "monitor = 0 ", "monitor = -1 ")
    result = cli("run", "--config", str(tree / "kiosk.toml"))
    assert result.returncode == 2
    assert "display.monitor" in result.stderr and "Traceback" not in result.stderr


# ---- layered site configuration -------------------------------------------------------------


def test_a_site_file_of_one_key_changes_only_that_key(tmp_path, capsys):
    site = tmp_path / "kiosk.toml"
    site.write_text("[display]\nmonitor = 1\n")
    shipped = load_kiosk_config(CONFIGS / "kiosk.toml")
    config = load_kiosk_config(site)
    assert config.monitor == 1 and config.site == site
    assert (config.scenes, config.resolution, config.quit_keys, config.devices_config) == (
        shipped.scenes,
        shipped.resolution,
        shipped.quit_keys,
        shipped.devices_config,
    )
    assert main(["check-config", str(site)]) == 0
    assert "over the shipped defaults" in capsys.readouterr().out


def test_tables_merge_key_by_key(tmp_path):
    site = tmp_path / "kiosk.toml"
    site.write_text("[content]\nresolution = { hopf = 32 }\n")
    assert load_kiosk_config(site).resolution == {"hopf": 32, "collision": 40}


def test_relative_paths_resolve_against_the_naming_file_else_the_shipped_files(tmp_path):
    (tmp_path / "museum-devices.toml").write_text('[devices.k]\nurl = "keyboard://"\n')
    site = tmp_path / "kiosk.toml"
    site.write_text(
        '[devices]\nconfig = "museum-devices.toml"\n[attract]\ntimelines = "attract"\n'
    )  # not here: the shipped folder
    config = load_kiosk_config(site)
    assert config.devices_config == tmp_path / "museum-devices.toml"
    assert config.attract_dir == CONFIGS / "attract"


def test_problems_name_the_file_that_holds_the_key(tmp_path):
    site = tmp_path / "kiosk.toml"
    site.write_text("[display]\nmonitor = 99\n[burn_in]\ncolour = 1\n")
    with pytest.raises(ConfigError) as info:
        load_kiosk_config(site)
    assert f"{site}: display.monitor: must lie in [0, 16], got 99" in info.value.problems
    assert any(p.startswith(f"{site}: burn_in.colour: unknown key") for p in info.value.problems)


def test_show_prints_every_effective_value_with_its_file(tmp_path, capsys):
    site = tmp_path / "kiosk.toml"
    site.write_text("[attract]\nidle_timeout_s = 30\n")
    assert main(["check-config", str(site), "--show"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(
        line.startswith("attract.idle_timeout_s = 30 ") and line.endswith(f"# {site}")
        for line in lines
    ), lines
    assert any(
        line.startswith("display.vsync = true ")
        and line.endswith("kiosk.toml")
        and str(site) not in line
        for line in lines
    )
    assert any(line.startswith("devices.config = ") for line in lines)


def test_etc_exhibit_is_the_default_site_file(tmp_path, monkeypatch):
    from exhibit.kiosk import config as kiosk_config

    site = tmp_path / "etc-kiosk.toml"
    site.write_text("[display]\nsamples = 0\n")
    monkeypatch.delenv("EXHIBIT_CONFIG", raising=False)
    monkeypatch.setattr(kiosk_config, "SITE_CONFIG", site)
    assert load_kiosk_config().samples == 0
    monkeypatch.setattr(kiosk_config, "SITE_CONFIG", tmp_path / "absent.toml")
    assert load_kiosk_config().site is None


def test_device_commands_read_the_kiosk_config(tmp_path, cli):
    (tmp_path / "museum-devices.toml").write_text('[devices.only-keys]\nurl = "keyboard://"\n')
    site = tmp_path / "kiosk.toml"
    site.write_text('[devices]\nconfig = "museum-devices.toml"\n')
    for args, env in ((["--config", str(site)], {}), ([], {"EXHIBIT_CONFIG": str(site)})):
        import json
        import os
        import subprocess
        import sys

        result = subprocess.run(
            [sys.executable, "-m", "exhibit", "devices", "--json", "--wait", "0", *args],
            capture_output=True,
            text=True,
            env={**os.environ, **env},
        )
        assert result.returncode == 0, result.stderr
        names = [d["name"] for d in json.loads(result.stdout)["configured"]]
        assert names == ["only-keys"]


def test_quality_pins(tree):
    edit(tree / "kiosk.toml", 'antialiasing = "auto" ', 'antialiasing = "none" ')
    edit(tree / "kiosk.toml", 'mesh = "auto" ', 'mesh = "reduced" ')
    edit(tree / "kiosk.toml", 'render_scale = "auto" ', "render_scale = 0.8 ")
    edit(tree / "kiosk.toml", 'target_fps = "auto" ', "target_fps = 30 ")
    q = load_kiosk_config(tree / "kiosk.toml").quality
    assert (q.antialiasing_pin, q.mesh_pin, q.effects_pin, q.scale_pin, q.target_fps) == (
        "none",
        1,
        None,
        0.8,
        30.0,
    )
    assert q.level == "auto" and q.step_interval_s == 4.0


def test_quality_levels_are_the_renderers():
    from exhibit.kiosk.config import MESH_LEVELS, QUALITY_LEVELS
    from exhibit.render.quality import LEVEL_NAMES, MESH_FACTORS

    assert QUALITY_LEVELS == LEVEL_NAMES and len(MESH_LEVELS) == len(MESH_FACTORS)


def test_text_sizes_reach_the_renderer(tmp_path):
    """[text] in a site file changes the sizes the HUD draws; the config layer's floor is the
    layout's (1/45 of the screen height), and its defaults are the renderer's."""
    from exhibit.kiosk.config import MIN_CAPTION_CAP, TextConfig
    from exhibit.render import layout

    assert MIN_CAPTION_CAP == layout.MIN_CAPTION_CAP
    defaults = layout.TextSizes()
    assert TextConfig() == TextConfig(
        defaults.caption_cap, defaults.title_cap, defaults.infinity_beyond
    )
    site = tmp_path / "site.toml"
    site.write_text("[text]\ncaption_cap_height = 0.03\ntitle_cap_height = 0.05\n")
    config = load_kiosk_config(site, check_linked=False)
    assert config.text == TextConfig(0.03, 0.05, 1000.0)


def _broken_site_files(tmp_path):
    """A dangling symlink, a symlink loop, and a file that cannot be opened (root reads any
    file, so its opening is refused by a stand-in)."""
    (tmp_path / "dangling.toml").symlink_to(tmp_path / "nowhere.toml")
    (tmp_path / "loop.toml").symlink_to(tmp_path / "loop.toml")
    return {"dangling": tmp_path / "dangling.toml", "loop": tmp_path / "loop.toml"}


@pytest.mark.parametrize("kind", ["dangling", "loop"])
@pytest.mark.parametrize("how", ["etc", "env", "argument"])
def test_a_site_file_that_cannot_be_read_is_an_error_not_the_defaults(
    tmp_path, monkeypatch, capsys, kind, how
):
    from exhibit.kiosk import config as kiosk_config

    site = _broken_site_files(tmp_path)[kind]
    monkeypatch.delenv("EXHIBIT_CONFIG", raising=False)
    args = ["check-config"]
    if how == "etc":
        monkeypatch.setattr(kiosk_config, "SITE_CONFIG", site)
    elif how == "env":
        monkeypatch.setenv("EXHIBIT_CONFIG", str(site))
    else:
        args.append(str(site))
    assert main(args) == 2
    out = capsys.readouterr().out
    assert out.startswith(f"{site}: cannot read: "), out
    assert "OK" not in out and "internal error" not in out
    if kind == "dangling":
        assert "which does not exist" in out
    # exhibit run refuses it too, with one line per problem and exit 2, before any window
    run_args = ["run", "--windowed", "--duration", "1"]
    if how == "argument":
        run_args += ["--config", str(site)]
    assert main(run_args) == 2
    captured = capsys.readouterr()
    assert f"{site}: cannot read: " in captured.err + captured.out
    assert "Traceback" not in captured.err and "internal error" not in captured.err


def test_an_unreadable_site_file_is_an_error(tmp_path, monkeypatch, capsys):
    from exhibit.kiosk import config as kiosk_config
    from exhibit.schema import files

    site = tmp_path / "kiosk.toml"
    site.write_text("[display]\nsamples = 0\n")
    real_open = files.os.open

    def refuse(path, *args, **kwargs):
        if str(path) == str(site):
            raise PermissionError(13, "Permission denied")
        return real_open(path, *args, **kwargs)

    monkeypatch.delenv("EXHIBIT_CONFIG", raising=False)
    monkeypatch.setattr(kiosk_config, "SITE_CONFIG", site)
    monkeypatch.setattr(files.os, "open", refuse)
    assert main(["check-config"]) == 2
    assert f"{site}: cannot read: Permission denied" in capsys.readouterr().out


def test_a_start_scene_conflict_is_reported_against_the_site_file(tmp_path, capsys):
    site = tmp_path / "kiosk.toml"
    site.write_text('[content]\nscenes = ["collision"]\n')
    assert main(["check-config", str(site)]) == 2
    out = capsys.readouterr().out
    assert (
        f"{site}: content.scenes: does not include the start scene 'hopf' (the shipped "
        "default of content.start_scene)"
    ) in out, out
    assert str(CONFIGS / "kiosk.toml") + ":" not in out
    site.write_text('[content]\nstart_scene = "nothing-like-it"\n')
    assert main(["check-config", str(site)]) == 2
    out = capsys.readouterr().out
    assert f"{site}: content.start_scene: 'nothing-like-it' is not one of content.scenes" in out
    site.write_text('[content]\nscenes = ["collision"]\nstart_scene = "collision"\n')
    assert main(["check-config", str(site)]) == 0
