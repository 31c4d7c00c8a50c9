"""The hypothesis profiles (tests/hypothesis_profiles.py): under CI every property test runs with
its full example count and Hypothesis's own CI settings, as before the profiles existed; the
default run a fraction."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PROBE = (
    "from hypothesis import settings; import tests.hypothesis_profiles as h; "
    "s = settings.default; print(h.PROFILE, s.max_examples, s.derandomize, "
    "s.database is None, h.examples(300), h.examples(40), h.examples(6))"
)
#: Variables by which Hypothesis recognises CI (hypothesis/_settings.py, _CI_VARS).
CI_VARIABLES = (
    "CI",
    "TF_BUILD",
    "BUILDKITE",
    "CIRCLECI",
    "CIRRUS_CI",
    "CODEBUILD_BUILD_ID",
    "GITHUB_ACTIONS",
    "GITLAB_CI",
    "HEROKU_TEST_RUN_ID",
    "TEAMCITY_VERSION",
    "bamboo.buildKey",
    "HYPOTHESIS_PROFILE",
)


def probe(**env) -> list[str]:
    clean = {k: v for k, v in os.environ.items() if k not in CI_VARIABLES}
    out = subprocess.run(
        [sys.executable, "-c", PROBE],
        env={**clean, **env},
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return out.split()


@pytest.mark.parametrize(
    "env", [{"CI": "true"}, {"GITHUB_ACTIONS": "true"}, {"HYPOTHESIS_PROFILE": "ci"}]
)
def test_ci_runs_the_full_counts_with_hypothesis_own_ci_settings(env):
    assert probe(**env) == ["ci", "100", "True", "True", "300", "40", "6"]


def test_the_default_run_runs_a_fraction():
    name, default, derandomize, _, n300, n40, n6 = probe()
    assert name == "dev" and derandomize == "False"
    assert int(default) < 100 and int(n300) < 300 and int(n40) < 40
    assert int(n6) == 6  # never more than the full count, never below the floor otherwise
