"""``sensor_motion = "closer"``, ``"farther"`` or ``"still"``: how the sensor moves while the
caption is shown ("Now the 4D viewpoint moves closer"), over the whole caption: never the other
way, and standing still for no more than MOTION_STILL_SHARE of its time (in reduced motion: no
longer than a held step). Measured between samples, so a caption seen at one moment only says
nothing of it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from exhibit.timelines.claims.base import (
    EPS_R,
    MOTION_STILL_SHARE,
    MOTION_STILL_STEPPED_S,
    VIEW,
    Claim,
    Seen,
    distance,
    time_spans,
)

Motion = Literal["closer", "farther", "still"]
MOTIONS: tuple[Motion, ...] = get_args(Motion)


@dataclass(frozen=True)
class SensorMotion(Claim):
    key = "sensor_motion"
    fragment = Motion | None
    stage = VIEW
    on_file = True
    example = 'sensor_motion = "closer"'

    motion: str

    @classmethod
    def parse(cls, value: str, pose: tuple[float, ...]) -> SensorMotion:
        return cls(value)

    def problems(self, seen: Seen) -> list[str]:
        if len(seen.samples) < 2:
            return []
        times, r, motion, where = seen.times, seen.r, self.motion, seen.where
        steps = [b - a for a, b in zip(r, r[1:])]
        sign = {"closer": 1.0, "farther": -1.0, "still": 0.0}[motion]
        if sign == 0.0:
            bad = [j for j, s in enumerate(steps) if abs(s) > EPS_R]
            if not bad:
                return []
            return [
                f"{where}.sensor_motion: the caption says 'still', but the sensor moves at t = "
                f"{time_spans(times, bad, steps=True)}"
            ]
        wrong = [j for j, s in enumerate(steps) if s * sign < -EPS_R]
        if wrong:
            other = "farther" if sign > 0 else "closer"
            return [
                f"{where}.sensor_motion: the caption says {motion!r}, but the sensor moves "
                f"{other} at t = {time_spans(times, wrong, steps=True)}"
            ]
        if not any(s * sign > EPS_R for s in steps):
            return [
                f"{where}.sensor_motion: the caption says the sensor moves {motion}, but it "
                f"stays at {distance(r[0])} all the while (t = {times[0]:g}..{times[-1]:g} s)"
            ]
        still = [j for j, s in enumerate(steps) if abs(s) <= EPS_R]
        if seen.stepped:  # held steps: no stretch held longer than a step
            long = [(a, b) for a, b in _stretches(times, still) if b - a > MOTION_STILL_STEPPED_S]
            if not long:
                return []
            spans = ", ".join(f"{a:.1f}..{b:.1f} s" for a, b in long)
            return [
                f"{where}.sensor_motion: the caption says {motion!r}, but the sensor stands "
                f"still at t = {spans} (longer than a held step, {MOTION_STILL_STEPPED_S:g} s)"
            ]
        share = sum(times[j + 1] - times[j] for j in still) / (times[-1] - times[0])
        if share <= MOTION_STILL_SHARE:
            return []
        return [
            f"{where}.sensor_motion: the caption says {motion!r}, but the sensor stands still "
            f"at {distance(r[still[0]])} at t = {time_spans(times, still, steps=True)} "
            f"({100 * share:.0f} % of its time, more than {100 * MOTION_STILL_SHARE:.0f} %)"
        ]


def _stretches(times: list[float], steps: list[int]) -> list[tuple[float, float]]:
    """The time spans of runs of consecutive steps (step j: from sample j to j + 1)."""
    out: list[tuple[float, float]] = []
    for j in steps:
        if out and times[j] == out[-1][1]:
            out[-1] = (out[-1][0], times[j + 1])
        else:
            out.append((times[j], times[j + 1]))
    return out
