"""The locks and the offline bundle (docs/DEPLOYMENT.md, "Offline install").

Fast: requirements/*.lock pin every dependency pyproject.toml names (run, test extra, build
system) to one version inside its range, each with sha256 hashes, the run lock agrees with the
test lock, and bootstrap.sh installs from them with --require-hashes; a missing, damaged or
foreign bundle is refused in one line before anything is installed.

Slow (CI): `./bootstrap.sh bundle` writes a bundle, and with the network cut (a network
namespace with no interface, `unshare -n`) the README's run command, run from a copy of it,
makes a venv from the bundle alone and the exhibit draws a figure from another folder; apt,
pointed at the bundle's repository and nothing else, resolves every Debian package the run job
and the kiosk need, on this machine and on one with nothing installed."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from tests.deploy.bundles import debian_12_with_python_311, make_bundle

REPO = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())
LOCKS = REPO / "requirements"


def lock(name: str) -> dict[str, tuple[str, list[str]]]:
    """A lock file as name -> (version, hashes)."""
    text = (LOCKS / f"{name}.lock").read_text().replace("\\\n", " ")
    pins = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        match = re.fullmatch(r"([A-Za-z0-9._-]+)==(\S+)((?:\s+--hash=sha256:[0-9a-f]{64})+)", line)
        assert match, f"{name}.lock: not a hashed pin: {line[:80]}"
        pins[canonicalize_name(match.group(1))] = (
            match.group(2),
            re.findall(r"sha256:([0-9a-f]{64})", match.group(3)),
        )
    return pins


def bootstrap_array(name: str) -> list[str]:
    text = (REPO / "bootstrap.sh").read_text()
    body = re.search(rf"^{name}=\(\n(.*?)^\)", text, flags=re.S | re.M).group(1)
    return [
        w
        for line in body.splitlines()
        for w in line.split("#")[0].split()
        if not w.startswith('"$')
    ]


@pytest.mark.parametrize(
    "name, requirements",
    [
        ("run", PYPROJECT["project"]["dependencies"]),
        (
            "test",
            PYPROJECT["project"]["dependencies"]
            + PYPROJECT["project"]["optional-dependencies"]["test"],
        ),
        ("build", PYPROJECT["build-system"]["requires"] + ["pip"]),
    ],
)
def test_each_lock_pins_every_dependency_in_its_range_with_hashes(name, requirements):
    pins = lock(name)
    for text in requirements:
        requirement = Requirement(text)
        key = canonicalize_name(requirement.name)
        assert key in pins, f"{name}.lock lacks {requirement.name} (./bootstrap.sh lock)"
        version, hashes = pins[key]
        assert requirement.specifier.contains(version, prereleases=True), (
            f"{name}.lock: {requirement.name}=={version} is outside pyproject's {text!r}: "
            "./bootstrap.sh lock"
        )
        assert hashes


def test_the_locks_agree_and_are_generated_by_the_documented_command():
    run, test, build = lock("run"), lock("test"), lock("build")
    assert run.keys() <= test.keys()
    for key in run.keys() & test.keys():
        assert run[key][0] == test[key][0], key
    for key in build.keys() & test.keys():
        assert build[key][0] == test[key][0], key
    for name in ("run", "test", "build"):
        assert "#    ./bootstrap.sh lock\n" in (LOCKS / f"{name}.lock").read_text()
    script = (REPO / "bootstrap.sh").read_text()
    assert 'pip_install --require-hashes -r "requirements/$lock.lock"' in script
    assert "pip_install --no-deps --no-build-isolation -e ." in script
    # the venv is remade when a lock changes
    assert re.search(r'want=.*requirements/build\.lock "requirements/\$lock\.lock"', script)


# ------------------------------------------------------------------ refused bundles, one line


def fake_bundle(tmp_path: Path, python: str = "3.11") -> Path:
    """A bundle's skeleton: enough of the source for bootstrap.sh, a wheel and the manifest."""
    bundle = tmp_path / "bundle"
    (bundle / "exhibit").mkdir(parents=True)
    for name in ("bootstrap.sh", "pyproject.toml", "exhibit/__init__.py", "requirements"):
        source = REPO / name
        if source.is_dir():
            shutil.copytree(source, bundle / name)
        else:
            shutil.copy2(source, bundle / name)
    (bundle / "wheels").mkdir()
    (bundle / "wheels/pyserial-3.5-py2.py3-none-any.whl").write_bytes(b"a wheel")
    (bundle / "bundle.env").write_text(f"version=0\npython={python}\nmachine=x86_64\ndebian=12\n")
    subprocess.run(
        "find . -type f -printf '%P\\0' | xargs -0 sha256sum > SHA256SUMS",
        shell=True,
        cwd=bundle,
        check=True,
    )
    return bundle


def bootstrap(folder: Path, *args: str, **env: str) -> subprocess.CompletedProcess:
    environ = {k: v for k, v in os.environ.items() if k not in ("EXHIBIT_BUNDLE", "PYTHON")}
    environ.update(PYTHON=sys.executable, **env)
    return subprocess.run(
        [str(folder / "bootstrap.sh"), *args],
        capture_output=True,
        text=True,
        env=environ,
        timeout=120,
    )


def one_line(result: subprocess.CompletedProcess, message: str) -> None:
    assert result.returncode == 1, result.stderr
    assert result.stderr.count("\n") == 1 and message in result.stderr, result.stderr
    assert "Traceback" not in result.stderr


def test_a_missing_bundle_folder_is_one_line(tmp_path):
    one_line(
        bootstrap(REPO, "run", "--version", EXHIBIT_BUNDLE=str(tmp_path / "usb")),
        f"EXHIBIT_BUNDLE={tmp_path}/usb: no such folder",
    )
    one_line(
        bootstrap(REPO, "run", "--version", EXHIBIT_BUNDLE=str(tmp_path)),
        "is not a bundle (no bundle.env",
    )


def test_a_wheel_with_a_wrong_hash_is_refused_before_anything_is_installed(tmp_path):
    bundle = fake_bundle(tmp_path)
    with open(bundle / "wheels/pyserial-3.5-py2.py3-none-any.whl", "ab") as wheel:
        wheel.write(b"changed on the way")
    one_line(
        bootstrap(bundle, "run", "--version"),
        f"bundle {bundle} is damaged: wheels/pyserial-3.5-py2.py3-none-any.whl: FAILED",
    )
    assert not (bundle / ".venv").exists()


def test_a_bundle_for_another_python_is_refused(tmp_path):
    bundle = fake_bundle(tmp_path, python="3.9")
    one_line(
        bootstrap(bundle, "run", "--version"),
        "this bundle is for Python 3.9 on x86_64, "
        f"but {sys.executable} is Python {sys.version_info[0]}.{sys.version_info[1]}",
    )
    assert not (bundle / ".venv").exists()


def test_the_tests_are_not_run_from_a_bundle(tmp_path):
    one_line(bootstrap(fake_bundle(tmp_path), "test"), "a bundle holds what `run` needs")


def test_an_option_is_no_bundle_folder(tmp_path):
    """Issue 33: `./bootstrap.sh bundle --upgrade` failed with a raw `rm: unrecognized option`."""
    one_line(bootstrap(REPO, "bundle", "--upgrade"), "bundle takes no options, only a folder")
    assert not (REPO / "--upgrade.partial").exists()


# ------------------------------------------------------------------ the offline install


def _offline_prefix() -> list[str]:
    """The command prefix that runs a command with no network: a new network namespace."""
    if shutil.which("unshare") is None:
        pytest.skip("no unshare (util-linux): cannot cut the network for the offline test")
    prefix = ["unshare", "-n"] if os.geteuid() == 0 else ["unshare", "-r", "-n"]
    probe = subprocess.run([*prefix, "true"], capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(
            f"`{' '.join(prefix)}` is not permitted here ({probe.stderr.strip()}): "
            "the offline test needs root or unprivileged user namespaces"
        )
    return prefix


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    """A bundle of this checkout: $EXHIBIT_TEST_BUNDLE if set (made earlier), else made now."""
    return make_bundle(tmp_path_factory.mktemp("bundle") / "exhibit-bundle")


@pytest.mark.slow
def test_the_bundle_holds_every_wheel_of_the_lock_and_its_debs(bundle):
    check = subprocess.run(
        ["sha256sum", "--quiet", "--strict", "-c", "SHA256SUMS"],
        cwd=bundle,
        capture_output=True,
        text=True,
    )
    assert check.returncode == 0, check.stdout + check.stderr
    wheels = {
        canonicalize_name(w.name.split("-")[0]): w.name for w in (bundle / "wheels").glob("*.whl")
    }
    for name, (version, _hashes) in {**lock("run"), **lock("build")}.items():
        assert name in wheels, name
        assert f"-{version}-" in wheels[name], wheels[name]
        assert re.search(
            r"-(cp311-cp311|cp311-abi3|py3-none|py2\.py3-none)-"
            r"(any|manylinux[_0-9]*x86_64)",
            wheels[name],
        ), wheels[name]
    assert "exhibit" in wheels and wheels["exhibit"].endswith("-py3-none-any.whl")
    packages = set(
        re.findall(r"^Package: (\S+)$", (bundle / "debs/Packages").read_text(), flags=re.M)
    )
    assert set(bootstrap_array("apt_run") + bootstrap_array("apt_kiosk")) <= packages
    assert {"libc6", "libllvm15", "python3.11"} <= packages  # the closure, not just the names
    for field in ("python=3.11", "machine=x86_64", "debian=12"):
        assert field in (bundle / "bundle.env").read_text()


@pytest.mark.slow
def test_offline_the_run_command_installs_from_the_bundle_alone(bundle, tmp_path):
    """README's run command, run from a copy of the bundle with no network: a fresh .venv from
    the bundle's wheels, then the exhibit from another folder."""
    python = debian_12_with_python_311()
    offline = _offline_prefix()
    usb = tmp_path / "usb"
    shutil.copytree(bundle, usb, symlinks=True, ignore=shutil.ignore_patterns(".venv"))
    probe = (
        "import socket, sys\ntry: socket.create_connection(('151.101.0.223', 443), 5)\n"
        "except OSError as exc: sys.exit(str(exc))"
    )
    cut = subprocess.run([*offline, python, "-c", probe], capture_output=True, text=True)
    assert "Network is unreachable" in cut.stderr, cut.stderr  # really no network in there

    env = {k: v for k, v in os.environ.items() if not k.startswith(("EXHIBIT_", "PIP_"))}
    env.update(PYTHON=python, EXHIBIT_CACHE_DIR=str(tmp_path / "cache"))
    installed = subprocess.run(
        [*offline, "./bootstrap.sh", "run", "--version"],
        cwd=usb,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert installed.returncode == 0, installed.stderr[-3000:]
    assert installed.stdout.strip() == f"exhibit {bundle_version(bundle)}"
    assert "from the bundle" in installed.stderr

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    venv = usb / ".venv/bin"
    where = subprocess.run(
        [*offline, str(venv / "python"), "-c", "import exhibit; print(exhibit.__file__)"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert where.stdout.startswith(str(usb / ".venv/lib/python3.11/site-packages/exhibit/")), (
        where.stdout + where.stderr
    )  # the bundle's wheel, not this checkout
    drawn = subprocess.run(
        [
            *offline,
            str(venv / "exhibit"),
            "render",
            "--figure",
            "8",
            "--size",
            "320x240",
            "--out",
            "x.png",
        ],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert drawn.returncode == 0, drawn.stderr
    assert (elsewhere / "x.png").stat().st_size > 5000
    # the same command again reuses the venv (the stamp), still offline
    again = subprocess.run(
        [*offline, "./bootstrap.sh", "run", "--version"],
        cwd=usb,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert again.returncode == 0 and "installing" not in again.stderr, again.stderr


def bundle_version(bundle: Path) -> str:
    return re.search(r"^version=(.*)$", (bundle / "bundle.env").read_text(), re.M).group(1)


@pytest.mark.slow
@pytest.mark.parametrize("machine", ["this machine", "nothing installed"])
def test_offline_apt_resolves_every_package_from_the_bundle(bundle, tmp_path, machine):
    """apt with the bundle's repository as its only source (its own source list and lists), no
    network: every package of the run job and the kiosk resolves, here and on an empty system."""
    offline = _offline_prefix()
    if shutil.which("apt-get") is None:
        pytest.skip("no apt-get")
    state = tmp_path / "apt"
    for folder in ("lists/partial", "parts", "cache/archives/partial"):
        (state / folder).mkdir(parents=True)
    (state / "sources.list").write_text(f"deb [trusted=yes] file:{bundle}/debs ./\n")
    options = [
        "-o",
        f"Dir::Etc::SourceList={state}/sources.list",
        "-o",
        f"Dir::Etc::SourceParts={state}/parts",
        "-o",
        f"Dir::State::Lists={state}/lists",
        "-o",
        f"Dir::Cache={state}/cache",
        "-o",
        "Debug::NoLocking=1",
    ]
    if machine == "nothing installed":
        (state / "status").write_text("")
        options += ["-o", f"Dir::State::status={state}/status"]
    updated = subprocess.run(
        [*offline, "apt-get", *options, "update"], capture_output=True, text=True, timeout=120
    )
    assert updated.returncode == 0, updated.stdout + updated.stderr
    assert "Err:" not in updated.stdout
    packages = bootstrap_array("apt_run") + bootstrap_array("apt_kiosk")
    simulated = subprocess.run(
        [*offline, "apt-get", *options, "-s", "install", "--no-install-recommends", *packages],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert simulated.returncode == 0, simulated.stdout[-3000:] + simulated.stderr
    installs = re.findall(r"^Inst (\S+)", simulated.stdout, flags=re.M)
    if machine == "nothing installed":
        assert set(packages) <= set(installs)
        assert len(installs) > 100  # libc6 and all: the whole closure came from the bundle
