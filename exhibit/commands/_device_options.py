"""Options shared by the device commands (devices, monitor, record): which config, and
``--device NAME=URL`` to add or replace a device without editing the file.

They read the same configuration as `exhibit run`: ``--config`` (else $EXHIBIT_CONFIG, else
/etc/exhibit/kiosk.toml, else the shipped defaults) names the kiosk config, whose
``devices.config`` (or $EXHIBIT_DEVICES_CONFIG) is the device file; ``--devices-config`` names a
device file directly.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from exhibit.devices.config import DeviceConfig, load_config
from exhibit.devices.url import parse_url
from exhibit.errors import ExhibitError


def add_config_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--config",
        type=Path,
        default=None,
        help="kiosk config, as for `exhibit run` (default: $EXHIBIT_CONFIG, else "
        "/etc/exhibit/kiosk.toml, else the shipped one); its "
        "devices.config is used",
    )
    parser.add_argument(
        "--devices-config",
        type=Path,
        default=None,
        metavar="FILE",
        help="a device config file instead (default: $EXHIBIT_DEVICES_CONFIG)",
    )
    parser.add_argument(
        "--device",
        action="append",
        default=[],
        metavar="NAME=URL",
        help="add or replace a device, e.g. controller=sim://controller "
        "(repeatable); --only keeps just these",
    )
    parser.add_argument(
        "--only", action="store_true", help="use only the --device devices, not the config's"
    )


def devices_config_path(args: argparse.Namespace) -> Path:
    """The device file the kiosk would use, or the one given with --devices-config."""
    if args.devices_config is not None:
        return args.devices_config
    from exhibit.kiosk.config import load_kiosk_config

    path = load_kiosk_config(args.config, check_linked=False).devices_config
    assert path is not None  # load_kiosk_config refuses a config whose device file is missing
    return path


def config_from_args(args: argparse.Namespace) -> DeviceConfig:
    config = load_config(devices_config_path(args))
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
