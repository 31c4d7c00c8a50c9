"""The `exhibit` command as a user meets it: help, version, one-line errors with exit code 2."""

import json
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit import __version__
from exhibit.cli import COMMANDS, main
from tests.hypothesis_profiles import examples


def test_help_lists_every_subcommand(cli):
    """The commands `exhibit --help` lists (argparse's "    name  help" lines, each a whole
    word) are the ones the README's command table documents, and the ones the parser runs."""
    result = cli("--help")
    assert result.returncode == 0
    listed = re.findall(r"^ {4}([a-z][a-z-]*)(?: |$)", result.stdout, re.M)
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    documented = set(re.findall(r"^\| `exhibit ([a-z][a-z-]*)", readme, re.M))
    assert len(listed) == len(set(listed)) and set(listed) == documented
    assert set(listed) == set(COMMANDS)


def test_version(cli):
    result = cli("--version")
    assert result.returncode == 0
    assert result.stdout.strip() == f"exhibit {__version__}"


def test_no_command_prints_help_and_exits_2(capsys):
    assert main([]) == 2
    assert "commands" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["sweep", "--distances", "3,banana"], "'banana' is not a number"),
        (["sweep", "--distances", "-1"], "argument --distances: must lie in [0.05"),
        (["sweep", "--distances", "1e-320"], "argument --distances: must lie in [0.05"),
        (["devices", "--wait", "inf"], "argument --wait: must be a number in [0, 60]"),
        (["monitor", "--duration", "nan"], "argument --duration: must be a number"),
        (
            ["render", "hopf", "--sensor-distance", "1e-320", "--out", "x.png"],
            "--sensor-distance: must lie in",
        ),
        (["sweep", "--samples", "2"], "argument --samples: must lie in [8, 2048]"),
    ],
)
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


def test_a_closed_pipe_ends_quietly(tmp_path):
    """`exhibit scenes --json | true`: the reader is gone before the first write."""
    import subprocess
    import sys

    err = tmp_path / "err"
    result = subprocess.run(
        [
            "bash",
            "-o",
            "pipefail",
            "-c",
            f"{sys.executable} -m exhibit scenes --json 2>{err} | true",
        ]
    )
    assert result.returncode == 141  # 128 + SIGPIPE, as for any Unix tool
    assert err.read_text() == ""


def test_a_full_disk_is_one_line(tmp_path):
    import subprocess
    import sys

    with open("/dev/full", "w") as full:
        result = subprocess.run(
            [sys.executable, "-m", "exhibit", "scenes", "--json"],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
        )
    assert result.returncode == 1
    assert result.stderr.strip() == "exhibit scenes: error: No space left on device"


NUMERIC_OPTIONS = [
    ("devices", "--wait"),
    ("monitor", "--rate"),
    ("monitor", "--duration"),
    ("record", "--duration"),
    ("simulate", "--duration"),
    ("simulate", "--protocol-version"),
    ("sweep", "--samples"),
    ("sweep", "--distances"),
    ("status", "--max-age"),
    ("status", "--max-lost"),
]
HOSTILE = [
    "nan",
    "inf",
    "-inf",
    "1e-320",
    "1e308",
    "-1",
    "0",
    "1e999",
    "",
    "x",
    "0x10",
    "9" * 400,
    "1_000",
    " 3 ",
    "+inf",
    "NaN",
    "-0",
    "3,",
    ",",
    "inf,nan",
]


@settings(max_examples=examples(300), deadline=None, derandomize=True)
@given(
    option=st.sampled_from(NUMERIC_OPTIONS),
    text=st.one_of(st.sampled_from(HOSTILE), st.floats().map(repr), st.text(max_size=12)),
)
def test_numeric_options_are_finite_or_refused(option, text):
    """Every numeric option either parses to finite values in range or exits 2 in one line."""
    import contextlib
    import io
    import math

    from exhibit.cli import build_parser

    command, flag = option
    extra = (
        ["file.jsonl"] if command == "record" else ["controller"] if command == "simulate" else []
    )
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            args = build_parser(command).parse_args([command, *extra, f"{flag}={text}"])
        except SystemExit as exc:
            assert exc.code == 2
            assert len(err.getvalue().strip().splitlines()) == 1, err.getvalue()
            assert f"argument {flag}" in err.getvalue()
            return
    value = getattr(args, flag.lstrip("-").replace("-", "_"))
    for v in value if isinstance(value, list) else [value]:
        assert not math.isnan(v) and v >= 0
        assert math.isfinite(v) or flag == "--distances"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["render", "hopf", "--size", "１２８０x720", "--out", "x.png"], "--size width"),
        (["render", "hopf", "--size", "64x٣6", "--out", "x.png"], "--size height"),
        (["render", "hopf", "--samples", "٣", "--out", "x.png"], "--samples"),
        (["render", "hopf", "--resolution", "١٢", "--out", "x.png"], "--resolution"),
        (["render", "--figure", "６", "--out", "x.png"], "--figure"),
        (["render", "hopf", "--angles", "١,0,0,0,0,0", "--out", "x.png"], "--angles"),
        (["render", "hopf", "--sensor-distance", "３", "--out", "x.png"], "--sensor-distance"),
        (["render", "hopf", "--param", "axis_length=٣", "--out", "x.png"], "axis_length"),
        (["render", "hopf", "--slice", "t=٣", "--out", "x.png"], "--slice"),
        (["render", "--takeover", "hopf", "--after", "３", "--out", "x.png"], "--after"),
        (["render", "--takeover", "hopf", "--fps", "١٠", "--out", "x.png"], "--fps"),
    ],
)
def test_cli_numbers_are_ascii_digits_only(capsys, tmp_path, monkeypatch, argv, message):
    """Issue 33: int() and float() read "１２８０" and "٣"; a flag takes what a file takes."""
    monkeypatch.chdir(tmp_path)
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own refusal
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "x.png").exists()
