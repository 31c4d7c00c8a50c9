"""The window target under Xvfb: a GLFW window's context gets the same Renderer and draws the
same picture as the headless target. The window runs in a child process: with Mesa a process
that has initialised EGL (this suite's headless context) cannot make a GLX context current."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from exhibit import scenes
from exhibit.render import RenderOptions
from tests.render.conftest import unavailable
from tests.xvfb import xvfb

SIZE = (240, 180)
CHILD = r"""
import sys
import numpy as np
from PIL import Image
from exhibit import scenes
from exhibit.render import RenderOptions
from exhibit.render.frame_request import FrameRequest
from exhibit.render.window import Window

out, resolution = sys.argv[1], int(sys.argv[2])
scene, preset = scenes.figure(6)
window = Window((240, 180), samples=0, visible=False, vsync=False)
gpu = window.renderer.upload(scene.build(preset.params, resolution))
views = [preset.view, preset.view.replace(angles=(0.5, -0.4, -0.3, 0.0, 0.0, 0.0))]
for i, view in enumerate(views):
    window.draw(FrameRequest(gpu, view, RenderOptions(hud=False)))
    Image.fromarray(window.read()).save(f"{out}/window-{i}.png")
    window.swap()
assert window.ctx.error == "GL_NO_ERROR", window.ctx.error
print(window.size, window.ctx.info["GL_RENDERER"])
window.close()
"""


@pytest.fixture(scope="module")
def display():
    """A private Xvfb server on a free display number."""
    with xvfb() as name:
        yield name


@pytest.fixture(scope="module")
def window_frames(display, tmp_path_factory):
    out = tmp_path_factory.mktemp("window")
    env = dict(os.environ, DISPLAY=display)
    result = subprocess.run(
        [sys.executable, "-c", CHILD, str(out), "16"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        cwd=Path(__file__).resolve().parents[2],
    )
    if result.returncode != 0 and "cannot start GLFW" in result.stderr:
        unavailable(f"no GLFW window on Xvfb: {result.stderr.strip().splitlines()[-1]}")
    assert result.returncode == 0, result.stderr
    frames = []
    for i in range(2):
        with Image.open(out / f"window-{i}.png") as picture:
            frames.append(np.asarray(picture.convert("RGB")))
    return frames


def test_window_draws_the_headless_picture(window_frames, gl):
    scene, preset = scenes.figure(6)
    gpu = gl.renderer.upload(scene.build(preset.params, 16))
    offscreen = gl.image(gpu, preset.view, SIZE, RenderOptions(hud=False), samples=0)
    gpu.release()
    shown = window_frames[0]
    assert shown.shape == offscreen.shape
    differs = np.abs(shown.astype(int) - offscreen.astype(int)).max(axis=-1) > 8
    assert differs.mean() < 0.01
    assert np.abs(shown.astype(int) - shown[0, 0].astype(int)).max() > 60  # not blank


def test_window_frames_follow_the_view(window_frames):
    first, second = window_frames
    assert (np.abs(first.astype(int) - second.astype(int)).max(axis=-1) > 24).mean() > 0.02
