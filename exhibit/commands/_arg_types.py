"""argparse types for numeric options, on the config layer's limits: a flag can carry no more
than a file can (NaN, inf, 1e-320 and 1e308 are refused as ``argument --x: reason``, exit 2),
and numbers are written with the ASCII digits only, as device inputs and files are
("１２８０" and "٣" are refused)."""

from __future__ import annotations

import argparse
from typing import Any, TypeVar
from collections.abc import Callable

from pydantic_core import PydanticCustomError

from exhibit.schema.types import MAX_DISTANCE, MIN_DISTANCE, number_check


T = TypeVar("T", int, float)


def _argtype(check: Callable[[Any], T], name: str) -> Callable[[str], T]:
    def parse(text: str) -> T:
        value: object = text
        if not text.isascii():  # int() and float() read "１２８０" and "٣" as numbers
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a number written with the ASCII digits 0-9"
            )
        if text.strip().lower() not in ("inf", "+inf"):
            try:
                value = int(text) if text.strip().lstrip("+-").isdigit() else float(text)
            except (ValueError, OverflowError):
                raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        else:
            value = float("inf")
        try:
            return check(value)
        except PydanticCustomError as exc:
            raise argparse.ArgumentTypeError(exc.message()) from None

    parse.__name__ = name  # argparse names the type in its messages
    return parse


def number(low: float, high: float, inf_ok: bool = False) -> Callable[[str], float]:
    """A finite number in [low, high] (``inf`` too with ``inf_ok``)."""
    return _argtype(number_check(low, high, inf_ok=inf_ok), "number")


def integer(low: int, high: int) -> Callable[[str], int]:
    check = number_check(low, high, integer=True)  # an int, typed as a float
    return _argtype(lambda value: int(check(value)), "whole number")


def seconds(high: float = 1e7) -> Callable[[str], float]:
    """A positive, finite duration: a wait that ends."""
    return number(1e-3, high)


def distance() -> Callable[[str], float]:
    """A sensor or eye distance: inf or in [MIN_DISTANCE, MAX_DISTANCE]."""
    return number(MIN_DISTANCE, MAX_DISTANCE, inf_ok=True)


def distances(text: str) -> list[float]:
    """Comma-separated distances (inf allowed)."""
    one = distance()
    return [one(item.strip()) for item in text.split(",")]
