"""`exhibit render --timeline FILE` and `exhibit render --takeover SCENE`: the running kiosk
(exhibit.review.player.KioskPlayer) played headlessly for a curator's review.

--timeline: every frame at --fps into a folder (numbered PNGs and index.json, each frame's time
and caption), an MP4 (ffmpeg, as `exhibit render --frames` writes one), or a contact sheet PNG:
one tile per caption, the frame when it has been on screen SETTLED_S (fully faded in; half its
time on screen when that is shorter), labelled with its time and the language.

--takeover: the frame --after seconds after a visitor takes over from attract mode in a scene.

Every check on the arguments runs before any GL work: bad input is one line and exit 2.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import tempfile
from pathlib import Path

from exhibit import scenes
from exhibit.commands._media import (
    check_job,
    encode_mp4,
    gl_errors,
    need_ffmpeg,
    out_file,
    out_folder,
    parse_size,
    save_frame,
    write_out,
)
from exhibit.errors import ExhibitError
from exhibit.progress import Progress, on_terminal, report

#: Contact sheet geometry: tiles at most TILE_W wide, up to COLUMNS a row, GAP between them, a
#: LABEL_H strip under each tile and a HEADER_H strip above the grid.
TILE_W = 640
COLUMNS = 3
GAP = 8
LABEL_H = 30
HEADER_H = 40
BACKGROUND = (24, 24, 28)
INK = (235, 235, 235)


def output_kind(out: str) -> str:
    """ "folder" (ends in / or is a folder), "mp4" or "sheet" (.png); else an ExhibitError."""
    path = Path(out)
    if out.endswith(("/", "\\")) or os.path.isdir(path):  # no OSError: a 300-byte name
        return "folder"  # what is there is check_out's to say
    kind = {".mp4": "mp4", ".png": "sheet"}.get(path.suffix.lower())
    if kind is None:
        raise ExhibitError(
            f"--out: {out} must be a folder (ending in /), an .mp4 or a .png contact sheet"
        )
    if not os.path.isdir(path.parent):
        raise ExhibitError(f"--out: folder {path.parent} does not exist")
    return kind


def check_out(out: str, kind: str) -> Path:
    """--out checked (and a folder made) before any GL work, by the one safe writer's checks
    (exhibit.commands._media): a FIFO, a folder named as FILE.png, a dangling or any symbolic
    link at a file's name, /proc, an over-long name or a read-only folder is one line."""
    return out_folder(out) if kind == "folder" else out_file(out)


def _conflicts(args) -> None:
    if args.timeline is not None and args.takeover is not None:
        raise ExhibitError("give --timeline or --takeover, not both")
    flag = "--timeline" if args.timeline is not None else "--takeover"
    for name, given in (
        ("scene name", bool(args.scene)),
        ("--figure", args.figure is not None),
        ("--frames", args.frames is not None),
        ("--window", args.window),
        ("--slice", args.slice is not None),
        ("--angles", bool(args.angles)),
        ("--param", bool(args.param)),
    ):
        if given:
            raise ExhibitError(f"{flag} plays the kiosk: it takes no {name}")
    if getattr(args, "narration", False) and args.timeline is None:
        raise ExhibitError("--narration goes with --timeline")
    if getattr(args, "narration", False) and getattr(args, "verify", False):
        raise ExhibitError("--verify measures the picture: leave out --narration")
    if getattr(args, "verify", False):
        if args.timeline is None:
            raise ExhibitError("--verify goes with --timeline")
        if args.out is not None:
            raise ExhibitError("--verify measures the frames and writes none: leave out --out")
        return
    if args.out is None:
        raise ExhibitError("--out is required")


def run(args: argparse.Namespace) -> int:
    from exhibit.review.setup import base_config, check_language

    _conflicts(args)
    size = parse_size(args.size)
    config = base_config(args.config)
    language, _ = check_language(config, args.language)
    if getattr(args, "verify", False):
        return _verify(args, size, config)
    if args.timeline is not None:
        return _timeline(args, size, config, language)
    return _takeover(args, size, config, language)


#: --verify's kiosk frames per second: enough for the kiosk's own timing (crossfades, held
#: steps), few enough that a minute of timeline is seconds of work.
VERIFY_FPS = 5


def _verify(args, size, config) -> int:
    """Every caption's claims measured on the frames; problems on stdout, progress on
    stderr, exit 2 when a claim fails."""
    from exhibit.review.claims import frames_to_verify, plays, verify
    from exhibit.review.setup import read_timeline

    timeline = read_timeline(args.timeline)  # one line if it is not a timeline
    languages = (args.language,) if args.language else tuple(config.languages)
    fps = args.fps or VERIFY_FPS
    frames = frames_to_verify(timeline, fps, len(plays(languages, (False, True))))
    check_job(frames, size, "a lower --fps, one --language, a smaller --size or fewer captions")

    def verifying(what: str) -> None:
        report(f"verifying {what} ...")

    with gl_errors(size), Progress(frames, "verifying") as step, on_terminal(lines=True):
        verdict = verify(args.timeline, config, size, fps, languages, progress=verifying, step=step)
    for line in verdict.problems or []:
        print(line)
    played = f"{', '.join(languages)}, with and without reduced motion"
    found = verdict.found
    print(
        f"{verdict.path}: {verdict.captions_with_claims} of {verdict.captions} captions make "
        f"{verdict.claims} claims; {verdict.holding} of {verdict.checked} checks hold; "
        f"{len(found.marks)} unexplained marks, {len(found.tags)} tag faults ({played})"
    )
    return 2 if verdict.problems else 0


def _timeline(args, size, config, language) -> int:
    from exhibit.review.player import KioskPlayer
    from exhibit.review.setup import read_timeline

    kind = output_kind(args.out)
    timeline = read_timeline(args.timeline)  # one line if it is not a timeline
    fps = args.fps or (10 if kind == "sheet" else 25)  # checked by argparse (_args.number)
    if kind == "mp4":
        need_ffmpeg("a folder (DIR/) or a .png contact sheet")
    out = check_out(args.out, kind)
    from exhibit.review.player import caption_spans, play_schedule

    if getattr(args, "narration", False):
        if kind == "sheet":
            raise ExhibitError("--narration: a contact sheet has no sound: --out DIR/ or .mp4")
        return _narrated(args, size, config, language, timeline, kind, out, fps)
    spans = caption_spans(timeline)
    if kind == "sheet" and not spans:
        raise ExhibitError(f"--timeline: {timeline.path} shows no caption for a contact sheet")
    kept = [s.settled for s in spans] if kind == "sheet" else None
    schedule = play_schedule(timeline.duration, fps, kept)
    check_job(len(schedule), size, "a lower --fps, a smaller --size or a shorter timeline")
    with (
        gl_errors(size),
        KioskPlayer(size, timeline=args.timeline, language=language, config=config) as player,
    ):
        if kind == "sheet":
            with Progress(len(schedule)) as progress:
                frames = list(player.play(fps, times=kept, progress=progress))
            sheet = contact_sheet(
                frames, f"{timeline.name} ({Path(timeline.path).name}), language {language}"
            )
            save_frame(sheet, out)
            print(out)
            return 0
        folder = out if kind == "folder" else Path(tempfile.mkdtemp(prefix="exhibit-frames-"))
        try:
            index = []
            with Progress(len(schedule)) as progress:
                for i, frame in enumerate(player.play(fps, progress=progress)):
                    name = f"frame_{i:04d}.png"
                    save_frame(frame.image, folder / name, sync=False)
                    index.append(
                        {
                            "file": name,
                            "t": round(frame.t, 4),
                            "caption": frame.caption,
                            "mode": frame.mode,
                        }
                    )
            if kind == "folder":
                write_index(folder, timeline, language, fps, size, index)
            else:
                encode_mp4(folder, out, fps)
        finally:
            if kind != "folder":
                shutil.rmtree(folder, ignore_errors=True)
    print(out)
    return 0


def write_index(folder: Path, timeline, language, fps, size, frames, **extra) -> None:
    """DIR/index.json: the timeline, language, fps and size, ``extra`` keys, and each frame."""
    data = {
        "timeline": timeline.path,
        "scene": timeline.scene,
        "language": language,
        "fps": fps,
        "size": list(size),
        **extra,
        "frames": frames,
    }
    write_out(folder / "index.json", json.dumps(data, ensure_ascii=False, indent=1) + "\n")


def _narrated(args, size, config, language, timeline, kind, out, fps) -> int:
    """The timeline as the kiosk plays it after a listen press: its frames, held where the
    narration runs on, and the narration itself, as DIR/narration.wav with each spoken
    segment's start and end in index.json, or as the MP4's sound."""
    from exhibit.narration.sound import write_wav
    from exhibit.review.narrated import NARRATED_STRETCH, narration_track, play_narrated
    from exhibit.review.player import KioskPlayer

    estimate = math.ceil(NARRATED_STRETCH * timeline.duration * fps) + 1
    check_job(estimate, size, "a lower --fps, a smaller --size or a shorter timeline")
    folder = out if kind == "folder" else Path(tempfile.mkdtemp(prefix="exhibit-frames-"))
    try:
        with (
            gl_errors(size),
            KioskPlayer(
                size, timeline=args.timeline, language=language, config=config, narrate=True
            ) as player,
        ):
            index = []
            with Progress(estimate) as progress:
                frames = play_narrated(player, fps, progress)
                for i, (frame, into) in enumerate(frames):
                    name = f"frame_{i:04d}.png"
                    save_frame(frame.image, folder / name, sync=False)
                    index.append(
                        {
                            "file": name,
                            "t": round(frame.t, 4),
                            "timeline_t": round(into, 4),
                            "caption": frame.caption,
                            "mode": frame.mode,
                        }
                    )
            track = narration_track(player, len(index) / fps)
        wav = folder / "narration.wav"
        write_wav(wav, track.sound)
        if kind == "folder":
            narration = {"file": wav.name, "segments": track.segments, "failed": track.failed}
            write_index(folder, timeline, language, fps, size, index, narration=narration)
        else:
            encode_mp4(folder, out, fps, audio=wav)
    finally:
        if kind != "folder":
            shutil.rmtree(folder, ignore_errors=True)
    for problem in track.problems:
        print(f"narration: {problem}")
    print(out)
    return 0


def _takeover(args, size, config, language) -> int:
    from exhibit.review.player import KioskPlayer, takeover_frames
    from exhibit.review.setup import shipped_timeline

    scenes.get(args.takeover)  # "no scene named ..." before any GL work
    out = Path(args.out)
    if out.suffix.lower() != ".png":
        raise ExhibitError(f"--out: {out} must end in .png")
    out = out_file(args.out)  # no folder, FIFO, link...; a folder that exists and is writable
    after, fps = args.after, args.fps or 10
    check_job(takeover_frames(after, fps), size, "a lower --fps, a smaller --size or less --after")
    timeline = shipped_timeline(args.takeover, config.attract_dir)
    with (
        gl_errors(size),
        KioskPlayer(
            size, timeline=timeline, scene=args.takeover, language=language, config=config
        ) as player,
    ):
        with Progress(takeover_frames(after, fps)) as progress:
            player.on_step = progress
            frame = player.takeover(after, fps)
        save_frame(frame.image, out)
    print(out)
    return 0


def _font(size: int):
    from PIL import ImageFont

    try:
        from exhibit.render.text import font

        return font("sans", size)
    except Exception:  # noqa: BLE001 - any font will label a tile
        return ImageFont.load_default(size)


def sheet_size(count: int, frame_size: tuple[int, int]) -> tuple[tuple[int, int], int, int]:
    """((width, height) of the sheet, the tiles' width and height) for ``count`` frames."""
    w, h = frame_size
    tile_w = min(w, TILE_W)
    tile_h = max(1, round(h * tile_w / w))
    cols = min(count, COLUMNS)
    rows = math.ceil(count / cols)
    return (
        (cols * tile_w + (cols + 1) * GAP, HEADER_H + rows * (tile_h + LABEL_H) + (rows + 1) * GAP),
        tile_w,
        tile_h,
    )


def contact_sheet(frames, title: str):
    """The frames in a grid, each labelled "t = 9.0 s · de", under ``title``."""
    from PIL import Image, ImageDraw

    height, width = frames[0].image.shape[:2]
    (sheet_w, sheet_h), tile_w, tile_h = sheet_size(len(frames), (width, height))
    sheet = Image.new("RGB", (sheet_w, sheet_h), BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    draw.text((GAP, HEADER_H // 2), title, font=_font(20), fill=INK, anchor="lm")
    label = _font(16)
    cols = min(len(frames), COLUMNS)
    for i, frame in enumerate(frames):
        row, col = divmod(i, cols)
        x = GAP + col * (tile_w + GAP)
        y = HEADER_H + GAP + row * (tile_h + LABEL_H + GAP)
        tile = Image.fromarray(frame.image).convert("RGB")
        if tile.size != (tile_w, tile_h):
            tile = tile.resize((tile_w, tile_h), Image.Resampling.LANCZOS)
        sheet.paste(tile, (x, y))
        draw.text(
            (x, y + tile_h + LABEL_H // 2),
            f"t = {frame.t:.1f} s \u00b7 {frame.language}",
            font=label,
            fill=INK,
            anchor="lm",
        )
    return sheet
