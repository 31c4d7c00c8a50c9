"""Shared fixtures for the whole suite."""

import os
import subprocess
import sys

import pytest

# Chooses the hypothesis profile ("dev" by default, "ci" under CI=true) before any test module is
# imported, so every @settings(max_examples=examples(N)) sees it.
import tests.hypothesis_profiles  # noqa: F401

# A uniform name no shader declares is an error in tests (and in the kiosk subprocesses they
# start), where the kiosk itself only logs it (exhibit/render/shaders.py).
os.environ.setdefault("EXHIBIT_STRICT_UNIFORMS", "1")


@pytest.fixture
def cli():
    """Run `python -m exhibit ARGS...` as a user would; returns the CompletedProcess."""

    def run(*args):
        return subprocess.run(
            [sys.executable, "-m", "exhibit", *args], capture_output=True, text=True
        )

    return run


def pytest_addoption(parser):
    # Here, at the root of the suite, so the option is known however pytest is started.
    parser.addoption(
        "--update-golden",
        action="store_true",
        default=False,
        help="rewrite the golden images in tests/golden/ from the current renderer "
        "instead of comparing with them (look at them before committing: "
        "tests/golden/README.md)",
    )


@pytest.fixture(scope="session")
def headless():
    """One headless EGL renderer for the whole run (as moderngl's own tests do); without EGL
    the tests that need it skip, except under CI=true."""
    from exhibit.render import Headless, RenderUnavailable
    from tests.xvfb import unavailable

    try:
        h = Headless()
    except RenderUnavailable as exc:
        unavailable(f"no headless OpenGL: {exc}")
    yield h
    h.release()
