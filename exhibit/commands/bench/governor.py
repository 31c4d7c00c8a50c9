"""`exhibit bench governor [--fps 1 2 5] [--json]`: how long the frame governor takes to step
down on a machine that draws only a few frames a second. It drives exhibit.kiosk.governor's
Governor on a fake clock with the kiosk's ladder on software GL and the shipped 60 Hz target,
every level costing 1000 / fps ms (a machine too slow at every level), and reports when the
first step down comes and when the lowest level is reached. No GL, no wall clock: the numbers
are the rule's, the same on every machine (docs/PERFORMANCE.md). The baseline is a machine
at 60 fps that holds the target (no step at all)."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING

from exhibit.errors import ExhibitError

if TYPE_CHECKING:
    from exhibit.render.quality import Quality

HELP = "seconds the frame governor takes to step down at a few frames a second (fake clock)"
#: How long each machine is run (seconds of its fake clock).
RUN_S = 120.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--fps",
        type=float,
        nargs="+",
        default=[1.0, 2.0, 5.0],
        help="frame rates to drive it at (default: %(default)s)",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def drive(
    fps: float, levels: tuple[Quality, ...], target_ms: float, seconds: float = RUN_S
) -> dict:
    """A governor fed frames of 1000 / fps ms, back to back from t = 0: the time of each step
    (s) and the levels it stepped to."""
    from exhibit.kiosk.governor import Governor, Settings

    governor = Governor(levels, Settings(target_ms=target_ms), now=0.0)
    frame_ms = 1000.0 / fps
    now, steps = 0.0, []
    while now < seconds:
        if governor.update(frame_ms, now):
            steps.append((round(now, 3), governor.quality.name))
        now += max(frame_ms, target_ms) / 1000.0
    return {
        "fps": fps,
        "first_step_s": steps[0][0] if steps else None,
        "lowest_s": next((t for t, name in steps if name == levels[-1].name), None),
        "steps": steps,
    }


def run(args: argparse.Namespace) -> int:
    from exhibit.kiosk.governor import DEFAULT_REFRESH_HZ, kiosk_levels
    from exhibit.kiosk.config import QualityConfig

    if any(not 0.01 <= fps <= 1000 for fps in args.fps):
        raise ExhibitError("--fps: frame rates between 0.01 and 1000")
    levels, _ = kiosk_levels(QualityConfig(), "llvmpipe")
    target = 1000.0 / DEFAULT_REFRESH_HZ
    results = [drive(fps, levels, target) for fps in args.fps]
    baseline = drive(DEFAULT_REFRESH_HZ, levels, target)
    names = [level.name for level in levels]
    report = {
        "ladder": names,
        "target_ms": round(target, 2),
        "results": results,
        "baseline_60fps_steps": len(baseline["steps"]),
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"ladder {' > '.join(names)}; target {target:.1f} ms; fake clock")
    print(f"{'fps':>6} {'first step s':>13} {'lowest level s':>15}  steps")
    for row in results:
        first = "never" if row["first_step_s"] is None else f"{row['first_step_s']:.1f}"
        lowest = "never" if row["lowest_s"] is None else f"{row['lowest_s']:.1f}"
        steps = ", ".join(f"{name} at {t:.1f}" for t, name in row["steps"])
        print(f"{row['fps']:>6g} {first:>13} {lowest:>15}  {steps}")
    print(f"baseline: 60 fps holding the target, {report['baseline_60fps_steps']} steps")
    return 0
