"""Shared fixtures for the whole suite."""

import subprocess
import sys

import pytest


@pytest.fixture
def cli():
    """Run `python -m exhibit ARGS...` as a user would; returns the CompletedProcess."""
    def run(*args):
        return subprocess.run([sys.executable, "-m", "exhibit", *args], capture_output=True,
                              text=True)
    return run
