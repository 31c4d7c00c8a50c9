"""The `exhibit` command as a user meets it: help, version, one-line errors with exit code 2."""

import json

import pytest

from exhibit import __version__
from exhibit.cli import COMMANDS, main


def test_help_lists_every_subcommand(cli):
    result = cli("--help")
    assert result.returncode == 0
    for name in COMMANDS:
        assert name in result.stdout


def test_version(cli):
    result = cli("--version")
    assert result.returncode == 0
    assert result.stdout.strip() == f"exhibit {__version__}"


def test_no_command_prints_help_and_exits_2(capsys):
    assert main([]) == 2
    assert "commands" in capsys.readouterr().out


@pytest.mark.parametrize("args, fragment", [
    (["sweep", "--distances", "3,banana"], "'banana' is not a number"),
    (["sweep", "--distances", "-1"], "must be positive"),
    (["sweep", "--samples", "2"], "at least 8"),
])
def test_bad_arguments_give_one_line_and_exit_2(cli, args, fragment):
    result = cli(*args)
    assert result.returncode == 2
    assert fragment in result.stderr
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_sweep_reproduces_figures_6_to_8(capsys):
    """The paper: as the sensor approaches, the green torus's image grows far more than the red."""
    assert main(["sweep", "--distances", "inf,3,2", "--samples", "61", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    growth = {name: rows[-1][name]["area"] / rows[0][name]["area"] for name in ("green", "red")}
    assert growth["green"] > 10 * growth["red"] > 10
    # By symmetry (x,z)<->(y,w) the green and red tori have equal images at infinity.
    assert rows[0]["green"]["area"] == pytest.approx(rows[0]["red"]["area"], rel=1e-9)
