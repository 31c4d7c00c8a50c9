"""Whatever `exhibit check-config` accepts, the kiosk can run; whatever it refuses is named.

Hypothesis puts hostile values (NaN, inf, 1e-320, 1e308, huge integers, wrong types) into each
key of the kiosk config, the device config and an attract timeline. Each case either fails to
load with ``file: key: reason`` lines naming that file, or loads, and then the kiosk's own logic
(the attract/visitor state, the mapping and the clip transform, without a window) runs through
a minute of visitors turning every control and pressing every button, with every frame finite.
The file-type cases (FIFO, /dev/zero, folder, huge, not UTF-8, nested too deep) go through every
loader and must be refused promptly, by name.
"""

from __future__ import annotations

import math
import os
import shutil
import threading
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from exhibit.devices.base import DeviceError, Event, Kind
from exhibit.devices.config import load_config
from exhibit.devices.hid import load_layout
from exhibit.devices.mapping import ActivityDetector, Mapper
from exhibit.devices.replay import read_recording
from exhibit.errors import ConfigError, ExhibitError
from exhibit.geometry.pipeline import clip_transform
from exhibit import scenes
from exhibit.timelines.file import load_playlist, load_timeline
from exhibit.timelines.playlist import Playlist
from exhibit.kiosk.config import load_kiosk_config
from exhibit.kiosk.state import KioskState
from exhibit.scenes.toml_scene import load_scene_file
from tests.hypothesis_profiles import examples

CONFIGS = Path(__file__).resolve().parents[2] / "configs"

NASTY = [
    math.nan,
    math.inf,
    -math.inf,
    1e-320,
    -1e-320,
    1e308,
    -1e308,
    0,
    -0.0,
    1,
    -1,
    0.5,
    2**63,
    -(2**63),
    10**400,
    "inf",
    "nan",
    "",
    "x" * 5000,
    True,
    False,
    [],
    {},
    [1, 2],
    [math.nan] * 6,
    [1e308] * 6,
    [0] * 6,
    [1e-320] * 6,
    ["inf"] * 2,
    {"a": 1},
]
#: Values at the limits, which must be accepted and run.
EDGES = [
    0.05,
    0.2,
    0.95,
    1.0,
    5,
    20,
    180,
    -180,
    1440,
    3600,
    -3600,
    1e6,
    1e-3,
    86400,
    16,
    512,
    [3600] * 6,
    [-3600, 3600],
    [180, -180, 0, 0, 0, 0],
    [0, 0.05],
    "ctrl+alt+shift+q",
    "super+alt+f12",
    "hold",
    "linear",
    "axis 1",
    "delta 2",
    "sensor",
    "theta6",
]
ACCEPTED: list[str] = []


def toml_value(value) -> str:
    """A Python value as TOML text (NaN and inf as TOML's own nan and inf)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


values = st.one_of(
    st.sampled_from(NASTY),
    st.sampled_from(EDGES),
    st.floats(),
    st.integers(-(10**6), 10**6),
    st.lists(st.floats(allow_nan=True), max_size=7),
)

KIOSK_KEYS = [
    ("display", "monitor"),
    ("display", "size"),
    ("display", "samples"),
    ("display", "fps_limit"),
    ("display", "vsync"),
    ("content", "resolution"),
    ("content", "start_scene"),
    ("attract", "idle_timeout_s"),
    ("attract", "blend_s"),
    ("burn_in", "drift_px"),
    ("burn_in", "drift_period_s"),
    ("maintenance", "quit_keys"),
    ("accessibility", "reduced_motion"),
]
MAPPING_KEYS = ["sensor_min_distance", "home_angles", "home_sensor_distance", "limits"]
BIND_KEYS = ["step", "rate", "dead_zone", "curve", "invert", "input", "param"]
KEYFRAME_KEYS = ["t", "angles", "sensor_distance", "eye", "half_height", "caption", "ease"]

DEVICES = """
[devices.knobs]
url = "keyboard://"
[devices.stick]
url = "keyboard://"
[mapping]
sensor_min_distance = 2.0
[[mapping.bind]]
device = "knobs"
input = "delta 1"
param = "theta1"
step = 5
[[mapping.bind]]
device = "knobs"
input = "delta 2"
param = "sensor"
step = 0.025
[[mapping.bind]]
device = "stick"
input = "axis 1"
param = "theta2"
rate = 90
[[mapping.bind]]
device = "stick"
input = "axis 2"
param = "sensor"
rate = 0.25
[[mapping.bind]]
device = "knobs"
input = "button 1"
action = "home"
"""

TIMELINE = """name = "fuzz"
scene = "hopf"
preset = "figure-6"
[[keyframe]]
t = 0
sensor_distance = "inf"
[[keyframe]]
t = 5
angles = [10, -20, -30, 0, 0, 0]
sensor_distance = 3
[[keyframe]]
t = 10
sensor_distance = 2
"""


def make_tree(root: Path) -> Path:
    """A minimal kiosk tree: kiosk.toml, one device config, one timeline."""
    if root.exists():
        shutil.rmtree(root)
    (root / "attract").mkdir(parents=True)
    (root / "devices.toml").write_text(DEVICES)
    (root / "attract" / "01.toml").write_text(TIMELINE)
    (root / "kiosk.toml").write_text(
        '[content]\nscenes = ["hopf", "collision"]\n[devices]\nconfig = "devices.toml"\n'
        '[attract]\ntimelines = "attract"\n[maintenance]\nquit_keys = "ctrl+alt+q"\n'
    )
    return root / "kiosk.toml"


def set_key(path: Path, table: str, key: str, value) -> None:
    """Put ``key = value`` at the top of ``[table]`` (or of the first ``[[table]]``)."""
    text = path.read_text()
    line = f"{key} = {toml_value(value)}\n"
    for header in (f"[{table}]\n", f"[[{table}]]\n"):
        if header in text:
            head, rest = text.split(header, 1)
            body = "".join(x for x in rest.splitlines(True) if not x.startswith(f"{key} ="))
            path.write_text(head + header + line + body)
            return
    path.write_text(text + f"\n[{table}]\n" + line)


def set_item(path: Path, table: str, which: int, key: str, value) -> None:
    """Put ``key = value`` into the ``which``-th ``[[table]]``, replacing what was there."""
    head, *items = path.read_text().split(f"[[{table}]]\n")
    lines = [x for x in items[which].splitlines(True) if not x.startswith(f"{key} =")]
    items[which] = f"{key} = {toml_value(value)}\n" + "".join(lines)
    path.write_text(head + "".join(f"[[{table}]]\n" + item for item in items))


def run_kiosk_logic(config) -> None:
    """What `exhibit run` does with a loaded config, minus the window: a minute of use."""
    device_config = load_config(config.devices_config)
    mapper = Mapper(device_config.mapping, ActivityDetector(device_config.activity_threshold))
    state = KioskState(
        Playlist(load_playlist(config.attract_dir, scenes.get)),
        mapper,
        config.scenes,
        config.idle_timeout_s,
        config.blend_s,
        now=0.0,
        reduced_motion=config.reduced_motion,
    )
    rng = np.random.default_rng(0)
    t = 0.0
    for i in range(400):
        t += 0.15 if i % 50 else config.idle_timeout_s + 1  # visitors come and go
        events = []
        if i % 3 == 0:
            events.append(
                Event(t, "knobs", Kind.REL, int(rng.integers(0, 2)), float(rng.integers(-30, 30)))
            )
        if i % 4 == 0:
            events.append(
                Event(t, "stick", Kind.ABS, int(rng.integers(0, 2)), float(rng.uniform(-1, 1)))
            )
        if i % 37 == 0:
            events.append(Event(t, "knobs", Kind.BUTTON, 0, 1.0))
        frame = state.update(events, t)
        view = frame.view
        assert all(math.isfinite(a) for a in view.angles)
        assert math.isfinite(view.sensor_r) and view.sensor_r >= 0
        clip = clip_transform(view, 16 / 9)
        assert np.isfinite(clip.matrix).all()


def check_agreement(tree: Path) -> bool:
    """Loads the config; True if accepted (and then it ran), False if refused by name."""
    try:
        config = load_kiosk_config(tree)
    except ConfigError as exc:
        assert exc.problems and all(": " in p for p in exc.problems)
        assert all(p.startswith(str(tree.parent)) for p in exc.problems), exc.problems
        return False
    run_kiosk_logic(config)
    ACCEPTED.append(str(tree))
    return True


FUZZ = settings(
    max_examples=examples(200),
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)


@FUZZ
@given(key=st.sampled_from(KIOSK_KEYS), value=values)
def test_kiosk_values(tmp_path, key, value):
    tree = make_tree(tmp_path / "k")
    set_key(tree, key[0], key[1], value)
    check_agreement(tree)


@FUZZ
@given(key=st.sampled_from(MAPPING_KEYS), value=values)
def test_mapping_values(tmp_path, key, value):
    tree = make_tree(tmp_path / "m")
    set_key(tree.parent / "devices.toml", "mapping", key, value)
    check_agreement(tree)


@FUZZ
@given(key=st.sampled_from(BIND_KEYS), value=values, which=st.integers(0, 4))
def test_binding_values(tmp_path, key, value, which):
    tree = make_tree(tmp_path / "b")
    set_item(tree.parent / "devices.toml", "mapping.bind", which, key, value)
    check_agreement(tree)


@FUZZ
@given(key=st.sampled_from(KEYFRAME_KEYS), value=values, which=st.integers(0, 2))
def test_timeline_values(tmp_path, key, value, which):
    tree = make_tree(tmp_path / "t")
    set_item(tree.parent / "attract" / "01.toml", "keyframe", which, key, value)
    check_agreement(tree)


def test_the_reported_crashes_are_refused(tmp_path):
    """The issue's examples: each was accepted, then crashed the kiosk."""
    cases = [
        ("bind", "step", math.inf, 0),
        ("bind", "step", 1e308, 0),
        ("bind", "rate", math.inf, 2),
        ("mapping", "home_angles", [0, math.nan, 0, 0, 0, 0]),
        ("mapping", "home_sensor_distance", 1e-320),
        ("keyframe", "sensor_distance", 1e-320),
        ("maintenance", "quit_keys", "ctrl+ctrl+q"),
    ]
    for table, key, value, *which in cases:
        tree = make_tree(tmp_path / "r")
        if table == "bind":
            set_item(tree.parent / "devices.toml", "mapping.bind", which[0], key, value)
        elif table == "mapping":
            set_key(tree.parent / "devices.toml", "mapping", key, value)
        elif table == "keyframe":
            set_item(tree.parent / "attract" / "01.toml", "keyframe", 1, key, value)
        else:
            set_key(tree, table, key, value)
        with pytest.raises(ConfigError) as info:
            load_kiosk_config(tree)
        assert any(key in p for p in info.value.problems), (key, info.value.problems)


# ---- file types -------------------------------------------------------------------------------


def _fifo(path: Path) -> None:
    os.mkfifo(path)


def _dev_zero(path: Path) -> None:
    path.symlink_to("/dev/zero")


def _folder(path: Path) -> None:
    path.mkdir()


def _huge(path: Path) -> None:
    path.write_text("# padding\n" * 200_000)  # 2 MB of valid TOML comments


def _latin1(path: Path) -> None:
    path.write_bytes('name = "caf\xe9"\n'.encode("latin-1"))


def _nested(path: Path) -> None:
    path.write_text("x = " + "[" * 100_000 + "]" * 100_000 + "\n")


def _missing(path: Path) -> None:
    pass


def _dangling(path: Path) -> None:
    path.symlink_to(path.parent / "nowhere.toml")


FILE_KINDS = [_fifo, _dev_zero, _folder, _huge, _latin1, _nested, _missing, _dangling]
LOADERS = {
    "kiosk": load_kiosk_config,
    "devices": load_config,
    "layout": load_layout,
    "timeline": lambda path: load_timeline(path, scenes.get),
    "scene": load_scene_file,
    "recording": read_recording,
}


@pytest.mark.parametrize("make", FILE_KINDS, ids=[f.__name__[1:] for f in FILE_KINDS])
@pytest.mark.parametrize("loader", LOADERS, ids=list(LOADERS))
def test_every_loader_refuses_what_is_not_a_small_text_file(tmp_path, loader, make):
    path = tmp_path / "input.toml"
    make(path)
    outcome: list = []

    def load():
        try:
            LOADERS[loader](path)
            outcome.append("accepted")
        except (ConfigError, DeviceError, ExhibitError) as exc:
            outcome.append(str(exc))
        except BaseException as exc:  # noqa: BLE001 - reported below
            outcome.append(exc)

    worker = threading.Thread(target=load, daemon=True)
    worker.start()
    worker.join(10)
    assert outcome, f"{loader} hung on {make.__name__[1:]}"
    message = outcome[0]
    assert isinstance(message, str) and message != "accepted", message
    assert str(path) in message, message
    assert "\n" not in message or loader == "kiosk"


def test_a_symlink_to_a_good_file_is_fine(tmp_path):
    """Deployments link configs into /etc; only the target's kind matters."""
    tree = make_tree(tmp_path / "s")
    (tree.parent / "devices.toml").rename(tmp_path / "site-devices.toml")
    (tree.parent / "devices.toml").symlink_to(tmp_path / "site-devices.toml")
    assert load_kiosk_config(tree).scenes == ("hopf", "collision")
