"""Start-up work the first frames would otherwise pay for, done one piece per frame after the
first: every title and caption panel laid out and rasterised, and a frame drawn through a
crossfade at every quality level the governor may choose (software GL compiles each shader
variant at its first draw, and the crossfade's snapshot is allocated at the first cut: each a
long frame at the first scene change otherwise)."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable

log = logging.getLogger("exhibit.kiosk")


class WarmUp:
    """Chores in order; each returns whether it is done (False: try again next frame, e.g.
    while a crossfade holds the snapshot a quality level would draw through)."""

    def __init__(self, chores: Iterable[Callable[[], bool]] = ()):
        self.chores = list(chores)

    def __bool__(self) -> bool:
        return bool(self.chores)

    def step(self) -> None:
        """One piece (never fatal: the frames do it themselves when needed)."""
        chore = self.chores[0]
        try:
            if not chore():
                return
        except Exception as exc:  # noqa: BLE001
            log.warning("start-up warm-up step failed: %s", exc)
        self.chores.pop(0)

    def all(self) -> None:
        """Every piece left, now (a kiosk that prepares everything before its first frame:
        reviews, tests)."""
        while self.chores:
            self.chores.pop(0)()
