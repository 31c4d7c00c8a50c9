"""`exhibit scenes`: what can be shown, for curators and installers."""

from __future__ import annotations

import argparse
import json
import sys

from exhibit import scenes

HELP = "list the scenes with their titles and parameters"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument(
        "--check-colours",
        action="store_true",
        help="check that every scene's colours stay apart for colour-blind "
        "visitors (ΔE 15 under protanopia, deuteranopia, tritanopia); "
        "exit 2 on any pair that does not",
    )


def run(args: argparse.Namespace) -> int:
    if args.check_colours:
        return _check_colours()
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


def _check_colours() -> int:
    """Every scene's colour pairs held to exhibit.scenes.colours' rule, one line a problem."""
    from exhibit.scenes.colours import colour_problems, least_delta_e, scene_parts

    problems = [
        f"{path}: colours: not checked, the scene does not load ({message})"
        for path, message in scenes.problems()
    ]  # a broken curator scene is named, not skipped
    for name in scenes.names():
        scene = scenes.get(name)
        try:
            parts = scene_parts(scene)
        except Exception:  # noqa: BLE001 - colour_problems says why, in one line
            problems += colour_problems(scene)
            continue
        found = colour_problems(scene, parts)
        problems += found
        if not found:
            least, vision = least_delta_e(parts)
            margin = "one colour" if least == float("inf") else f"least ΔE {least:.1f} ({vision})"
            print(f"{name:20} OK: {len(parts)} colours, {margin}")
    for problem in problems:
        print(problem)
    if problems:
        print(f"{len(problems)} problem(s) found.")
        return 2
    return 0
