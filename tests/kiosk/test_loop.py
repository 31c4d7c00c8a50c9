"""The kiosk's loop in-process, without a display: the real Kiosk drawing into the headless EGL
target (exhibit.render.target.HeadlessTarget) on a clock the test moves, with input posted as
the window would deliver it. Attract mode, takeover, idle return, scene switching, focus loss,
close requests and the maintenance keys, each in a few hundred milliseconds; the GLFW glue
itself keeps its few tests under Xvfb (test_window.py, test_focus.py)."""

from __future__ import annotations

import math

import pytest

from exhibit.render.target import CloseRequest, Focus, Key
from tests.kiosk.support import IDLE_S, SIZE, HeadlessKiosk


@pytest.fixture
def loop(headless, tmp_path):
    return HeadlessKiosk(headless, tmp_path)


def test_the_kiosk_draws_its_attract_mode_into_the_headless_target(loop):
    loop.run(1.0)
    assert loop.frame.mode == "attract" and loop.frame.scene == "clifford-torus"
    assert loop.target.image.shape == (SIZE[1], SIZE[0], 3) and loop.target.image.std() > 5
    assert loop.target.cursor_hidden and not loop.target.close_allowed


def test_a_key_takes_over_and_idle_time_gives_the_exhibit_back(loop):
    loop.run(0.5)
    before = loop.frame.view.angles[0]
    loop.target.post(Key("q", True))
    loop.run(1.0)
    assert loop.frame.mode == "visitor" and loop.frame.view.angles[0] > before + 0.1
    loop.target.post(Key("q", False))
    loop.run(IDLE_S - 1.0)
    assert loop.frame.mode == "visitor"  # not idle long enough yet
    loop.run(2.5)
    assert loop.frame.mode == "attract"


@pytest.mark.parametrize("mods", [{"ctrl"}, {"alt"}, {"super"}, {"ctrl", "shift"}])
def test_a_key_with_ctrl_alt_or_super_does_not_turn_the_knobs(loop, mods):
    """Ctrl+Q, Ctrl+W, Alt+Q, Super+W are someone's shortcuts: no takeover, no turn."""
    loop.run(0.5)
    for name in ("q", "w"):
        loop.target.post(Key(name, True, frozenset(mods)))
    loop.run(1.0)
    assert loop.frame.mode == "attract"
    for name in ("q", "w"):
        loop.target.post(Key(name, False, frozenset(mods)))
    loop.run(0.2)
    assert loop.frame.mode == "attract"


def test_shift_q_turns_and_a_release_under_ctrl_lets_go(loop):
    loop.run(0.5)
    before = loop.frame.view.angles[0]
    loop.target.post(Key("q", True, frozenset({"shift"})))
    loop.run(1.0)
    assert loop.frame.mode == "visitor" and loop.frame.view.angles[0] > before + 0.1
    loop.target.post(Key("q", False, frozenset({"ctrl"})))  # Ctrl pressed before letting go
    loop.run(0.3)
    held = loop.frame.view.angles[0]
    loop.run(1.0)
    assert loop.frame.view.angles[0] == pytest.approx(held)


def test_the_next_scene_key_switches_scene(loop):
    loop.run(0.3)
    loop.target.post(Key("n", True))
    loop.target.post(Key("n", False))
    loop.run(0.5)
    assert loop.frame.scene == "hopf" and loop.frame.mode == "visitor"


def test_losing_the_focus_lets_go_of_every_held_key(loop):
    loop.target.post(Key("q", True))
    loop.run(1.0)
    loop.target.post(Focus(False))  # the release never comes: another window has the keys
    loop.run(0.3)
    held = loop.frame.view.angles[0]
    loop.run(1.0)
    assert loop.frame.view.angles[0] == pytest.approx(held)


def test_a_close_request_is_refused_and_the_loop_goes_on(loop):
    loop.run(0.2)
    loop.target.post(CloseRequest())
    loop.run(0.5)
    assert not loop.target.should_close and loop.frame.mode == "attract"


@pytest.mark.parametrize(
    "mods, quits",
    [
        (frozenset({"ctrl", "alt", "shift"}), True),
        (frozenset({"ctrl", "alt"}), False),  # one modifier short
        (frozenset(), False),  # a visitor's plain q
    ],
)
def test_the_maintenance_keys_end_the_loop(loop, mods, quits):
    loop.target.post(Key("q", True, mods))
    code = loop.kiosk.run(max_frames=20)
    assert code == 0
    assert (loop.kiosk.frames < 5) == quits, loop.kiosk.frames
    assert math.isfinite(loop.frame.view.angles[0])


@pytest.mark.slow
def test_the_shipped_collision_timeline_travels_through_time(headless, tmp_path):
    """Figure 17's timeline moves the slice t = c through the contact: the glowing curve (the
    renderer's slice colour) and the inset of the 3D world are on screen at the middle moment,
    and not before the slices begin."""
    from tests.golden.kiosk_frames import KioskRun

    run = KioskRun(headless, tmp_path, (480, 270), "06-collision-17.toml", idle_timeout_s=600)

    def glow() -> int:
        image = run.window.image.astype(int)
        r, g, b = image[..., 0], image[..., 1], image[..., 2]
        return int(((r > 235) & (g > 205) & (b > 100) & (b < 180)).sum())

    def border() -> float:
        """How much of the inset's top edge is its border colour."""
        rect = run.kiosk.parts.inset.rect
        row = run.window.image[int(rect.y0), int(rect.x0) + 2 : int(rect.x1) - 2].astype(int)
        return float((abs(row - [204, 209, 224]).max(axis=1) < 12).mean())

    run.run_until(20.0, step=0.5)
    assert run.kiosk.state.frame.view.slice_axis is None and glow() < 5
    assert border() < 0.5  # no inset while nothing slices
    run.run_until(53.0, step=0.5)
    frame = run.kiosk.state.frame
    assert frame.view.slice_axis == 3 and frame.view.slice_at == 0.0
    assert glow() > 40, glow()
    assert border() > 0.95  # the inset: the 3D world at that moment


def test_release_frees_every_mesh_the_kiosk_uploaded(headless, tmp_path):
    """A review or a test builds many kiosks on one GL context: release() frees each uploaded
    mesh once (levels share meshes) and forgets them."""
    from tests.kiosk.support import HeadlessKiosk

    run = HeadlessKiosk(headless, tmp_path)
    run.run(0.3)
    uploaded = {
        id(g): g for levels in run.kiosk.content.meshes.gpu.values() for g in levels.values()
    }
    assert uploaded and all(g.surfaces for g in uploaded.values())
    run.kiosk.release()
    assert run.kiosk.content.meshes.gpu == {} and all(not g.surfaces for g in uploaded.values())
