"""What a visitor sees right after taking over: for every scene of the shipped content list, the
real kiosk (exhibit.kiosk.review.KioskPlayer) plays attract mode for 3 s on a shipped timeline
of that scene (else the scene alone), a visitor turns θ1 with the keyboard's q for 0.25 s, and
2 s later (the framing has glided by then) the frame must show the surfaces clear of every text
panel, and every marker label on the screen and off the panels (tests/golden/visitor_checks.py),
in English and in German.

The shipped mesh resolutions and quality level fxaa, at 1280x720 and 1920x1080. The default run
is 1280x720 in German (its captions are the longer: every case failing in English fails in
German too; about 25 s on llvmpipe); English and 1920x1080 are marked slow. The cases in XFAIL fail today: the scene's own caption
is longer than the timeline's, and its panel covers the picture framed for the shorter one (being
fixed in exhibit/kiosk/app.py).
"""

from __future__ import annotations

import os

import pytest

from exhibit.kiosk.review import KioskPlayer, base_config, shipped_timeline
from tests.golden.visitor_checks import capture, visitor_problems

CONFIG = base_config()
SCENES = CONFIG.scenes
LANGUAGES = ("en", "de")
FPS = 5.0
AFTER_S = 2.0

#: (scene, width, language) failing today, as found on llvmpipe.
XFAIL = {
    ("offset-parabola", 1280, "en"), ("offset-parabola", 1280, "de"),
    ("offset-cusp", 1280, "en"), ("offset-cusp", 1280, "de"),
    ("collision", 1280, "de"), ("clifford-torus", 1280, "de"),
    ("complex-square", 1280, "en"), ("complex-square", 1280, "de"),
    ("offset-parabola", 1920, "en"), ("offset-parabola", 1920, "de"),
    ("offset-cusp", 1920, "en"), ("offset-cusp", 1920, "de"),
    ("collision", 1920, "de"), ("veronese", 1920, "de"),
}


def _cases():
    for size in ((1280, 720), (1920, 1080)):
        for scene in SCENES:
            for language in LANGUAGES:
                marks = [pytest.mark.slow] if size[0] == 1920 or language == "en" else []
                if (scene, size[0], language) in XFAIL:
                    marks.append(pytest.mark.xfail(strict=False,
                                                   reason="takeover framing: being fixed"))
                yield pytest.param(scene, size, language, marks=marks,
                                   id=f"{scene}-{size[0]}x{size[1]}-{language}")


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """One mesh cache for the module (each scene built once, at its shipped resolution)."""
    folder = tmp_path_factory.mktemp("meshes")
    before = os.environ.get("EXHIBIT_CACHE_DIR")
    os.environ["EXHIBIT_CACHE_DIR"] = str(folder)
    yield folder
    if before is None:
        os.environ.pop("EXHIBIT_CACHE_DIR", None)
    else:
        os.environ["EXHIBIT_CACHE_DIR"] = before


@pytest.mark.parametrize("scene, size, language", list(_cases()))
def test_the_takeover_frame_is_readable(headless, cache, scene, size, language):
    player = KioskPlayer(size, timeline=shipped_timeline(scene), scene=scene,
                         language=language, config=CONFIG, headless=headless)
    try:
        frame = player.takeover(AFTER_S, FPS)
        view = capture(headless, player.window, frame.caption, frame.mode, frame.scene)
    finally:
        player.close()
    assert (frame.mode, frame.scene, frame.language) == ("visitor", scene, language)
    assert visitor_problems(view) == []
