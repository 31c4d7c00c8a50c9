"""``shrinks = [...]``: the object's area on screen at the caption's end is at most / GROWTH
its area at the start, and it never rises back on the way by more than GROWTH_DIP."""

from __future__ import annotations

from dataclasses import dataclass

from exhibit.timelines.claims.base import GROWTH, ObjectsClaim, START_TO_END, Seen, growth_problems


@dataclass(frozen=True)
class Shrinks(ObjectsClaim):
    key = "shrinks"
    stage = START_TO_END
    example = 'shrinks = ["slice"]'

    def problems(self, seen: Seen) -> list[str]:
        return growth_problems(seen, self.objects, self.key, -1, f"x{1 / GROWTH:.2f} or less")
