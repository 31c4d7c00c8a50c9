"""``grows = [...]``: the object's area on screen at the caption's end is at least x GROWTH its
area at the start, and it never falls back on the way by more than GROWTH_DIP ("the green
doughnut grows")."""

from __future__ import annotations

from dataclasses import dataclass

from exhibit.timelines.claims.base import GROWTH, ObjectsClaim, START_TO_END, Seen, growth_problems


@dataclass(frozen=True)
class Grows(ObjectsClaim):
    key = "grows"
    stage = START_TO_END
    example = 'grows = ["torus Z=-√2/2"]'

    def problems(self, seen: Seen) -> list[str]:
        return growth_problems(seen, self.objects, self.key, 1, f"x{GROWTH:g} or more")
