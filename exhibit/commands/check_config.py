"""`exhibit check-config [FILE]`: check the kiosk config and everything it names (device config,
attract timelines, scene files) and list every problem as file: key: reason."""

from __future__ import annotations

from exhibit.kiosk.config import ConfigError, load_kiosk_config

HELP = "check the kiosk configuration and all the files it names; exit 2 on any problem"


def add_arguments(parser) -> None:
    parser.add_argument("config", nargs="?", help="kiosk config (default: $EXHIBIT_CONFIG or "
                                                  "configs/kiosk.toml)")


def run(args) -> int:
    try:
        config = load_kiosk_config(args.config)
    except ConfigError as exc:
        for problem in exc.problems:
            print(problem)
        print(f"{len(exc.problems)} problem(s) found.")
        return 2
    print(f"{config.path}: OK ({len(config.scenes)} scenes, devices {config.devices_config}, "
          f"attract {config.attract_dir})")
    return 0
