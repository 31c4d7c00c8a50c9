"""``at = { "torus Z=0" = "right" }``: where an object is on the screen at every moment the
caption is shown: "left", "right", "top", "bottom", "centre", or two of them ("top right").

For the words spoken to a visitor who cannot see the screen: a description that says "at
right" or "in the middle" is a claim like any caption's, measured on the centre of what shows
of the object (exhibit.review.claims), so a curator's "in the middle" that is at the right
fails `--verify`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from pydantic import Field, StringConstraints

from exhibit.schema.types import Name
from exhibit.timelines.claims.base import EVERY_MOMENT, MAX_CLAIMED, Claim, Seen, time_spans

#: The words a place is written in, and what each means of the centre (x, y as fractions of the
#: screen from its top-left corner): within 0.4 of the screen from an edge; the middle 0.4.
PLACES = {
    "left": lambda x, y: x < 0.4,
    "right": lambda x, y: x > 0.6,
    "top": lambda x, y: y < 0.4,
    "bottom": lambda x, y: y > 0.6,
    "centre": lambda x, y: 0.3 <= x <= 0.7 and 0.3 <= y <= 0.7,
}
Place = Annotated[
    str,
    StringConstraints(
        pattern=r"^(left|right|top|bottom|centre)( (left|right|top|bottom|centre))?$"
    ),
]


@dataclass(frozen=True)
class At(Claim):
    key = "at"
    fragment = Annotated[dict[Name, Place], Field(min_length=1, max_length=MAX_CLAIMED)] | None
    stage = EVERY_MOMENT
    example = 'at = { "torus Z=0" = "right" }'

    #: (object, place words) pairs
    places: tuple[tuple[str, str], ...]

    @classmethod
    def parse(cls, value: dict[str, str], pose: tuple[float, ...]) -> At:
        return cls(tuple(value.items()))

    def count(self) -> int:
        return len(self.places)

    def names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.places)

    def problems(self, seen: Seen) -> list[str]:
        out = []
        for name, place in self.places:
            if not seen.matched[name]:
                continue
            centres = [seen.centre(name, s) for s in seen.samples]
            bad = [j for j, c in enumerate(centres) if not _in(c, place)]
            if bad:
                shown = [c for c in (centres[j] for j in bad) if c is not None]
                where = (
                    "not on the screen"
                    if not shown
                    else "its centre at "
                    + ", ".join(f"({x:.2f}, {y:.2f})" for x, y in shown[:2])
                    + " of the screen's width and height"
                )
                out.append(
                    f"{seen.head}: at {name} = {place!r}: {where} at t = "
                    f"{time_spans(seen.times, bad)}"
                )
        return out


def _in(centre: tuple[float, float] | None, place: str) -> bool:
    return centre is not None and all(PLACES[w](*centre) for w in place.split())
