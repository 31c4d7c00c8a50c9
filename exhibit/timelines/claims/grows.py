"""``grows = [...]``: the object's area on screen at the caption's end is at least x GROWTH its
area at the start ("the green doughnut grows")."""

from __future__ import annotations

from dataclasses import dataclass

from exhibit.timelines.claims.base import GROWTH, START_TO_END, Claim, Names, Seen


@dataclass(frozen=True)
class Grows(Claim):
    key = "grows"
    fragment = Names | None
    stage = START_TO_END
    example = 'grows = ["torus Z=-√2/2"]'

    objects: tuple[str, ...]

    @classmethod
    def parse(cls, value: list[str], pose: tuple[float, ...]) -> Grows:
        return cls(tuple(value))

    def count(self) -> int:
        return len(self.objects)

    def names(self) -> tuple[str, ...]:
        return self.objects

    def problems(self, seen: Seen) -> list[str]:
        out = []
        first, last = seen.samples[0], seen.samples[-1]
        for name in self.objects:
            if not seen.matched[name] or len(seen.samples) < 2:
                continue
            g = seen.growth(name)
            if not g >= GROWTH:
                a, b = seen.area(name, first), seen.area(name, last)
                out.append(
                    f"{seen.head}: grows {name}: its area on screen went from {a} to {b} px "
                    f"(x{g:.2f}, {seen.span}), not x{GROWTH:g} or more"
                )
        return out
