"""The render-target interface (exhibit/render/target.py): GLFW's callbacks become the same
toolkit-neutral events the headless target delivers, so the kiosk cannot tell them apart."""

from __future__ import annotations

from types import SimpleNamespace

from exhibit.render.target import CloseRequest, Focus, HeadlessTarget, Key
from exhibit.render.window import Window


def fake_glfw(callbacks: dict, closed: list):
    return SimpleNamespace(
        PRESS=1,
        RELEASE=0,
        REPEAT=2,
        MOD_SHIFT=1,
        MOD_CONTROL=2,
        MOD_ALT=4,
        MOD_SUPER=8,
        KEY_SPACE=32,
        KEY_ESCAPE=256,
        KEY_UP=265,
        KEY_DOWN=264,
        KEY_LEFT=263,
        KEY_RIGHT=262,
        get_key_name=lambda key, scancode: {81: "Q", 78: "n"}.get(key),
        set_key_callback=lambda handle, f: callbacks.__setitem__("key", f),
        set_window_focus_callback=lambda handle, f: callbacks.__setitem__("focus", f),
        set_window_close_callback=lambda handle, f: callbacks.__setitem__("close", f),
        set_window_should_close=lambda handle, value: closed.append(value),
    )


def test_the_window_turns_glfw_callbacks_into_events():
    callbacks, closed, events = {}, [], []
    window = Window.__new__(Window)  # the callbacks alone: no display needed
    window._glfw, window.handle = fake_glfw(callbacks, closed), object()
    window.close_allowed, window._handler = True, None
    window._install_callbacks()
    callbacks["key"](None, 81, 0, 1, 0)  # no handler yet: dropped, no error
    window.set_input(events.append)
    callbacks["key"](None, 81, 0, 1, 2 | 4 | 1)
    callbacks["key"](None, 81, 0, 2, 0)  # auto-repeat: not an event
    callbacks["key"](None, 81, 0, 0, 0)
    callbacks["key"](None, 32, 0, 1, 8)
    callbacks["key"](None, 999, 0, 1, 0)  # a key with no name
    callbacks["focus"](None, 0)
    window.close_allowed = False
    callbacks["close"](None)
    assert events == [
        Key("q", True, frozenset({"ctrl", "alt", "shift"})),
        Key("q", False),
        Key("space", True, frozenset({"super"})),
        Focus(False),
        CloseRequest(),
    ]
    assert closed == [False]  # the kiosk's policy: a close request does not close it


def test_the_headless_target_delivers_posted_input_at_swap():
    events = []
    target = HeadlessTarget(
        SimpleNamespace(ctx=None, renderer=None, activate=lambda: None), (64, 32)
    )
    target.set_input(events.append)
    target.post(Key("n", True))
    target.post(CloseRequest())
    assert events == [] and not target.should_close
    target.swap()
    assert events == [Key("n", True), CloseRequest()] and target.should_close
    target.close_allowed = False
    target.post(CloseRequest())
    target.swap()
    assert not target.should_close  # as a GLFW window: a refused request clears the flag
