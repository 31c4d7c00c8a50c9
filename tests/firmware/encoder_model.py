"""A bouncing rotary encoder (EC11 type, one full quadrature cycle per detent) turned by a
visitor, sampled as the knob box samples it: the test input for the Gray-code decoder.

A plan of moves (whole detents at a speed, half-turns that come back, pauses) becomes edge
times on the A and B contacts: four edges per detent, unevenly spaced (the phase error of a cheap
encoder, up to +-30 % of a quarter cycle). Every edge bounces: the contact flips back and forth
a random number of times for up to ``bounce_s`` before it settles. The contacts are then sampled
every 1 / ``rate_hz`` from a random phase.

``expected`` is what an ideal decoder reports: a detent each time the position reaches a
multiple of four quarter steps other than the last one it reported, with its direction.
"""

from __future__ import annotations

import bisect
import random
from dataclasses import dataclass, field

CW = (0b01, 0b11, 0b10, 0b00)  # AB states clockwise from rest at 00 (firmware/common/quad.c)


@dataclass
class Encoder:
    rng: random.Random
    bounce_s: float = 0.002
    max_speed: float = 10.0  # detents per second
    rate_hz: float = 2000.0
    phase_error: float = 0.3
    #: per contact (A, B): sorted transition times and the level after each
    _times: list[list[float]] = field(default_factory=lambda: [[], []])
    _levels: list[list[int]] = field(default_factory=lambda: [[], []])
    t: float = 0.0
    pos: int = 0  # quarter steps
    expected: list[int] = field(default_factory=list)
    _last_detent: int = 0

    def state(self, pos: int) -> int:
        return CW[(pos - 1) % 4]

    def _edge(self, t: float, bit: int, level: int) -> None:
        """One contact changes to ``level`` at t, bouncing for up to bounce_s."""
        c = 0 if bit == 0b10 else 1
        toggles = self.rng.choice([0, 2, 4, 6, 8])
        length = self.rng.uniform(0, self.bounce_s)
        times = sorted(self.rng.uniform(t, t + length) for _ in range(toggles))
        seq = [t] + times
        for i, when in enumerate(seq):
            self._times[c].append(when)
            self._levels[c].append(level if i % 2 == 0 else 1 - level)
        # the last entry is the settled level: an even number of toggles after the edge
        assert self._levels[c][-1] == level

    def _step(self, direction: int, dt: float) -> None:
        old = self.state(self.pos)
        self.pos += direction
        new = self.state(self.pos)
        changed = old ^ new
        self.t += dt
        self._edge(self.t, changed, 1 if new & changed else 0)
        if self.pos % 4 == 0 and self.pos != self._last_detent:
            self.expected.append(1 if self.pos > self._last_detent else -1)
            self._last_detent = self.pos

    def _quarters(self, speed: float) -> list[float]:
        """The four quarter-cycle durations of one detent at ``speed`` detents/s."""
        q = [0.25 * (1 + self.rng.uniform(-self.phase_error, self.phase_error)) for _ in range(4)]
        total = sum(q)
        return [x / total / speed for x in q]

    def turn(self, detents: int, speed: float) -> None:
        direction = 1 if detents > 0 else -1
        for _ in range(abs(detents)):
            for dt in self._quarters(speed):
                self._step(direction, dt)

    def wiggle(self, quarters: int, speed: float) -> None:
        """Part of a detent and back: no detent."""
        direction = self.rng.choice((1, -1))
        qs = self._quarters(speed)
        for i in range(quarters):
            self._step(direction, qs[i])
        for i in range(quarters):
            self._step(-direction, qs[i])

    def pause(self, seconds: float) -> None:
        self.t += seconds

    def visitor(self, moves: int) -> "Encoder":
        """A random session: turns both ways at up to max_speed, wiggles, pauses."""
        self.pause(0.05)
        for _ in range(moves):
            speed = self.rng.uniform(0.5, self.max_speed)
            r = self.rng.random()
            if r < 0.6:
                self.turn(self.rng.choice((1, -1)) * self.rng.randint(1, 12), speed)
            elif r < 0.8:
                self.wiggle(self.rng.randint(1, 3), speed)
            else:
                self.pause(self.rng.uniform(0.0, 0.3))
            # a reversal waits at least a quarter cycle (a hand cannot turn back faster)
            self.pause(0.25 / speed)
        self.pause(0.05)
        return self

    def samples(self) -> list[int]:
        """AB every 1 / rate_hz over the whole session, from a random phase."""
        order = [sorted(zip(self._times[c], range(len(self._times[c])))) for c in (0, 1)]
        times = [[t for t, _ in o] for o in order]
        levels = [[self._levels[c][i] for _, i in order[c]] for c in (0, 1)]
        start = self.rng.uniform(0, 1 / self.rate_hz)
        out = []
        n = int((self.t - start) * self.rate_hz)
        for k in range(n):
            ts = start + k / self.rate_hz
            ab = 0
            for c in (0, 1):
                i = bisect.bisect_right(times[c], ts) - 1
                level = levels[c][i] if i >= 0 else 0
                ab |= level << (1 - c)
            out.append(ab)
        return out
