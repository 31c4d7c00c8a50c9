"""What a caption claims in ``while``, one kind a module (issue 43), as exhibit.render.passes
holds the render passes: each kind owns its key and schema fragment, what it makes of the value,
its count, its check on the samples and its message (:mod:`.base` says what a kind is).

KINDS lists them in the order the ``while`` table's keys are read, checked and named. A new kind
is a module here and a line in KINDS; exhibit.timelines.file reads it, check-config
(exhibit.timelines.captions) checks it on the timeline file when it is a view condition,
`exhibit render --timeline --verify` (exhibit.review.claims) on the frames, and
tests/kiosk/test_claims.py holds docs/KIOSK.md to the list."""

from __future__ import annotations

from exhibit.timelines.claims.absent import Absent
from exhibit.timelines.claims.angles_within import AnglesWithin
from exhibit.timelines.claims.at import At
from exhibit.timelines.claims.base import Claim
from exhibit.timelines.claims.covers import Covers
from exhibit.timelines.claims.fills import Fills
from exhibit.timelines.claims.grows import Grows
from exhibit.timelines.claims.outgrows import Outgrows
from exhibit.timelines.claims.sensor_distance import SensorDistance
from exhibit.timelines.claims.sensor_motion import SensorMotion
from exhibit.timelines.claims.shrinks import Shrinks
from exhibit.timelines.claims.visible import Visible

KINDS: tuple[type[Claim], ...] = (
    SensorDistance,
    SensorMotion,
    AnglesWithin,
    Visible,
    Absent,
    Grows,
    Shrinks,
    Outgrows,
    Fills,
    At,
    Covers,
)
