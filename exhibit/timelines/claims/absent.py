"""``absent = ["slice"]``: none of it shows at any moment the caption is shown ("Nothing
yet.")."""

from __future__ import annotations

from dataclasses import dataclass

from exhibit.timelines.claims.base import EVERY_MOMENT, ObjectsClaim, Seen, time_spans

#: At most this share of the screen (a few pixels of a mark at its first instant).
ABSENT_SHARE = 2e-5


@dataclass(frozen=True)
class Absent(ObjectsClaim):
    key = "absent"
    stage = EVERY_MOMENT
    example = 'absent = ["slice"]'

    def problems(self, seen: Seen) -> list[str]:
        out = []
        for name in self.objects:
            if not seen.matched[name]:
                continue
            share = [seen.share(name, s) for s in seen.samples]
            bad = [j for j, x in enumerate(share) if x > ABSENT_SHARE]
            if bad:
                most = max(share[j] for j in bad)
                out.append(
                    f"{seen.head}: absent {name}: covers {100 * most:.3f} % of the screen at "
                    f"t = {time_spans(seen.times, bad)}, more than {100 * ABSENT_SHARE:.3f} %"
                )
        return out
