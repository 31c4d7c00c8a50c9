"""Options shared by the device commands (devices, monitor, record): which config, and
``--device NAME=URL`` to add or replace a device without editing the file."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from exhibit.devices.config import DEFAULT_CONFIG, DeviceConfig, load_config
from exhibit.devices.url import parse_url
from exhibit.errors import ExhibitError


def add_config_arguments(parser) -> None:
    parser.add_argument("--config", type=Path, default=None,
                        help=f"device config (default {DEFAULT_CONFIG.relative_to(DEFAULT_CONFIG.parents[2])})")
    parser.add_argument("--device", action="append", default=[], metavar="NAME=URL",
                        help="add or replace a device, e.g. controller=sim://controller "
                             "(repeatable); --only keeps just these")
    parser.add_argument("--only", action="store_true",
                        help="use only the --device devices, not the config's")


def config_from_args(args) -> DeviceConfig:
    config = load_config(args.config)
    devices = {} if args.only else dict(config.devices)
    for item in args.device:
        name, sep, url = item.partition("=")
        if not sep or not name or not url:
            raise ExhibitError(f"--device {item!r}: expected NAME=URL, e.g. knobs=sim://knobbox")
        parse_url(url)
        devices[name] = url
    if not devices:
        raise ExhibitError("no devices: give --device NAME=URL or a config with [devices.NAME]")
    return dataclasses.replace(config, devices=devices)
