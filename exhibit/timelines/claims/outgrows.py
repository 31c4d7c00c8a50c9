"""``outgrows = ["a", "b"]``: a grows x GROWTH or more, and at least OUTGROWTH times as much as
b ("the green doughnut grows far more than the red one")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from pydantic import Field

from exhibit.schema.types import Name
from exhibit.timelines.claims.base import GROWTH, START_TO_END, Claim, Seen

#: The first's growth at least this many times the second's.
OUTGROWTH = 1.5


@dataclass(frozen=True)
class Outgrows(Claim):
    key = "outgrows"
    fragment = Annotated[list[Name], Field(min_length=2, max_length=2)] | None
    stage = START_TO_END
    example = 'outgrows = ["a", "b"]'

    first: str
    second: str

    @classmethod
    def parse(cls, value: list[str], pose: tuple[float, ...]) -> Outgrows:
        return cls(value[0], value[1])

    def names(self) -> tuple[str, ...]:
        return (self.first, self.second)

    def problems(self, seen: Seen) -> list[str]:
        first, second = self.first, self.second
        if len(seen.samples) < 2 or not (seen.matched[first] and seen.matched[second]):
            return []
        g1, g2 = seen.growth(first), seen.growth(second)
        if g1 >= GROWTH and g1 >= OUTGROWTH * g2:
            return []
        return [
            f"{seen.head}: outgrows {first}, {second}: grew x{g1:.2f} against x{g2:.2f} "
            f"({seen.span}), not x{GROWTH:g} or more and {OUTGROWTH:g} times as much"
        ]
