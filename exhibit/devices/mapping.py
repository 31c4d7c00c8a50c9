"""From device events to the exhibit's seven parameters: θ1..θ6 and the sensor distance.

Which input drives which parameter is configuration (a list of bindings, see
:mod:`exhibit.devices.config`); this module does the arithmetic:

- knob detents (REL events) are angle steps: ``step`` degrees per detent, applied once;
- 6-axis deflection (ABS events) is an angular rate: ``rate`` degrees per second at full
  deflection, after a dead zone (rescaled so the output rises from 0 at its edge, no jump) and a
  sensitivity curve ``|x| ** curve`` (1 = linear, 2 = fine control near rest). The held
  deflection is integrated over the time between event stamps (the controller's own sampling
  instants) and up to ``now``;
- a held button bound to a parameter is a rate too (full deflection while held): the controller's
  sensor buttons, a zoom rocker;
- inversion per binding; several devices and bindings may drive one parameter at once;
- angles wrap to (-180°, 180°] unless a parameter has limits;
- the sensor moves in r = 1/d: r = 0 is the sensor at infinity (orthographic), a normal value
  that a knob reaches and rests on; r never goes below 0 (no "beyond infinity") nor above
  1 / ``sensor_min_distance``.

Buttons may also do an action: ``home`` (every parameter back to its home value),
``next-scene`` (the kiosk moves on: :meth:`Mapper.switches_scene`), ``language`` (the kiosk
shows the next of its languages: exhibit.kiosk.language) or ``listen`` (narration on or off:
exhibit.kiosk.narrator; a press that is no takeover, so attract mode goes on, spoken). A
button with no binding at all moves to the next scene too, so a knob box's unbound push
buttons do something.

Limits never make the view jump: a value the exhibit put outside them (an attract timeline, a
scene's start pose) is not pulled back, it just cannot move further out.

The :class:`ActivityDetector` tells the kiosk's idle logic whether a person is there: detents and
button presses count; an axis counts only when it is off its slowly adapting baseline by more
than a threshold, so noise and a drifting pot do not keep the exhibit out of attract mode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, get_args
from collections.abc import Iterable

from exhibit.devices.base import Event, Kind
from exhibit.geometry.view import ViewState

__all__ = [
    "PARAMS",
    "ACTIONS",
    "Param",
    "Action",
    "Binding",
    "ParamLimits",
    "MappingConfig",
    "Mapper",
    "ActivityDetector",
    "shape",
]

#: The seven parameters a device can drive, in order.
Param = Literal["theta1", "theta2", "theta3", "theta4", "theta5", "theta6", "sensor"]
PARAMS: tuple[Param, ...] = get_args(Param)
#: What a button can do instead of driving a parameter.
Action = Literal["home", "next-scene", "language", "listen"]
ACTIONS: tuple[Action, ...] = get_args(Action)
SENSOR = 6
MAX_DT = 0.5  # a stalled loop does not turn into a lurch


@dataclass(frozen=True)
class Binding:
    """One input channel driving one parameter (or, for a button, doing an action)."""

    device: str
    kind: Kind
    index: int  # 0-based channel
    param: str | None = None  # one of PARAMS; None for a button with an action
    step: float = 0.0  # REL: degrees (sensor: r) per detent
    rate: float = 0.0  # ABS, BUTTON: degrees (sensor: r) per second at full deflection / held
    dead_zone: float = 0.0
    curve: float = 1.0
    invert: bool = False
    action: str | None = None  # BUTTON: one of ACTIONS
    #: BUTTON with an action: it fires once the button has been held this long (a long press),
    #: not when pressed; None: when pressed.
    hold_s: float | None = None


@dataclass(frozen=True)
class ParamLimits:
    """Limits of one angle in degrees; None = wraps around."""

    low: float | None = None
    high: float | None = None


@dataclass(frozen=True)
class MappingConfig:
    bindings: tuple[Binding, ...] = ()
    #: the closest the sensor may come; r stays in [0, 1/sensor_min_distance]
    sensor_min_distance: float = 2.0
    limits: dict[str, ParamLimits] = field(default_factory=dict)
    #: where "home" puts the angles (degrees) and the sensor (distance; inf allowed)
    home_angles: tuple[float, ...] = (0.0,) * 6
    home_sensor_distance: float = math.inf

    @property
    def sensor_r_max(self) -> float:
        return 1.0 / self.sensor_min_distance


def shape(x: float, dead_zone: float, curve: float) -> float:
    """Dead zone, rescaled so the output starts at 0 at its edge, then ``|x| ** curve``."""
    a = abs(x)
    if a <= dead_zone:
        return 0.0
    s = min(1.0, (a - dead_zone) / (1.0 - dead_zone)) ** curve
    return s if x > 0 else -s


class ActivityDetector:
    """Whether someone is using the exhibit, for the kiosk's idle logic.

    An axis counts when it is more than ``threshold`` off its baseline. The baseline follows a
    small offset quickly (``settle_s``: noise, a pot resting just outside the firmware's dead
    zone) and any offset slowly (``drift_s``: a stick stuck far out stops counting after a
    while; a visitor holding a stick this long is rare and moves again).
    """

    def __init__(self, threshold: float = 0.15, settle_s: float = 3.0, drift_s: float = 30.0):
        self.threshold, self.settle_s, self.drift_s = threshold, settle_s, drift_s
        self.last_active: float | None = None
        self._axes: dict[tuple[str, int], list[float]] = {}  # key -> [value, baseline, t]

    def _mark(self, t: float) -> None:
        if self.last_active is None or t > self.last_active:
            self.last_active = t

    def _settle(self, st: list[float], t: float) -> None:
        dt = t - st[2]
        if dt <= 0:
            return
        off = st[0] - st[1]
        tau = self.settle_s if abs(off) < 2 * self.threshold else self.drift_s
        st[1] += off * (1.0 - math.exp(-dt / tau))
        st[2] = t

    def observe(self, e: Event) -> None:
        if e.kind is Kind.REL or e.kind is Kind.BUTTON:
            if e.value:
                self._mark(e.t)
        else:
            st = self._axes.setdefault((e.device, e.index), [0.0, 0.0, e.t])
            self._settle(st, e.t)
            st[0] = e.value
            if abs(e.value - st[1]) > self.threshold:
                self._mark(e.t)

    def update(self, now: float) -> None:
        """A held deflection keeps counting (no events arrive while it is steady)."""
        for st in self._axes.values():
            self._settle(st, now)
            if abs(st[0] - st[1]) > self.threshold:
                self._mark(now)

    def idle_for(self, now: float) -> float:
        """Seconds since the last real input (inf if there never was any)."""
        return math.inf if self.last_active is None else max(0.0, now - self.last_active)


class Mapper:
    """Applies events to a ViewState. Keeps the held deflections between calls, so call it
    every frame with the new events (possibly none) and the current time."""

    def __init__(self, config: MappingConfig, activity: ActivityDetector | None = None):
        self.config = config
        self.activity = activity or ActivityDetector()
        self._by_channel: dict[tuple[str, Kind, int], list[Binding]] = {}
        for b in config.bindings:
            self._by_channel.setdefault((b.device, b.kind, b.index), []).append(b)
        # held channel (device, kind, index) -> [held value, time integrated up to]: axes, and
        # buttons that drive a parameter while held
        self._held: dict[tuple[str, Kind, int], list[float]] = {}
        self._rate_buttons = {
            key
            for key, binds in self._by_channel.items()
            if key[1] is Kind.BUTTON and any(b.param for b in binds)
        }
        # long presses: channel -> when its button went down (None once it has fired)
        self._holds: dict[tuple[str, Kind, int], float | None] = {}
        #: Actions whose long press came due in the latest apply().
        self.fired: set[str] = set()

    def switches_scene(self, e: Event) -> bool:
        """Whether ``e`` asks the kiosk for the next scene: a press of a ``next-scene`` button,
        or of a button bound to nothing."""
        if e.kind is not Kind.BUTTON or not e.value > 0:
            return False
        binds = self._by_channel.get((e.device, e.kind, e.index), ())
        return not binds or any(b.action == "next-scene" for b in binds)

    def button_role(self, device: str, index: int) -> str:
        """What a button does, for people: "home", "next-scene", "sensor +" (held: a rate; "-"
        when inverted), several joined by ", "."""
        binds = self._by_channel.get((device, Kind.BUTTON, index), ())
        if not binds:
            return "next-scene"  # as switches_scene: a button bound to nothing
        return ", ".join(
            (f"{b.action} (held {b.hold_s:g} s)" if b.hold_s else b.action)
            or f"{b.param} {'-' if b.invert else '+'}"
            for b in binds
        )

    def pressed(self, events: Iterable[Event], action: str) -> bool:
        """Whether ``events`` press a button bound to ``action`` (one of ACTIONS), or a long
        press of one came due in the latest apply()."""
        return action in self.fired or any(
            e.kind is Kind.BUTTON
            and e.value > 0
            and any(
                b.action == action and b.hold_s is None
                for b in self._by_channel.get((e.device, e.kind, e.index), ())
            )
            for e in events
        )

    def without(self, events: list[Event], action: str) -> list[Event]:
        """``events`` less those of buttons bound to ``action`` alone: a ``listen`` press is no
        visitor taking over (attract mode goes on, spoken)."""
        return [
            e
            for e in events
            if not (
                e.kind is Kind.BUTTON
                and (binds := self._by_channel.get((e.device, e.kind, e.index), ()))
                and all(b.action == action for b in binds)
            )
        ]

    def _long_presses(self, e: Event, key, now: float) -> None:
        """Track the buttons of long-press bindings: down starts the wait, up ends it."""
        if e.kind is not Kind.BUTTON or not any(
            b.hold_s is not None for b in self._by_channel.get(key, ())
        ):
            return
        if e.value > 0:
            if key not in self._holds:
                self._holds[key] = min(e.t, now)
        else:
            self._holds.pop(key, None)

    def _due(self, now: float) -> set[str]:
        """The actions whose button has now been held for its hold_s (each fires once)."""
        fired = set()
        for key, down in self._holds.items():
            if down is None:
                continue
            due = [
                b for b in self._by_channel[key] if b.hold_s is not None and now - down >= b.hold_s
            ]
            if due:
                # load_mapping gives hold_s only to an action button
                fired |= {b.action for b in due if b.action is not None}
                self._holds[key] = None
        return fired

    def _integrate(
        self, key: tuple[str, Kind, int], st: list[float], t: float, acc: list[float]
    ) -> None:
        dt = t - st[1]
        if dt <= 0:
            return
        st[1] = t
        if st[0] == 0.0:
            return
        dt = min(dt, MAX_DT)
        for b in self._by_channel.get(key, ()):
            if b.param is None:
                continue
            v = shape(st[0], b.dead_zone, b.curve) * b.rate * dt
            acc[PARAMS.index(b.param)] += -v if b.invert else v

    def apply(self, view: ViewState, events: Iterable[Event], now: float) -> ViewState:
        """The view after ``events`` and the time up to ``now``."""
        acc = [0.0] * 7
        home = False
        for e in events:
            if not math.isfinite(e.value):  # a corrupt source must not poison the view
                continue
            self.activity.observe(e)
            key = (e.device, e.kind, e.index)
            self._long_presses(e, key, now)
            if e.kind is Kind.ABS or key in self._rate_buttons:
                st = self._held.get(key)
                if st is None:
                    st = self._held[key] = [0.0, min(e.t, now)]
                self._integrate(key, st, min(e.t, now), acc)
                st[0] = e.value if e.kind is Kind.ABS else float(e.value > 0)
            for b in self._by_channel.get(key, ()):
                if e.kind is Kind.REL and b.param is not None:
                    v = e.value * b.step
                    acc[PARAMS.index(b.param)] += -v if b.invert else v
                elif e.kind is Kind.BUTTON and e.value > 0 and b.action == "home":
                    home = True
        for key, st in self._held.items():
            self._integrate(key, st, now, acc)
        self.fired = self._due(now)
        self.activity.update(now)
        if home:
            view = self.home(view)
        if not any(acc):
            return view
        return self._step(view, acc)

    def home(self, view: ViewState) -> ViewState:
        cfg = self.config
        r = 0.0 if math.isinf(cfg.home_sensor_distance) else 1.0 / cfg.home_sensor_distance
        return view.replace(angles=tuple(math.radians(a) for a in cfg.home_angles), sensor_r=r)

    def _step(self, view: ViewState, acc: list[float]) -> ViewState:

        angles = list(view.angles)
        for i in range(6):
            if not acc[i]:
                continue
            lim = self.config.limits.get(PARAMS[i])
            a = angles[i] + math.radians(acc[i])
            if lim is None or (lim.low is None and lim.high is None):
                a = math.remainder(
                    a, 2 * math.pi
                )  # (-pi, pi]: any multiple of 2 pi is the same view
                if a == -math.pi:
                    a = math.pi
            else:
                a = _bounded(
                    angles[i],
                    a,
                    lim.low and math.radians(lim.low),
                    lim.high and math.radians(lim.high),
                )
            angles[i] = a
        r = view.sensor_r
        if acc[SENSOR]:
            r = max(0.0, _bounded(r, r + acc[SENSOR], 0.0, self.config.sensor_r_max))
        return view.replace(angles=tuple(angles), sensor_r=r)


def _bounded(old: float, new: float, low: float | None, high: float | None) -> float:
    """``new`` kept within [low, high], except that a value already outside is not pulled in:
    it may only move back towards the range."""
    if high is not None and new > high:
        new = max(min(old, new), high)
    if low is not None and new < low:
        new = min(max(old, new), low)
    return new
