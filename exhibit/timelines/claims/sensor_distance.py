"""``sensor_distance = [low, high]`` (or ``"inf"``; high may be ``"inf"``): the sensor stays at
a distance in that range while the caption is shown ("At distance 2 the viewpoint touches the
4D ball")."""

from __future__ import annotations

import math
from dataclasses import dataclass

from exhibit.schema.types import DistanceRange, distance_to_r
from exhibit.timelines.claims.base import EPS_R, VIEW, Claim, Seen, distance, time_spans


@dataclass(frozen=True)
class SensorDistance(Claim):
    key = "sensor_distance"
    fragment = DistanceRange | None
    stage = VIEW
    on_file = True
    example = "sensor_distance = [1.9, 2.1]"

    #: the range of r = 1/d the sensor must stay in
    r: tuple[float, float]
    #: the distances as written, for messages
    written: tuple[float, float]

    @classmethod
    def parse(cls, value: tuple[float, float], pose: tuple[float, ...]) -> SensorDistance:
        return cls((distance_to_r(value[1]), distance_to_r(value[0])), value)

    def problems(self, seen: Seen) -> list[str]:
        times, r = seen.times, seen.r
        low, high = self.r
        bad = [j for j, x in enumerate(r) if not low - EPS_R <= x <= high + EPS_R]
        if not bad:
            return []
        d = self.written
        want = (
            "inf"
            if d[0] == math.inf
            else f"[{d[0]:g}, {'inf' if d[1] == math.inf else f'{d[1]:g}'}]"
        )
        near, far = distance(max(r[j] for j in bad)), distance(min(r[j] for j in bad))
        shown = near if near == far else f"{near}..{far}"
        return [
            f"{seen.where}.sensor_distance: the caption is shown at t = {time_spans(times, bad)} "
            f"with the sensor at {shown}, outside {want}"
        ]
