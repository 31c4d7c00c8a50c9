"""``fills = { "torus Z=-√2/2" = 0.9 }``: the object covers at least that share of the screen
at every moment the caption is shown ("green fills the world")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from pydantic import Field

from exhibit.schema.types import Name, Number
from exhibit.timelines.claims.base import EVERY_MOMENT, MAX_CLAIMED, Claim, Seen, time_spans


@dataclass(frozen=True)
class Fills(Claim):
    key = "fills"
    fragment = (
        Annotated[
            dict[Name, Annotated[float, Number(0.001, 1.0)]],
            Field(min_length=1, max_length=MAX_CLAIMED),
        ]
        | None
    )
    stage = EVERY_MOMENT
    example = 'fills = { "torus Z=-√2/2" = 0.9 }'

    #: (object, least share of the screen) pairs
    shares: tuple[tuple[str, float], ...]

    @classmethod
    def parse(cls, value: dict[str, float], pose: tuple[float, ...]) -> Fills:
        return cls(tuple(value.items()))

    def count(self) -> int:
        return len(self.shares)

    def names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.shares)

    def problems(self, seen: Seen) -> list[str]:
        out = []
        for name, low in self.shares:
            if not seen.matched[name]:
                continue
            share = [seen.share(name, s) for s in seen.samples]
            bad = [j for j, x in enumerate(share) if x < low]
            if bad:
                least = min(share[j] for j in bad)
                out.append(
                    f"{seen.head}: fills {name} = {low:g}: covers {least:.2f} of the screen at "
                    f"t = {time_spans(seen.times, bad)}"
                )
        return out
