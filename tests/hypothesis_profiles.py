"""Hypothesis profiles: under CI every property test runs its full example count, as before these
profiles existed; on a workstation ("dev", the default there) a fraction of it, so the default
run is quick.

"ci" is Hypothesis's own profile, which it loads by itself when it detects CI (CI=true among
others): 100 examples, derandomized, no deadline, no example database. It is left as it is.
"dev" is Hypothesis's default profile with fewer examples. The profile is chosen once, when this
module is first imported (tests/conftest.py imports it before any test module): HYPOTHESIS_PROFILE
if set, else "ci" where Hypothesis detected CI, else "dev".

Tests that set their own count write ``@settings(max_examples=examples(300))``: 300 under "ci",
a fraction of it under "dev".
"""

import math
import os

from hypothesis import settings

#: The count every test without an explicit one runs under CI (Hypothesis's "ci" profile).
CI_EXAMPLES = settings.get_profile("ci").max_examples
#: The dev profile's share of each full count.
DEV_FRACTION = 0.2
#: Under "dev" no test drops below this many examples (or its full count, if that is smaller).
MIN_EXAMPLES = 10

# No deadline: a shared machine under load is no reason to fail (speed is for benchmarks).
settings.register_profile("dev", max_examples=round(CI_EXAMPLES * DEV_FRACTION), deadline=None)


def profile_name() -> str:
    explicit = os.environ.get("HYPOTHESIS_PROFILE")
    if explicit:
        return explicit
    # Hypothesis loaded its "ci" profile at import if it detected CI.
    return "ci" if settings.default is settings.get_profile("ci") else "dev"


PROFILE = profile_name()
settings.load_profile(PROFILE)


def examples(full: int) -> int:
    """The example count for a test whose full (CI) count is `full`."""
    if PROFILE != "dev":
        return full
    return min(full, max(MIN_EXAMPLES, math.ceil(full * DEV_FRACTION)))
