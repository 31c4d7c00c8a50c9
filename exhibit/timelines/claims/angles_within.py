"""``angles_within = D`` (degrees, 0..180): the view stays within D degrees of the pose at the
keyframe that states it, each of the six angles and the eye's azimuth and incidence ("in the
plane ..." is true only while the view is the plane view)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

from exhibit.schema.types import Number
from exhibit.timelines.claims.base import VIEW, Claim, Seen, time_spans

#: The pose's eight angles, as the messages name them.
POSE_NAMES = ("θ1", "θ2", "θ3", "θ4", "θ5", "θ6", "eye azimuth", "eye incidence")


@dataclass(frozen=True)
class AnglesWithin(Claim):
    key = "angles_within"
    fragment = Annotated[float, Number(0, 180)] | None
    stage = VIEW
    on_file = True
    example = "angles_within = 5"

    degrees: float
    #: the stating keyframe's pose (radians: θ1..θ6, eye azimuth, incidence)
    pose: tuple[float, ...]

    @classmethod
    def parse(cls, value: float, pose: tuple[float, ...]) -> AnglesWithin:
        return cls(float(value), tuple(pose))

    def problems(self, seen: Seen) -> list[str]:
        limit, stated = self.degrees, self.pose
        turns = []  # per sample: (largest turn in degrees, which angle)
        for sample in seen.samples:
            view = sample.view
            pose = view.angles + (view.eye_azimuth, view.eye_incidence)
            diffs = [abs(math.degrees(a - b)) for a, b in zip(pose, stated)]
            k = max(range(len(diffs)), key=diffs.__getitem__)
            turns.append((diffs[k], k))
        bad = [j for j, (turn, _) in enumerate(turns) if turn > limit + 1e-6]
        if not bad:
            return []
        worst, k = max(turns[j] for j in bad)
        return [
            f"{seen.where}.angles_within: the caption is shown at t = "
            f"{time_spans(seen.times, bad)} with the view turned up to {worst:.1f}° "
            f"({POSE_NAMES[k]}) from keyframe[{seen.first}]'s pose, more than {limit:g}°"
        ]
