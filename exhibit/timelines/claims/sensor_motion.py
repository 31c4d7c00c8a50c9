"""``sensor_motion = "closer"``, ``"farther"`` or ``"still"``: how the sensor moves while the
caption is shown ("Now the 4D viewpoint moves closer"); measured between samples, so a caption
seen at one moment only says nothing of it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from exhibit.timelines.claims.base import EPS_R, VIEW, Claim, Seen, distance, time_spans

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
            what = "the sensor moves"
        else:
            bad = [j for j, s in enumerate(steps) if s * sign < -EPS_R]
            what = "the sensor moves " + ("farther" if sign > 0 else "closer")
            if not bad and not any(s * sign > EPS_R for s in steps):
                return [
                    f"{where}.sensor_motion: the caption says the sensor moves {motion}, but it "
                    f"stays at {distance(r[0])} all the while (t = {times[0]:g}..{times[-1]:g} s)"
                ]
        if not bad:
            return []
        return [
            f"{where}.sensor_motion: the caption says {motion!r}, but {what} at t = "
            f"{time_spans(times, bad, steps=True)}"
        ]
