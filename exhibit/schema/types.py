"""Field types shared by every config file, defined once so no two files disagree on a limit.

Each type is a pydantic plain validator with its own message, so an error reads like
``must lie in [4, 512], got 2`` rather than pydantic's wording, and bool is never a number.
A field names its Python type and its limits: ``x: Annotated[float, Number(0, 10)] = 5`` (the
helpers return the validator, so a type checker reads the field as a float); the common ones
have names (``Angle``, ``Distance``, ``Name``...).
Limits are chosen so that everything accepted can be run: no step or rate that overflows, no
distance whose reciprocal is inf, no angle that loses all precision.
"""

from __future__ import annotations

import math
import re
import unicodedata
from typing import Annotated, Any
from collections.abc import Callable

from pydantic import BaseModel, ConfigDict, PlainValidator
from pydantic_core import PydanticCustomError

#: The one mesh resolution cap (cells per axis) for scene files, the kiosk and the CLI.
MAX_RESOLUTION = 512
MIN_RESOLUTION = 4
#: The closest any sensor or eye may come (a distance below it makes r = 1/d explode), and the
#: farthest finite one; ``inf`` is allowed where a distance may be at infinity.
MIN_DISTANCE = 0.05
MAX_DISTANCE = 1e6
#: Angles in degrees: ten turns either way is more than any timeline needs.
MAX_ANGLE = 3600.0
#: Coordinates of boxes and positions in 4D.
MAX_COORDINATE = 1e4


class Model(BaseModel):
    """A table of a config file: unknown keys are mistakes, values are never coerced."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


def fail(reason: str, value: Any = None, show: bool = True) -> PydanticCustomError:
    """The error a validator raises; the value is shown shortened (it may be a megabyte)."""
    if show:
        reason = f"{reason}, got {shorten(value)}"
    return PydanticCustomError("exhibit", reason.replace("{", "{{").replace("}", "}}"))


def shorten(value: Any, width: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= width else text[: width - 5] + "…" + text[-4:]


def _g(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:g}"


def number_check(
    low: float, high: float, integer: bool = False, inf_ok: bool = False
) -> Callable[[Any], float]:
    """A checker for a finite number in [low, high] (a whole number with ``integer``; also
    ``inf`` or "inf" with ``inf_ok``). Booleans, NaN and strings are refused."""
    noun = "a whole number" if integer else "a number"
    rng = f"[{_g(low)}, {_g(high)}]"
    want = f"{noun} in {rng}" + (' or "inf"' if inf_ok else "")

    def check(value: Any) -> float:
        if inf_ok and value == "inf":
            return math.inf
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise fail(f"must be {want}", value)
        if inf_ok and isinstance(value, float) and value == math.inf:
            return math.inf
        if isinstance(value, float) and not math.isfinite(value):
            raise fail(f"must be {want}", value)
        if integer and isinstance(value, float) and not value.is_integer():
            raise fail(f"must be {want}", value)
        if not low <= value <= high:
            raise fail(f"must lie in {rng}", value)
        return int(value) if integer else float(value)

    return check


def Number(low: float = -1e9, high: float = 1e9, *, inf_ok: bool = False) -> PlainValidator:
    """A finite float in [low, high]; with ``inf_ok`` also +inf (written inf or "inf").
    Used as ``Annotated[float, Number(0, 10)]``."""
    return PlainValidator(number_check(low, high, inf_ok=inf_ok))


def Integer(low: int, high: int) -> PlainValidator:
    """A whole number in [low, high], as an int: ``Annotated[int, Integer(0, 16)]``."""
    return PlainValidator(number_check(low, high, integer=True))


def numbers_check(
    count: int, low: float = -1e9, high: float = 1e9, integer: bool = False
) -> Callable[[Any], tuple[float, ...]]:
    """A checker for a list of exactly ``count`` finite numbers in [low, high]."""
    one = number_check(low, high, integer=integer)
    noun = "whole numbers" if integer else "numbers"

    def check(value: Any) -> tuple[float, ...]:
        if not isinstance(value, (list, tuple)) or len(value) != count:
            raise fail(f"must be a list of {count} {noun} in [{_g(low)}, {_g(high)}]", value)
        out = []
        for i, v in enumerate(value):
            try:
                out.append(one(v))
            except PydanticCustomError as exc:
                raise fail(f"item {i + 1} {exc.message()}", show=False) from None
        return tuple(out)

    return check


def Numbers(
    count: int, low: float = -1e9, high: float = 1e9, *, integer: bool = False
) -> PlainValidator:
    """A list of exactly ``count`` finite numbers in [low, high], as a tuple:
    ``Annotated[tuple[float, ...], Numbers(3, 0.0, 1.0)]``."""
    return PlainValidator(numbers_check(count, low, high, integer))


def text_check(
    max_length: int, multiline: bool = False, empty_ok: bool = False
) -> Callable[[Any], str]:
    """Text shown to people: a string, not too long, no control characters (which would print
    as boxes or move a terminal's cursor)."""

    def check(value: Any) -> str:
        if not isinstance(value, str):
            raise fail("must be a string", value)
        if not value.strip() and not empty_ok:
            raise fail("must not be empty", value)
        if len(value) > max_length:
            raise fail(f"is {len(value)} characters, more than {max_length}", show=False)
        allowed = "\n\t" if multiline else ""
        for i, ch in enumerate(value):
            if ch not in allowed and unicodedata.category(ch) in ("Cc", "Cs", "Co"):
                raise fail(f"has a control character {ch!r} at {i + 1}", show=False)
        return value

    return check


def Text(
    max_length: int = 200, *, multiline: bool = False, empty_ok: bool = False
) -> PlainValidator:
    """Text shown to people (see ``text_check``): ``Annotated[str, Text(100)]``."""
    return PlainValidator(text_check(max_length, multiline, empty_ok))


#: Angles in degrees and distances (sensor, eye): the same everywhere.
Angle = Annotated[float, Number(-MAX_ANGLE, MAX_ANGLE)]
Distance = Annotated[float, Number(MIN_DISTANCE, MAX_DISTANCE, inf_ok=True)]
Resolution = Annotated[int, Integer(MIN_RESOLUTION, MAX_RESOLUTION)]
Seconds = Annotated[float, Number(0.0, 86400.0)]
Coordinate = Annotated[float, Number(-MAX_COORDINATE, MAX_COORDINATE)]
#: Zoom: half the height of the view, in 3D units.
HalfHeight = Annotated[float, Number(1e-3, 1e3)]
Name = Annotated[str, Text(100)]
Caption = Annotated[str, Text(2000, multiline=True, empty_ok=True)]
#: A keyframe's spoken description of the picture (exhibit.narration): never blank, and short
#: enough to be spoken in about 40 s.
Description = Annotated[str, Text(600, multiline=True)]


def _distance_range(value: Any) -> tuple[float, float]:
    """A range of distances for a condition: "inf" (at infinity) or [low, high], either end a
    distance (high may be "inf"), low <= high."""
    want = 'must be "inf" or [low, high] distances with low <= high (high may be "inf")'
    one = number_check(MIN_DISTANCE, MAX_DISTANCE, inf_ok=True)
    if value == "inf":
        return (math.inf, math.inf)
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise fail(want, value)
    out = []
    for i, v in enumerate(value):
        try:
            out.append(one(v))
        except PydanticCustomError as exc:
            raise fail(f"item {i + 1} {exc.message()}", show=False) from None
    if out[0] > out[1]:
        raise fail(want, value)
    return (out[0], out[1])


#: A range of sensor distances, as a caption's condition states it.
DistanceRange = Annotated[tuple[float, float], PlainValidator(_distance_range)]


def distance_to_r(distance: float) -> float:
    """r = 1/d, the form every view uses (r = 0 is a sensor at infinity)."""
    return 0.0 if math.isinf(distance) else 1.0 / distance


MODIFIERS = ("alt", "ctrl", "shift", "super")


def _quit_keys(value: Any) -> tuple[str, ...]:
    """At least two distinct modifiers and one key, so no visitor presses it by chance; empty
    means no way to quit."""
    if not isinstance(value, str):
        raise fail('must be a string like "ctrl+alt+shift+q"', value)
    if not value.strip():
        return ()
    combo = [k.strip().lower() for k in value.split("+")]
    mods = [k for k in combo if k in MODIFIERS]
    rest = [k for k in combo if k not in MODIFIERS]
    if (
        len(set(mods)) < 2
        or len(mods) != len(set(mods))
        or len(rest) != 1
        or not re.fullmatch(r"[a-z0-9]|f\d{1,2}|escape", rest[0])
    ):
        raise fail(
            f"must be at least two different modifiers of {'/'.join(MODIFIERS)} and "
            'one key, like "ctrl+alt+shift+q" (so no visitor can press it by chance)',
            value,
        )
    return tuple(combo)


QuitKeys = Annotated[tuple[str, ...], PlainValidator(_quit_keys)]
