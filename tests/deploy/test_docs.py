"""docs/DEPLOYMENT.md against the code and CI: no step exists only on paper. The packages of
step 1 are what CI installs for the cage test, the commands `exhibit install` is said to run are
the ones it runs, the file table and the removal list are the files it writes, the example site
config passes check-config, every `exhibit ...` command shown parses, and the hardening it
describes is what the units say."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from exhibit.cli import build_parser
from exhibit.commands import install as inst
from tests.deploy.unitfile import units

REPO = Path(__file__).resolve().parents[2]
DOC = (REPO / "docs/DEPLOYMENT.md").read_text()
#: Packages step 1 installs that the cage test does not need: fetching the code, and sysctl
#: (the test runs no `exhibit install` as root on the machine itself).
NOT_FOR_THE_TEST = {"git", "ca-certificates", "procps"}


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", DOC, flags=re.S)


def shell_lines(text: str) -> list[list[str]]:
    """Each command of a shell block as words: continuation lines joined, comments dropped, and
    commands joined by &&, ||, ; or | taken apart."""
    commands = []
    for line in text.replace("\\\n", " ").splitlines():
        lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
        lexer.whitespace_split = True
        words: list[str] = []
        for token in lexer:
            if token in ("&&", "||", ";", "|"):
                commands.append(words)
                words = []
            else:
                words.append(token)
        commands.append(words)
    return [words for words in commands if words]


def section(title: str) -> str:
    match = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", DOC, flags=re.S | re.M)
    assert match, title
    return match.group(1)


def bootstrap_packages(array: str) -> set[str]:
    """The packages of one of bootstrap.sh's apt arrays, with the arrays it includes."""
    text = (REPO / "bootstrap.sh").read_text()
    body = re.search(rf"^{array}=\(\n(.*?)^\)", text, flags=re.S | re.M).group(1)
    words = set()
    for line in body.splitlines():
        for word in line.split("#")[0].split():
            included = re.fullmatch(r'"\$\{(\w+)\[@\]\}"', word)
            words |= bootstrap_packages(included.group(1)) if included else {word}
    return words


def test_step_1_installs_what_ci_installs_for_the_cage_test():
    install = [
        words for words in shell_lines(blocks("sh")[0]) if words[:2] == ["apt-get", "install"]
    ]
    assert len(install) == 1
    doc = {w for w in install[0][2:] if not w.startswith("-")}
    assert {"cage", "xwayland", "libwayland-cursor0", "libgl1-mesa-dri"} <= doc
    ci = bootstrap_packages("apt_run") | bootstrap_packages("apt_test")
    assert doc - NOT_FOR_THE_TEST <= ci, doc - NOT_FOR_THE_TEST - ci
    # and exactly what an offline bundle carries (less git and its certificates, for cloning)
    bundled = bootstrap_packages("apt_run") | bootstrap_packages("apt_kiosk")
    assert doc - {"git", "ca-certificates"} == bundled, doc ^ bundled


def test_the_commands_install_runs_are_the_ones_shown():
    shown = next(shell_lines(b) for b in blocks("sh") if b.startswith("useradd"))
    assert shown == inst.steps(need_user=True)


def test_the_file_table_and_the_removal_list_are_what_install_writes():
    table = dict(re.findall(r"^\| `([^`]+)` \| `(/[^`]+)` \|", DOC, flags=re.M))
    assert table == {name: "/" + dest for name, dest in inst.FILES.items()}
    removing = section("Removing")
    for dest in inst.FILES.values():
        assert "/" + dest in removing, dest


def test_the_example_site_config_holds_only_changes_and_passes_check_config(tmp_path):
    (example,) = blocks("toml")
    assert len(re.findall(r"^\w+ *=", example, flags=re.M)) <= 5  # a few keys, not a copy
    site = tmp_path / "kiosk.toml"
    site.write_text(example)
    result = subprocess.run(
        [sys.executable, "-m", "exhibit", "check-config", str(site)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_exhibit_command_shown_parses():
    parser = build_parser()
    seen = 0
    for block in blocks("sh"):
        for words in shell_lines(block):
            if not words[0].endswith("exhibit") or words[0].startswith("/etc"):
                continue
            seen += 1
            try:
                parser.parse_args(words[1:])
            except SystemExit as exc:  # argparse's way of refusing
                pytest.fail(f"{shlex.join(words)}: exit {exc.code}")
    assert seen >= 6


def test_the_hardening_described_is_what_the_units_say():
    app = units(REPO / "systemd/exhibit.service")["Service"]
    kiosk = units(REPO / "systemd/exhibit-kiosk.service")["Service"]
    hardening = section("Hardening")
    filters = re.search(r"```ini\n(.*?)```", hardening, flags=re.S).group(1).splitlines()
    for service in (app, kiosk):
        for line in filters:
            key, value = line.split("=", 1)
            assert value in service[key], line
    left_out = re.findall(r"^\| `([A-Za-z]+)=[^|]*\| (both|app|kiosk) \|", hardening, flags=re.M)
    assert len(left_out) >= 6
    for key, where in left_out:
        for name, service in (("app", app), ("kiosk", kiosk)):
            if where in ("both", name):
                assert key not in service, f"{key} is set in the {name} unit"
    assert app["PrivateUsers"] == ["yes"] and "PrivateUsers=yes" in hardening


def test_the_tried_on_line_names_what_ci_runs():
    tried = re.search(r"^\*\*Tried on:\*\* (.*?)\n\n", DOC, flags=re.S | re.M).group(1)
    for what in (
        "Debian 12",
        "cage 0.1.4",
        "xwayland",
        "llvmpipe",
        "GLFW 3.4",
        "tests/deploy/test_cage_kiosk.py",
    ):
        assert what in tried, what


def test_every_bootstrap_command_shown_is_a_job_it_has():
    script = (REPO / "bootstrap.sh").read_text()
    jobs = set(re.search(r"^  ([a-z|]+)\) shift ;;$", script, flags=re.M).group(1).split("|"))
    assert jobs == {"run", "test", "lock", "bundle", "update"}
    shown = [
        words
        for block in blocks("sh")
        for words in shell_lines(block)
        if words[0].endswith("bootstrap.sh") or words[0].startswith("EXHIBIT_BUNDLE=")
    ]
    shown = [words[1:] if "=" in words[0] else words for words in shown]
    assert {words[1] for words in shown} == jobs - {"test"}  # test is the README's
    for words in shown:
        if words[1] == "update":
            assert words[2:] in ([], ["--prefix", "DIR"]) or words[2] == "--prefix", words
    assert "EXHIBIT_BUNDLE=/media/usb/exhibit-bundle ./bootstrap.sh run" in DOC


def test_the_update_and_rollback_shown_are_what_the_code_does():
    from exhibit.commands import update

    updating = section("8. Updating")
    assert "/opt/exhibit/.venv/bin/exhibit rollback" in updating
    assert f"/opt/exhibit{update.Releases().releases[len('/opt/exhibit') :]}/" in updating
    assert f"`{update.PREVIOUS}`" in updating
    assert f"`{' '.join(update.RESTART)}`" in updating
    assert "beyond three" in updating and update.KEEP == 3


def test_the_offline_numbers_match_the_locks():
    offline = section("Offline install")
    locked = set()
    for name in ("run", "build"):
        text = (REPO / f"requirements/{name}.lock").read_text()
        locked |= set(re.findall(r"^([A-Za-z0-9._-]+)==", text, flags=re.M))
    # every number comes from a command the section names
    wheels = re.search(r"`ls wheels \| wc -l` (\d+)", offline)
    assert wheels and int(wheels.group(1)) == len(locked) + 1  # and the project's own wheel
    for command in (
        "`du -sh` of the bundle",
        "`ls debs/*.deb | wc -l`",
        "`time ./bootstrap.sh run --version`",
    ):
        assert command in offline, command
