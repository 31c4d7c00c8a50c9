"""``covers = { "torus Z=-√2/2" = [0.2, 0.5] }``: the share of the screen an object covers as
seen lies in that range at every moment the caption is shown ("a big ball fills the right
side", "a thin ring"): how big a description says a thing is, measured."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from pydantic import Field

from exhibit.schema.types import Name, Number
from exhibit.timelines.claims.base import EVERY_MOMENT, MAX_CLAIMED, Claim, Seen, time_spans

Share = Annotated[float, Number(0.0, 1.0)]


@dataclass(frozen=True)
class Covers(Claim):
    key = "covers"
    fragment = (
        Annotated[
            dict[Name, Annotated[list[Share], Field(min_length=2, max_length=2)]],
            Field(min_length=1, max_length=MAX_CLAIMED),
        ]
        | None
    )
    stage = EVERY_MOMENT
    example = 'covers = { "torus Z=-√2/2" = [0.2, 0.5] }'

    #: (object, least share, most share) triples
    ranges: tuple[tuple[str, float, float], ...]

    @classmethod
    def parse(cls, value: dict[str, list[float]], pose: tuple[float, ...]) -> Covers:
        return cls(tuple((name, min(r), max(r)) for name, r in value.items()))

    def count(self) -> int:
        return len(self.ranges)

    def names(self) -> tuple[str, ...]:
        return tuple(name for name, _, _ in self.ranges)

    def problems(self, seen: Seen) -> list[str]:
        out = []
        for name, low, high in self.ranges:
            if not seen.matched[name]:
                continue
            share = [seen.share(name, s) for s in seen.samples]
            bad = [j for j, x in enumerate(share) if not low <= x <= high]
            if bad:
                worst = min(bad, key=lambda j: min(abs(share[j] - low), abs(share[j] - high)))
                out.append(
                    f"{seen.head}: covers {name} = [{low:g}, {high:g}]: covers "
                    f"{share[worst]:.3f} of the screen at t = {time_spans(seen.times, bad)}"
                )
        return out
