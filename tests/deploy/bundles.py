"""An offline bundle of this checkout for the deployment tests: the one `./bootstrap.sh bundle`
writes (docs/DEPLOYMENT.md, "Offline install"), or $EXHIBIT_TEST_BUNDLE when one was made
earlier (a bundle takes a minute and 160 MB of downloads)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def debian_12_with_python_311() -> str:
    """Debian 12's /usr/bin/python3 (3.11), what a bundle is for; skips elsewhere."""
    release = Path("/etc/os-release")
    if not release.exists() or 'VERSION_ID="12"' not in release.read_text():
        pytest.skip("bundles are made on and for Debian 12")
    python = "/usr/bin/python3"
    check = subprocess.run(
        [python, "-c", "import sys; print(sys.version_info[:2] == (3, 11))"],
        capture_output=True,
        text=True,
    )
    if check.stdout.strip() != "True":
        pytest.skip("the bundle is for Debian 12's Python 3.11 (/usr/bin/python3)")
    return python


def make_bundle(folder: Path) -> Path:
    """A bundle of this checkout in ``folder`` (made now), or $EXHIBIT_TEST_BUNDLE."""
    debian_12_with_python_311()
    if os.environ.get("EXHIBIT_TEST_BUNDLE"):
        return Path(os.environ["EXHIBIT_TEST_BUNDLE"])
    result = subprocess.run(
        [str(REPO / "bootstrap.sh"), "bundle", str(folder)],
        capture_output=True,
        text=True,
        timeout=900,
        env={k: v for k, v in os.environ.items() if k != "EXHIBIT_BUNDLE"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return folder
