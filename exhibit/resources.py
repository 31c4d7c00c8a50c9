"""Where the shipped data lives: configs (kiosk, devices, HID layouts, timelines, scenes) and the
systemd units, found the same way from a clone and from an installed wheel.

The repository keeps them at the top level (configs/, systemd/); the package links to them
(exhibit/configs, exhibit/systemd are symlinks), and building a wheel copies the files behind the
links into it as package data. So ``importlib.resources`` finds real files in both cases, and
nothing depends on where the package was installed from.
"""

from __future__ import annotations

from importlib.resources import as_file, files
from pathlib import Path


def shipped(*parts: str) -> Path:
    """The path of a shipped file or folder, e.g. ``shipped("configs", "kiosk.toml")``."""
    resource = files("exhibit").joinpath(*parts)
    with as_file(resource) as path:  # a real path for a normal install; zip installs unsupported
        return Path(path).resolve()  # in a clone: configs/..., as people know it
