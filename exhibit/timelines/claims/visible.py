"""``visible = ["offset curve", ...]``: each object shows at every moment the caption is shown,
and is not hidden behind others but for a sliver."""

from __future__ import annotations

from dataclasses import dataclass

from exhibit.timelines.claims.base import EVERY_MOMENT, ObjectsClaim, Sample, Seen, time_spans

#: At least this share of the screen (a 2 px curve 140 px long at 1280x720).
VISIBLE_SHARE = 3e-4
#: ... and at least this part of it, against the object drawn with nothing in front of it
#: (a curve hidden inside a tube but for a sliver is not visible).
VISIBLE_PART = 0.3
#: ... unless what shows covers this much of the screen anyway (a big surface mostly behind
#: another is still plainly there).
PLAINLY_VISIBLE = 3e-3


@dataclass(frozen=True)
class Visible(ObjectsClaim):
    key = "visible"
    stage = EVERY_MOMENT
    example = 'visible = ["offset curve"]'

    def footprints(self) -> tuple[str, ...]:
        return self.objects

    def problems(self, seen: Seen) -> list[str]:
        out = []
        samples, times, head = seen.samples, seen.times, seen.head
        size = samples[0].size
        total = size[0] * size[1]

        def whole(name: str, s: Sample) -> int:
            """Its footprint (a live mark has none)."""
            return sum(s.footprint.get(n, 0) for n in seen.matched[name])

        def least_share(name: str, s: Sample) -> float:
            """VISIBLE_SHARE, or less for an object that is small as a whole (a marker)."""
            part = whole(name, s) / total
            return min(VISIBLE_SHARE, VISIBLE_PART * part) if part else VISIBLE_SHARE

        def shown_part(name: str, s: Sample) -> float:
            """What shows of it against its footprint (a live mark: all of it shows)."""
            footprint, area = whole(name, s), seen.area(name, s)
            return area / footprint if footprint else float(area > 0)

        for name in self.objects:
            if not seen.matched[name]:
                continue
            share = [seen.share(name, s) for s in samples]
            bad = [j for j, s in enumerate(samples) if share[j] < least_share(name, s)]
            if bad:
                least = min(share[j] for j in bad)
                out.append(
                    f"{head}: visible {name}: covers {100 * least:.3f} % of the screen at t = "
                    f"{time_spans(times, bad)}, less than {100 * VISIBLE_SHARE:.2f} % (or, for a "
                    f"small object, {100 * VISIBLE_PART:.0f} % of it)"
                )
                continue
            hidden = [
                j
                for j, s in enumerate(samples)
                if shown_part(name, s) < VISIBLE_PART and share[j] < PLAINLY_VISIBLE
            ]
            if hidden:
                least = min(shown_part(name, samples[j]) for j in hidden)
                out.append(
                    f"{head}: visible {name}: {100 * least:.0f} % of it shows at t = "
                    f"{time_spans(times, hidden)} (the rest is behind other objects), less than "
                    f"{100 * VISIBLE_PART:.0f} % and under {100 * PLAINLY_VISIBLE:.1f} % of the "
                    "screen"
                )
        return out
