"""`exhibit render`: a scene or one of the paper's figures to a PNG, or an animation of the sensor
approaching (frames in a folder, a GIF, or an MP4 through ffmpeg), on the headless EGL renderer.
`--timeline` and `--takeover` play the running kiosk instead (exhibit.commands._review)."""

from __future__ import annotations

import argparse
import math
import shutil
import tempfile
from pathlib import Path

from exhibit import scenes
from exhibit.commands import _arg_types as _args
from exhibit.commands._media import (
    check_gl_size,
    encode_mp4,
    gl_errors,
    need_ffmpeg,  # noqa: F401
    out_file,
    out_folder,
    parse_size,
    save_frame,
    whole_number as _int,
    write_out,
)
from exhibit.errors import ExhibitError
from exhibit.geometry.view import ViewState
from exhibit.scenes.base import Scene, parse_overrides
from exhibit.schema.types import MAX_ANGLE, MAX_RESOLUTION, MIN_RESOLUTION

#: The most --fps and --after a review may ask for (exhibit.commands._review).
MAX_FPS = 120
MAX_AFTER_S = 600.0

HELP = "render a scene or a figure of the paper to a PNG (or frames, GIF, MP4) headlessly"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", nargs="?", help="scene name (see `exhibit scenes`)")
    parser.add_argument(
        "--figure",
        type=str,
        metavar="N",
        help="render the paper's Figure N with the parameters it states",
    )
    parser.add_argument(
        "--param", action="append", default=[], metavar="K=V", help="scene parameter (repeatable)"
    )
    parser.add_argument(
        "--size",
        default="1280x720",
        metavar="WxH",
        help="image size in pixels (default: %(default)s)",
    )
    parser.add_argument("--angles", metavar="A1,...,A6", help="the six 4D Euler angles in degrees")
    parser.add_argument(
        "--sensor-distance", metavar="D|inf", help="sensor distance (inf = orthographic 4D -> 3D)"
    )
    parser.add_argument("--eye", metavar="AZ,INC", help="eye azimuth and incidence in degrees")
    parser.add_argument(
        "--resolution", type=str, metavar="N", help="mesh resolution (default: the scene's)"
    )
    parser.add_argument(
        "--frames",
        type=str,
        metavar="N",
        help="render N frames of the sensor moving in from the view's distance "
        "to --sensor-to; --out is a folder, a .gif or an .mp4",
    )
    parser.add_argument(
        "--sensor-to",
        default="2",
        metavar="D",
        help="final sensor distance of an animation (default: %(default)s)",
    )
    parser.add_argument(
        "--samples",
        type=str,
        default="4",
        metavar="S",
        help="multisampling samples per pixel, 0 = off (default: %(default)s)",
    )
    parser.add_argument("--no-hud", action="store_true", help="no title, numbers or axes gizmo")
    parser.add_argument(
        "--no-fit",
        action="store_true",
        help="keep the view's own zoom (default: the picture is fitted into the "
        "space the text leaves free)",
    )
    parser.add_argument(
        "--no-silhouettes",
        action="store_true",
        help="do not draw the live Lemma 3 silhouettes and Lemma 2 points",
    )
    parser.add_argument(
        "--depth-colour", action="store_true", help="colour surfaces by 4D depth (w after rotation)"
    )
    parser.add_argument(
        "--slice",
        metavar="AXIS=C",
        help="draw the slice of the surfaces by the hyperplane AXIS = C, glowing "
        "(e.g. t=-1.5 for the collision: the moment t = -1.5)",
    )
    parser.add_argument(
        "--inset",
        action="store_true",
        help="with --slice: a picture in the picture of the 3D world at that moment",
    )
    parser.add_argument(
        "--out", metavar="FILE", help="output .png (or, with --frames, a folder, .gif or .mp4)"
    )
    parser.add_argument(
        "--timeline",
        metavar="FILE",
        help="play an attract timeline headlessly as the kiosk shows it; --out is a folder "
        "(DIR/: numbered PNGs), an .mp4 or a .png contact sheet (one frame per caption)",
    )
    parser.add_argument(
        "--narration",
        action="store_true",
        help="with --timeline: narrated (DIR/narration.wav + index.json, or the .mp4's sound)",
    )
    parser.add_argument(
        "--verify",
        action="store_true",
        help="with --timeline: play it and measure every caption's claims (its `while`) on "
        "the frames, in each language shown and with and without reduced motion (or "
        "--language alone); prints each failing claim as 'file: keyframe N: claim: what was "
        "measured' and exits 2; no --out",
    )
    parser.add_argument(
        "--takeover",
        metavar="SCENE",
        help="the frame a visitor sees --after seconds after taking over from "
        "attract mode in SCENE; --out FILE.png",
    )
    parser.add_argument(
        "--after",
        default=2.0,
        metavar="S",
        type=_args.number(0.0, MAX_AFTER_S),
        help="with --takeover: seconds after the takeover (default: %(default)s)",
    )
    parser.add_argument(
        "--fps",
        metavar="N",
        type=_args.number(1, MAX_FPS),
        help="with --timeline or --takeover: kiosk frames per second (default: "
        "25 for frames and MP4, 10 for a contact sheet or a takeover)",
    )
    parser.add_argument(
        "--language",
        metavar="CODE",
        help="with --timeline or --takeover: the language shown (default: the kiosk's first)",
    )
    parser.add_argument(
        "--config",
        metavar="KIOSK.toml",
        help="with --timeline or --takeover: a kiosk site file (text sizes, "
        "languages, mesh resolutions; default: the shipped config)",
    )
    parser.add_argument(
        "--window",
        action="store_true",
        help="show it in a window instead, driven by the kiosk's keyboard keys "
        "(q/a w/s e/d r/f t/g y/h turn theta1..6, u/j move the sensor, "
        "space = home; c colours by 4D depth, Esc quits)",
    )


def _distance(text: str, name: str) -> float:
    try:
        return _args.distance()(text)
    except argparse.ArgumentTypeError as exc:
        raise ExhibitError(f"{name}: {exc}") from None


def _floats(text: str, count: int, name: str) -> list[float]:
    items = [item.strip() for item in text.split(",")]
    if len(items) != count:
        raise ExhibitError(f"{name}: expected {count} comma-separated numbers, got {len(items)}")
    values = []
    for item in items:
        try:
            if not item.isascii():  # float() reads "１２" and "٣"
                raise ValueError(item)
            value = float(item)
        except ValueError:
            raise ExhibitError(f"{name}: {item!r} is not a number") from None
        if not math.isfinite(value) or abs(value) > MAX_ANGLE:
            raise ExhibitError(f"{name}: {item!r} must be finite degrees within ±{MAX_ANGLE:g}")
        values.append(value)
    return values


def resolve(args: argparse.Namespace) -> tuple[Scene, dict[str, object], ViewState, str]:
    """(scene, params, view, caption line) from the arguments; every problem is an ExhibitError."""
    if args.figure is not None and args.scene:
        raise ExhibitError("give a scene or --figure, not both")
    if args.figure is not None:
        scene, preset = scenes.figure(_int(args.figure, "--figure", 1, 99))
        params: dict[str, object] = dict(preset.params)
        view = preset.view
        note = f"Figure {args.figure}. {preset.caption}".strip()
    elif args.scene:
        scene = scenes.get(args.scene)
        params, view, note = {}, scene.view, ""
    else:
        raise ExhibitError("name a scene or give --figure N")
    params.update(parse_overrides(args.param))
    scene.resolve(params)  # reports unknown names and bad values before any GL work
    changes: dict[str, object] = {}
    if args.angles:
        changes["angles"] = tuple(math.radians(a) for a in _floats(args.angles, 6, "--angles"))
    if args.eye:
        az, inc = _floats(args.eye, 2, "--eye")
        changes["eye_azimuth"], changes["eye_incidence"] = math.radians(az), math.radians(inc)
    if changes:
        view = view.replace(**changes)
    if args.sensor_distance is not None:
        view = view.with_sensor_distance(_distance(args.sensor_distance, "--sensor-distance"))
    if args.slice is not None:
        axis, at = parse_slice(args.slice, tuple(scene.axes))
        view = view.replace(slice_axis=axis, slice_at=at)
    elif args.inset:
        raise ExhibitError("--inset shows the 3D world at a slice: give --slice AXIS=C too")
    return scene, params, view, note


def parse_slice(text: str, axes: tuple[str, ...]) -> tuple[int, float]:
    """`--slice AXIS=C`: the axis index and the value, finite and within ±1e6."""
    name, sep, value = text.partition("=")
    name = name.strip()
    if not sep or name not in axes:
        raise ExhibitError(f"--slice: {text!r} is not AXIS=C with AXIS one of {', '.join(axes)}")
    try:
        if not value.isascii():  # float() reads "１２" and "٣"
            raise ValueError(value)
        at = float(value)
    except ValueError:
        raise ExhibitError(f"--slice: {value.strip()!r} is not a number") from None
    if not (math.isfinite(at) and abs(at) <= 1e6):
        raise ExhibitError(f"--slice: {value.strip()!r} must be a finite number within ±1e6")
    return axes.index(name), at


def run(args: argparse.Namespace) -> int:
    if args.timeline is not None or args.takeover is not None:
        from exhibit.commands import _review

        return _review.run(args)
    for flag in ("language", "config", "fps"):
        if getattr(args, flag) is not None:
            raise ExhibitError(f"--{flag} goes with --timeline or --takeover")
    if args.narration:
        raise ExhibitError("--narration goes with --timeline")
    scene, params, view, note = resolve(args)
    size = parse_size(args.size)
    samples = _int(args.samples, "--samples", 0, 16)
    resolution = (
        None
        if args.resolution is None
        else _int(args.resolution, "--resolution", MIN_RESOLUTION, MAX_RESOLUTION)
    )
    frames = None if args.frames is None else _int(args.frames, "--frames", 1, 10000)
    if args.window:
        return _window(scene, params, view, note, size, resolution, samples)
    if args.out is None:
        raise ExhibitError("--out FILE is required (or --window)")
    out = Path(args.out)
    if frames is None:
        if out.suffix.lower() != ".png":
            raise ExhibitError(f"--out: {out} must end in .png (use --frames for animations)")
        out = out_file(args.out)  # "d.png/", a FIFO, a link, read-only: one line, before GL
    kind = "folder"
    if frames is not None:
        kind = {".gif": "gif", ".mp4": "mp4"}.get(out.suffix.lower(), "folder")
        if args.out.endswith("/"):
            kind = "folder"
        if kind == "mp4":
            need_ffmpeg("a .gif or a folder")
        out = out_file(args.out) if kind != "folder" else out_folder(args.out)
    end_r = 1.0 / _distance(args.sensor_to, "--sensor-to")

    from exhibit.render import Headless, HudInfo, RenderOptions

    options = RenderOptions(
        silhouettes=not args.no_silhouettes,
        pinch_points=not args.no_silhouettes,
        depth_colour=args.depth_colour,
        hud=not args.no_hud,
    )
    hud = HudInfo(scene.title, scene.caption, scene.axes, note)
    mesh = scene.build(params, resolution)
    fit = not args.no_fit and (args.figure is None or scenes.figure(int(args.figure))[1].fit)
    inset = None
    if args.inset:
        from exhibit.render.inset import inset_rect
        from exhibit.render.layout import hud_layout

        inset = inset_rect(size, hud_layout(size, sizes=options.text).margin)
    if fit and scene.fit and frames is None:
        # The picture in the space the text (and the inset) leave (exhibit.render.framer). Not
        # animations: the sensor sweep's point is the image growing to fill the world.
        from exhibit.render.framer import Framer

        framer = Framer(size, options.text, hud=options.hud, extra=(inset,) if inset else ())
        view = framer.view(mesh, view, scene.title, [(scene.caption, note)])
    headless = Headless()
    try:
        check_gl_size(headless.ctx, size, samples if frames is None else 0)
        with gl_errors(size):  # a framebuffer the driver will not make: one line
            gpu = headless.renderer.upload(mesh)
            if frames is None:
                inset_gpu, drawn = None, None
                if inset is not None:
                    inset_gpu, drawn = _inset(headless, scene, params, mesh, view, inset)
                try:
                    picture = headless.still(gpu, view, size, options, hud, samples, inset=drawn)
                finally:
                    if inset_gpu is not None:
                        inset_gpu.release()
                save_frame(picture, out)
                print(out)
                return 0
            images = []
            for i in range(frames):
                t = i / (frames - 1) if frames > 1 else 0.0
                frame_view = view.replace(sensor_r=(1 - t) * view.sensor_r + t * end_r)
                images.append(headless.image(gpu, frame_view, size, options, hud, samples))
    finally:
        headless.release()
    _write_animation(images, out, kind)
    print(out)
    return 0


def _inset(headless, scene, params, mesh, view, rect):
    """The time-slice inset (exhibit.render.inset) for ``rect``: the world at the slice
    uploaded, and the frame pipeline's Inset, drawn as the kiosk draws it."""
    from exhibit.render.frame import Inset
    from exhibit.render.inset import inset_label, inset_mesh, inset_view

    axis, at = view.slice_axis, view.slice_at
    world = inset_mesh(scene, scene.resolve(params), mesh, axis, at)
    size = (int(rect.width), int(rect.height))
    gpu = headless.renderer.upload(world)
    return gpu, Inset(
        gpu,
        inset_view(view, world, size),
        (rect.x0, rect.y0, *size),
        inset_label(scene.axes[axis], at),
    )


def _window(scene, params, view, note, size, resolution, samples) -> int:
    """The staff viewer: the kiosk's keyboard mapping (the device config `exhibit run` would
    use) drives the view (exhibit.commands._staff_viewer)."""
    from exhibit.commands import _staff_viewer as _viewer
    from exhibit.devices.config import load_config
    from exhibit.kiosk.config import load_kiosk_config
    from exhibit.render import HudInfo, RenderOptions
    from exhibit.render.window import Window

    devices = load_config(load_kiosk_config(check_linked=False).devices_config)
    window = Window(size, title=scene.title, samples=samples)
    try:
        gpu = window.renderer.upload(scene.build(params, resolution))
        hud = HudInfo(scene.title, scene.caption, tuple(scene.axes), note)
        _viewer.run(window, gpu, view, hud, devices, RenderOptions())
    finally:
        window.close()
    return 0


def _write_animation(images, out: Path, kind: str) -> None:
    """The frames as a GIF, an MP4 or numbered PNGs in a folder (checked by out_file and
    out_folder), every file through the one safe writer (exhibit.commands._media)."""
    import io

    from PIL import Image

    if kind == "gif":
        pictures = [Image.fromarray(im) for im in images]
        buffer = io.BytesIO()
        pictures[0].save(
            buffer, format="GIF", save_all=True, append_images=pictures[1:], duration=80, loop=0
        )
        write_out(out, buffer.getvalue())
        return
    folder = out if kind == "folder" else Path(tempfile.mkdtemp(prefix="exhibit-frames-"))
    for i, image in enumerate(images):
        save_frame(image, folder / f"frame_{i:04d}.png", sync=False)
    if kind == "mp4":
        try:
            encode_mp4(folder, out)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
