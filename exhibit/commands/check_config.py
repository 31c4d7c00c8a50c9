"""`exhibit check-config [FILE] [--show]`: check the kiosk config (the site file over the shipped
defaults) and everything it names (device config, attract timelines, scene files); list every
problem as file: key: reason, or with --show the effective settings and where each came from.

It also plays every attract timeline (exhibit.timelines.captions): a caption shown while the view
contradicts its ``while`` condition, or too briefly to be read, is a problem here, though the
kiosk still plays such a timeline (a wrong caption is no reason to show nothing). Likewise a
text without a translation in a language shown, or with characters the font lacks
(exhibit.kiosk.language): the kiosk shows the English text instead. And a curator's scene whose
colours a colour-blind visitor cannot tell apart (exhibit.scenes.colours), and a label or claim
naming an object its scene does not have (exhibit.timelines.object_names: the kiosk skips the
tag)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Mapping

from exhibit import scenes
from exhibit.kiosk.config import ConfigError, load_kiosk_config
from exhibit.kiosk.language import Catalogue, coverage_problems
from exhibit.render.layout import CONTACT_KEY, KEY_WORDS
from exhibit.timelines.captions import caption_problems
from exhibit.timelines.file import load_timeline, timeline_paths

HELP = "check the kiosk configuration and all the files it names; exit 2 on any problem"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "config",
        nargs="?",
        help="site config over the shipped defaults "
        "(default: $EXHIBIT_CONFIG, else "
        "/etc/exhibit/kiosk.toml if it exists)",
    )
    parser.add_argument(
        "--show",
        action="store_true",
        help="print the effective configuration, each value with its file",
    )


def run(args: argparse.Namespace) -> int:
    notes: list[str] = []
    try:
        config = load_kiosk_config(args.config)
        problems = (
            _caption_problems(config.attract_dir)
            + _name_problems(config)
            + coverage_problems(config)
            + _colour_problems(config)
            + _layout_problems(config)
        )
        if not problems:
            narration, notes = _narration(config)
            problems += narration
    except ConfigError as exc:
        problems = exc.problems
    for note in notes:
        print(note)
    if problems:
        for problem in problems:
            print(problem)
        print(f"{len(problems)} problem(s) found.")
        return 2
    if args.show:
        width = min(48, max(len(f"{k} = {_toml(v)}") for k, (v, _) in config.sources.items()))
        for key, (value, origin) in config.sources.items():
            line = f"{key} = {_toml(value)}"
            print(f"{line:<{width}}  # {origin}")
        return 0
    layered = " (over the shipped defaults)" if config.site else " (the shipped defaults)"
    print(
        f"{config.path}: OK{layered}: {len(config.scenes)} scenes, devices "
        f"{config.devices_config}, attract {config.attract_dir}"
    )
    return 0


def _caption_problems(attract_dir) -> list[str]:
    """Every caption of every timeline held to its condition and its reading time (the
    timelines have been checked already, so they load)."""
    if attract_dir is None:
        return []
    return [
        p
        for path in timeline_paths(attract_dir)
        for p in caption_problems(load_timeline(path, scenes.get))
    ]


def _name_problems(config) -> list[str]:
    """Every label and claim naming an object its scene does not have (exhibit.timelines.
    object_names): each timeline's keyframes, and the labels of each scene shown (the kiosk
    draws such a tag nowhere, and a claim about it finds nothing)."""
    from exhibit.timelines.captions import name_problems
    from exhibit.timelines.object_names import known, unknown_line

    timelines = []
    if config.attract_dir is not None:
        timelines = [load_timeline(p, scenes.get) for p in timeline_paths(config.attract_dir)]
    out: list[str] = []
    shown = {}
    for name in dict.fromkeys([*config.scenes, *(t.scene for t in timelines)]):
        try:
            shown[name] = scenes.get(name)
        except Exception:  # noqa: BLE001 - an unknown scene is reported by the config check
            continue
    for timeline in timelines:
        if timeline.scene in shown:
            scene = shown[timeline.scene]
            out += name_problems(timeline, scene.objects, scene.aliases)
    for scene in shown.values():
        where = f"{scene.source or f'scene {scene.name}'}: labels"
        for name in dict.fromkeys(name for name, _ in scene.labels):
            if not known(name, scene.objects):
                out.append(unknown_line(where, name, scene.objects, scene.aliases))
    return out


def _narration(config) -> tuple[list[str], list[str]]:
    """Every narration segment made as the kiosk will speak it (exhibit.kiosk.narrator):
    problems for those that cannot be (a recording refused, no speech engine, one that hung:
    the segments after it are skipped, counted on its line), and a note for each that runs
    past the time its caption is shown (the kiosk then holds the caption while narration is
    on: a visitor listening waits, one reading sees it longer)."""
    from exhibit.kiosk.narrator import prepare_all, report_lines

    if config.attract_dir is None:
        return [], []
    timelines = [load_timeline(path, scenes.get) for path in timeline_paths(config.attract_dir)]
    notes: list[str] = []
    failures = []
    for p in prepare_all(config, timelines):
        where = f"{p.timeline}: keyframe[{p.segment.keyframe}]: narration ({p.segment.language})"
        if p.error is not None:
            failures.append((where, p.error, p.skipped))
        elif p.overrun > 0:
            notes.append(
                f"{where} takes {p.seconds:.1f} s, its caption is shown {p.segment.window:.1f} s: "
                f"held {p.overrun:.1f} s longer while narration is on"
            )
        if p.error is None and p.segment.recording is not None:  # far off the loudness target
            from pathlib import Path

            from exhibit.narration.recordings import level_note

            note = level_note(Path(p.segment.recording), Path(p.segment.root or "."))
            notes += [note] if note else []
    return report_lines(failures), notes


def _colour_problems(config) -> list[str]:
    """The colours of every curator's scene the kiosk shows, held to the rule the shipped
    scenes keep (exhibit.scenes.colours; those are held to it by the tests)."""
    from exhibit.scenes.colours import colour_problems

    names = list(config.scenes)
    if config.attract_dir is not None:
        names += [
            load_timeline(path, scenes.get).scene for path in timeline_paths(config.attract_dir)
        ]
    out: list[str] = []
    for name in dict.fromkeys(names):
        try:
            scene = scenes.get(name)
        except Exception:  # noqa: BLE001 - an unknown scene is reported by the config check
            continue
        if scene.source is not None:
            out += colour_problems(scene)
    return out


def _layout_problems(config) -> list[str]:
    """Every title, caption and HUD word, in every language shown, laid out as the HUD lays it
    out on the smallest kiosk screen (exhibit.render.layout.CHECK_SIZE): a panel it would make
    too tall or too wide, or a word wider than its panel, is a problem here (the kiosk breaks
    and shortens such text rather than draw it off the screen)."""
    from exhibit.timelines.file import load_playlist
    from exhibit.kiosk.language import SOURCE, load_catalogues, shown_texts
    from exhibit.render.layout import TextSizes, text_problems

    timelines = (
        load_playlist(config.attract_dir, scenes.get) if config.attract_dir is not None else []
    )
    texts = shown_texts(config.scenes, timelines)
    t = config.text
    sizes = TextSizes(t.caption_cap, t.title_cap, t.infinity_beyond)
    hud = {
        "4D axes": "gizmo",
        "sensor": "numbers",
        "eye": "numbers",
        "fov": "numbers",
        # the key's entries widen the numbers panel; the first contact's words are a marker's
        # label too
        **{word: "numbers" for word in KEY_WORDS},
        CONTACT_KEY: "key",
    }

    def kind(english: str, where: str) -> str:
        if where == "the HUD":
            return hud.get(english, "label")
        return "title" if where.endswith(": title") else "caption"

    catalogues: Mapping[str, Catalogue | None] = {SOURCE: None}
    if config.catalogues_dir is not None:
        catalogues = load_catalogues(config.catalogues_dir, config.languages)
    out: list[str] = []
    seen: set = set()
    for code, catalogue in catalogues.items():
        if code not in config.languages:
            continue
        for english, where in texts.items():
            if not english:
                continue
            what = kind(english, where)
            if code == SOURCE or catalogue is None:
                text, prefix = english, f"{where}: {_short(english)}"
                if where == "the HUD":
                    continue  # the HUD's own English words fit (tests/render)
            else:
                if english not in catalogue.text:
                    continue  # reported as missing; the English is shown
                text = catalogue.text[english]
                prefix = f"{catalogue.path}: text.{english!r}"
            for reason in text_problems(what, text, sizes, word=english):
                line = f"{prefix}: {reason}"
                if line not in seen:
                    seen.add(line)
                    out.append(line)
    return out


def _short(text: str) -> str:
    return repr(text) if len(text) <= 40 else repr(text[:30] + "…")


def _toml(value) -> str:
    """A value as it would be written in the file (inf as TOML's inf)."""
    if isinstance(value, float) and value == float("inf"):
        return "inf"
    return json.dumps(value, ensure_ascii=False)
