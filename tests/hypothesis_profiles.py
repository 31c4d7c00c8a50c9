"""Hypothesis profiles: "ci" runs every property test with its full example count, "dev" (the
default on a workstation) with a fraction of it, so the default run is quick and CI=true still
runs everything.

The profile is chosen once, when this module is first imported (tests/conftest.py imports it
before any test module): HYPOTHESIS_PROFILE if set, else "ci" under CI=true, else "dev".

Tests that set their own count write ``@settings(max_examples=examples(300))``: 300 under "ci",
a fraction of it under "dev".
"""

import math
import os

from hypothesis import settings

# Hypothesis's own default; the count every test without an explicit one runs under CI today.
CI_EXAMPLES = 100
# The dev profile's share of each full count.
DEV_FRACTION = 0.2
# No test drops below this many examples (or its full count, if that is smaller).
MIN_EXAMPLES = 10

settings.register_profile("ci", max_examples=CI_EXAMPLES)
settings.register_profile("dev", max_examples=round(CI_EXAMPLES * DEV_FRACTION))


def profile_name() -> str:
    explicit = os.environ.get("HYPOTHESIS_PROFILE")
    if explicit:
        return explicit
    return "ci" if os.environ.get("CI") == "true" else "dev"


PROFILE = profile_name()
settings.load_profile(PROFILE)


def examples(full: int) -> int:
    """The example count for a test whose full (CI) count is `full`."""
    if PROFILE == "ci":
        return full
    return min(full, max(MIN_EXAMPLES, math.ceil(full * DEV_FRACTION)))
