"""The hypothesis profiles (tests/hypothesis_profiles.py): CI=true runs every property test with
its full example count, as before the profiles existed; the default run a fraction."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PROBE = ("from hypothesis import settings; import tests.hypothesis_profiles as h; "
         "print(h.PROFILE, settings.default.max_examples, h.examples(300), h.examples(40), "
         "h.examples(6))")


def probe(**env) -> list[str]:
    clean = {k: v for k, v in os.environ.items() if k not in ("CI", "HYPOTHESIS_PROFILE")}
    out = subprocess.run([sys.executable, "-c", PROBE], env={**clean, **env}, cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout
    return out.split()


@pytest.mark.parametrize("env", [{"CI": "true"}, {"HYPOTHESIS_PROFILE": "ci"}])
def test_ci_runs_the_full_counts(env):
    assert probe(**env) == ["ci", "100", "300", "40", "6"]


@pytest.mark.parametrize("env", [{}, {"CI": "false"}])
def test_the_default_run_runs_a_fraction(env):
    name, default, n300, n40, n6 = probe(**env)
    assert name == "dev"
    assert int(default) < 100 and int(n300) < 300 and int(n40) < 40
    assert int(n6) == 6  # never more than the full count, never below the floor otherwise
