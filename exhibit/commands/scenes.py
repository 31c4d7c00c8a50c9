"""`exhibit scenes`: what can be shown, for curators and installers."""

from __future__ import annotations

import json
import sys

from exhibit import scenes

HELP = "list the scenes with their titles and parameters"


def add_arguments(parser) -> None:
    parser.add_argument("--json", action="store_true", help="print JSON")


def run(args) -> int:
    listing = [scenes.get(name).to_json() for name in scenes.names()]
    for _, message in scenes.problems():
        print(f"exhibit scenes: skipped {message}", file=sys.stderr)
    if args.json:
        print(json.dumps({"scenes": listing}, indent=2, ensure_ascii=False))
        return 0
    for scene in listing:
        params = ", ".join(f"{p['name']}={p['default']:g}" for p in scene["parameters"]) or "-"
        presets = ", ".join(scene["presets"]) or "-"
        print(f"{scene['name']:20} {scene['title']}")
        print(f"{'':20} parameters: {params}; presets: {presets}")
    return 0
