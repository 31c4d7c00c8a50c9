"""Every mark explained (`exhibit render --timeline --verify`): an object that covers a visible
share of the screen while a caption is shown must be named by some word on screen: the caption
(its claims name objects), a tag (its labels), or the key under the numbers (Hud.explained).

A yellow disc the key calls a pinch point, a blue ellipse, a mint wire pipe: a visitor sees each
mark and asks what it is; a picture that shows what no word names leaves the question open."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from exhibit.review.tags_seen import TagFault
from exhibit.timelines.claims.base import Sample, matching, time_spans
from exhibit.timelines.model import Condition

#: An object a visitor notices: this share of the screen as seen (not behind others or the
#: HUD), a 2 px line about 70 px long at 1280x720 (the hypersphere's axis lines are 2 to 4
#: times that).
NOTICED_SHARE = 1.5e-4


@dataclass(frozen=True)
class FrameWords:
    """What the words of one frame name besides its caption's claims (the objects its tags and
    its key name, as the id pass names them), and its tags' faults."""

    named: frozenset[str] = frozenset()
    tag_faults: tuple[TagFault, ...] = ()


def unexplained_problems(
    condition: Condition,
    labels: Sequence[str],
    samples: Sequence[Sample],
    frames: Sequence[FrameWords],
    head: str,
) -> list[str]:
    """One line per object that covers NOTICED_SHARE of the screen in some sample of a caption
    while no word names it: not the caption's claims, its ``labels`` (the objects it tags,
    though a tag may be left out where its object has no point in front) nor the frame's tags
    and key (``frames[j]``: sample j's)."""
    if not samples:
        return []
    objects = samples[0].objects
    claimed = {o for c in condition.claims for n in c.names() for o in matching(n, objects)}
    claimed |= {o for n in labels for o in matching(n, objects)}
    bare: dict[str, list[int]] = {}
    most: dict[str, float] = {}
    for j, (sample, words) in enumerate(zip(samples, frames)):
        total = float(sample.size[0] * sample.size[1])
        for name in dict.fromkeys(sample.objects):
            if name in claimed or name in words.named:
                continue
            share = sample.pixels.get(name, 0) / total
            if share >= NOTICED_SHARE:
                bare.setdefault(name, []).append(j)
                most[name] = max(most.get(name, 0.0), share)
    times = [s.t for s in samples]
    return [
        f"{head}: {name!r} covers up to {100 * most[name]:.1f} % of the screen at t = "
        f"{time_spans(times, bare[name])}, and no word on screen names it (a claim of the "
        "caption, a label, or the key)"
        for name in bare
    ]
