"""`exhibit check-config [FILE] [--show]`: check the kiosk config (the site file over the shipped
defaults) and everything it names (device config, attract timelines, scene files); list every
problem as file: key: reason, or with --show the effective settings and where each came from."""

from __future__ import annotations

import json

from exhibit.kiosk.config import ConfigError, load_kiosk_config

HELP = "check the kiosk configuration and all the files it names; exit 2 on any problem"


def add_arguments(parser) -> None:
    parser.add_argument("config", nargs="?", help="site config over the shipped defaults "
                                                  "(default: $EXHIBIT_CONFIG, else "
                                                  "/etc/exhibit/kiosk.toml if it exists)")
    parser.add_argument("--show", action="store_true",
                        help="print the effective configuration, each value with its file")


def run(args) -> int:
    try:
        config = load_kiosk_config(args.config)
    except ConfigError as exc:
        for problem in exc.problems:
            print(problem)
        print(f"{len(exc.problems)} problem(s) found.")
        return 2
    if args.show:
        width = min(48, max(len(f"{k} = {_toml(v)}") for k, (v, _) in config.sources.items()))
        for key, (value, origin) in config.sources.items():
            line = f"{key} = {_toml(value)}"
            print(f"{line:<{width}}  # {origin}")
        return 0
    layered = " (over the shipped defaults)" if config.site else " (the shipped defaults)"
    print(f"{config.path}: OK{layered}: {len(config.scenes)} scenes, devices "
          f"{config.devices_config}, attract {config.attract_dir}")
    return 0


def _toml(value) -> str:
    """A value as it would be written in the file (inf as TOML's inf)."""
    if isinstance(value, float) and value == float("inf"):
        return "inf"
    return json.dumps(value, ensure_ascii=False)
