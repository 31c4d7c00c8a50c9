#!/usr/bin/env bash
# Sets up this checkout on a fresh Debian machine and runs one job:
#   ./bootstrap.sh run  [ARGS...]   install what the exhibit needs, then run it
#   ./bootstrap.sh test [ARGS...]   install what the tests need, then run the test suite
#   ./bootstrap.sh lock [UV ARGS]   regenerate requirements/*.lock (uv; --upgrade for newer)
#   ./bootstrap.sh bundle [DIR]     write an offline install folder (wheels, .debs, source)
#   ./bootstrap.sh update [--prefix DIR] [--keep N]
#                                   install this tree as a new release of a deployed kiosk
# System packages come from apt-get when run as root; otherwise the missing ones are named and
# the script stops. Python packages go into ./.venv, exactly as requirements/*.lock pins them
# (with their hashes), reused while pyproject.toml and the locks are unchanged. Run from a bundle
# (or with EXHIBIT_BUNDLE=DIR), everything comes from the bundle and nothing from the network
# (docs/DEPLOYMENT.md, "Offline install").
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$here"

job="${1:-}"
case "$job" in
  run|test|lock|bundle|update) shift ;;
  *) echo "usage: ./bootstrap.sh run|test [ARGS...] | lock [--upgrade] | bundle [DIR] | update [--prefix DIR]" >&2
     exit 2 ;;
esac

# System packages, by job. Each line says who needs it.
apt_run=(
  python3 python3-venv python3-pip   # the interpreter and venv (Python >= 3.11)
  libegl1 libgl1 libgl1-mesa-dri     # OpenGL/EGL, with Mesa llvmpipe where there is no GPU
  fonts-dejavu-core                  # the HUD's font (has θ and ∞)
  espeak-ng                          # narration: offline speech where no recording is given
  libasound2                         # narration: miniaudio plays through ALSA (loaded at run time)
)
apt_kiosk=(
  cage xwayland            # deployed kiosk: the compositor, and the X server Debian's cage insists on
  libwayland-client0 libwayland-egl1 libwayland-cursor0 libxkbcommon0  # GLFW's Wayland build
  procps                   # sysctl, which `exhibit install` runs
)
apt_test=(
  "${apt_run[@]}"
  "${apt_kiosk[@]}"        # deploy: the kiosk on cage as in docs/DEPLOYMENT.md (tests/deploy)
  gcc make pkg-config gcc-avr binutils-avr avr-libc arduino-core-avr libsimavr-dev libelf-dev  # firmware: host and AVR builds, simavr harness (tests/firmware)
  xvfb                     # renderer: window tests under Xvfb
  systemd                  # kiosk: systemd-analyze verify/security on the units (tests/kiosk)
  grim                     # deploy: a frame grabbed from cage (tests/deploy)
  prometheus               # kiosk: promtool checks `exhibit status --prometheus` (tests/kiosk)
)

# What a bundle is for: Debian 12's Python and machine (its wheels are cp311, x86_64).
bundle_python=3.11
bundle_machine=x86_64
bundle_debian=12
# uv, which writes requirements/*.lock (./bootstrap.sh lock only; never needed to run or test).
uv_version=0.13.9

say() { printf 'bootstrap: %s\n' "$*" >&2; }
die() { say "$*"; exit 1; }

version="$(sed -n 's/^__version__ = "\(.*\)"$/\1/p' exhibit/__init__.py)"

# The bundle to install from: EXHIBIT_BUNDLE, else this folder when it is one.
bundle=""
if [ -n "${EXHIBIT_BUNDLE:-}" ]; then
  [ -d "$EXHIBIT_BUNDLE" ] || die "EXHIBIT_BUNDLE=$EXHIBIT_BUNDLE: no such folder"
  bundle="$(cd "$EXHIBIT_BUNDLE" && pwd)"
  [ -f "$bundle/bundle.env" ] || die "EXHIBIT_BUNDLE=$EXHIBIT_BUNDLE is not a bundle (no bundle.env; ./bootstrap.sh bundle makes one)"
elif [ -f "$here/bundle.env" ]; then
  bundle="$here"
fi
if [ -n "$bundle" ]; then
  # Nothing from pip's configuration or environment (an index, find-links): only the bundle.
  for var in $(compgen -e); do case "$var" in PIP_*) unset "$var" ;; esac; done
  export PIP_CONFIG_FILE=/dev/null
fi
bundle_checked=""

bundle_field() { sed -n "s/^$1=//p" "$bundle/bundle.env"; }

# The bundle's files against its SHA256SUMS, once, before anything is installed from it.
check_bundle() {
  [ -n "$bundle_checked" ] && return 0
  [ -d "$bundle/wheels" ] && [ -f "$bundle/SHA256SUMS" ] \
    || die "bundle $bundle is incomplete (no wheels/ or SHA256SUMS): copy the whole folder"
  local bad
  if ! bad="$(cd "$bundle" && sha256sum --quiet --strict -c SHA256SUMS 2>&1)"; then
    die "bundle $bundle is damaged: $(printf '%s\n' "$bad" | head -n1) (copy the bundle again)"
  fi
  bundle_checked=1
}

install_system_packages() {
  if ! command -v dpkg-query >/dev/null 2>&1; then
    say "not a Debian system: make sure these are installed: $*"
    return 0
  fi
  local missing=()
  for pkg in "$@"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    say "missing system packages: ${missing[*]}"
    if [ -n "$bundle" ]; then
      say "install them as root:  $here/bootstrap.sh ${job} (as root, from the bundle)"
    else
      say "install them as root:  apt-get update && apt-get install -y ${missing[*]}"
    fi
    exit 1
  fi
  say "installing system packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  if [ -z "$bundle" ]; then
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    return 0
  fi
  # From the bundle's repository alone: its own source list and package lists, not the system's.
  check_bundle
  local debian; debian="$(. /etc/os-release 2>/dev/null && echo "${VERSION_ID:-unknown}")"
  [ "$debian" = "$(bundle_field debian)" ] \
    || die "the bundle's .deb files are for Debian $(bundle_field debian), this is Debian $debian: make a bundle on Debian $debian"
  local apt_dir; apt_dir="$(mktemp -d)"
  mkdir -p "$apt_dir/lists/partial" "$apt_dir/parts"
  echo "deb [trusted=yes] file:${bundle// /%20}/debs ./" > "$apt_dir/sources.list"
  local opts=(-o "Dir::Etc::SourceList=$apt_dir/sources.list" -o "Dir::Etc::SourceParts=$apt_dir/parts"
              -o "Dir::State::Lists=$apt_dir/lists")
  apt-get "${opts[@]}" update -qq >/dev/null
  apt-get "${opts[@]}" install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  rm -rf "$apt_dir"
}

pick_python() {
  local candidates=("${PYTHON:-}" python3 python3.13 python3.12 python3.11)
  for py in "${candidates[@]}"; do
    [ -n "$py" ] || continue
    command -v "$py" >/dev/null 2>&1 || continue
    if "$py" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
      echo "$py"; return 0
    fi
  done
  say "need Python >= 3.11 with venv (Debian: python3 python3-venv); set PYTHON=/path/to/python3.11+"
  exit 1
}

# pip install into .venv: from the index (PyPI) as configured, or from the bundle's wheels alone.
pip_install() {
  if [ -n "$bundle" ]; then
    .venv/bin/python -m pip install -q --no-index --find-links "$bundle/wheels" "$@"
  else
    .venv/bin/python -m pip install -q "$@"
  fi
}

setup_venv() {
  local lock="$1"   # run | test: requirements/$lock.lock
  local py; py="$(pick_python)"
  if [ -n "$bundle" ]; then
    local has; has="$("$py" -c 'import platform, sys; print("%d.%d %s" % (*sys.version_info[:2], platform.machine()))')"
    [ "$has" = "$(bundle_field python) $(bundle_field machine)" ] \
      || die "this bundle is for Python $(bundle_field python) on $(bundle_field machine), but $py is Python ${has% *} on ${has#* }: make the bundle for this machine, or set PYTHON=/path/to/python$(bundle_field python)"
  fi
  local file
  for file in requirements/build.lock "requirements/$lock.lock"; do
    [ -f "$file" ] || die "$file is missing (./bootstrap.sh lock writes it; a bundle carries it)"
  done
  local stamp=".venv/.exhibit-install-stamp"
  local want; want="$lock $(cat pyproject.toml requirements/build.lock "requirements/$lock.lock" | sha256sum | cut -d' ' -f1)"
  [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x .venv/bin/python ] && return 0
  [ -n "$bundle" ] && check_bundle
  if [ ! -x .venv/bin/python ]; then
    say "creating .venv with $py"
    "$py" -m venv .venv
  fi
  say "installing Python packages into .venv (requirements/$lock.lock${bundle:+, from the bundle})"
  pip_install --require-hashes -r requirements/build.lock   # pip, setuptools, wheel
  pip_install --require-hashes -r "requirements/$lock.lock"
  if [ -n "$bundle" ]; then
    local wheel="$bundle/wheels/exhibit-$version-py3-none-any.whl"
    [ -f "$wheel" ] || die "bundle $bundle has no $(basename "$wheel") for this source (exhibit $version)"
    pip_install --no-deps --force-reinstall "$wheel"
  else
    pip_install --no-deps --no-build-isolation -e .
  fi
  echo "$want" > "$stamp"
}

# This project's files (no .venv, .git, out/ or a bundle's wheels and .debs), NUL-separated,
# relative to here: what git tracks in a checkout, the rest of the tree otherwise.
source_files() {
  if [ -e .git ] && command -v git >/dev/null 2>&1 && git rev-parse --git-dir >/dev/null 2>&1; then
    git ls-files -z --cached | while IFS= read -r -d '' f; do
      if [ -e "$f" ] || [ -L "$f" ]; then printf '%s\0' "$f"; fi
    done
  else
    find . -mindepth 1 \( -path ./.venv -o -path ./.git -o -path ./out -o -path ./wheels \
      -o -path ./debs -o -path ./build -o -name __pycache__ -o -name '*.egg-info' \) -prune \
      -o \( -type f -o -type l \) ! -path ./SHA256SUMS ! -path ./bundle.env ! -path ./BUNDLE.md \
      -printf '%P\0'
  fi
}

copy_source() {  # copy_source DEST: the project's files into DEST (made)
  mkdir -p "$1"
  source_files | tar -C "$here" --null -T - -cf - | tar -C "$1" -xf -
}

# A flat apt repository for the .deb files in a folder: Packages, each package's control fields
# (dpkg-deb, always there) with where the file is, its size and hash; Packages.gz; and a Release
# file with their hashes (unsigned: the source list says [trusted=yes], SHA256SUMS vouches).
write_packages() {
  ( cd "$1"
    for deb in *.deb; do
      dpkg-deb -f "$deb"
      printf 'Filename: ./%s\nSize: %s\nSHA256: %s\n\n' "$deb" "$(stat -c %s "$deb")" \
        "$(sha256sum "$deb" | cut -d' ' -f1)"
    done > Packages
    gzip -9nk Packages
    { echo "Date: $(LC_ALL=C date -u -R)"
      echo "SHA256:"
      for index in Packages Packages.gz; do
        echo " $(sha256sum "$index" | cut -d' ' -f1) $(stat -c %s "$index") $index"
      done; } > Release )
}

make_bundle() {
  local dest="${1:-out/exhibit-$version-bundle}"
  [ -e "$dest" ] && die "$dest exists: remove it or name another folder"
  command -v apt-get >/dev/null 2>&1 && command -v dpkg-deb >/dev/null 2>&1 \
    || die "making a bundle needs a Debian $bundle_debian machine (apt-get, dpkg-deb)"
  local debian; debian="$(. /etc/os-release 2>/dev/null && echo "${VERSION_ID:-unknown}")"
  [ "$debian" = "$bundle_debian" ] || die "making a bundle for Debian $bundle_debian needs Debian $bundle_debian (this is $debian)"
  install_system_packages "${apt_run[@]}"
  local tmp="$dest.partial"
  rm -rf "$tmp"
  mkdir -p "$tmp/wheels" "$tmp/debs/partial" "$tmp/.apt"
  say "copying the source into $dest"
  copy_source "$tmp"
  # The project's wheel, built from a copy of the source with the locked pip and setuptools in a
  # venv of its own (./.venv is left alone).
  say "wheels: exhibit $version and requirements/run.lock, build.lock for CPython $bundle_python on $bundle_machine"
  local py; py="$(pick_python)"
  "$py" -m venv "$tmp/.build/venv"
  local pip=("$tmp/.build/venv/bin/python" -m pip)
  "${pip[@]}" install -q --require-hashes -r requirements/build.lock
  copy_source "$tmp/.build/src"
  "${pip[@]}" wheel -q --no-deps --no-build-isolation -w "$tmp/wheels" "$tmp/.build/src" >/dev/null
  local platforms=() minor
  for minor in $(seq 36 -1 17); do platforms+=(--platform "manylinux_2_${minor}_${bundle_machine}"); done
  platforms+=(--platform "manylinux2014_${bundle_machine}")
  "${pip[@]}" download -q --require-hashes --no-deps --only-binary=:all: \
    --implementation cp --python-version "$bundle_python" --abi "cp${bundle_python/./}" --abi abi3 \
    --abi none "${platforms[@]}" -r requirements/run.lock -r requirements/build.lock \
    -d "$tmp/wheels"
  # The .deb files of the run job and the kiosk with everything they depend on, resolved by apt
  # as if nothing were installed (an empty dpkg status), so a minimal Debian 12 finds them all.
  say "Debian packages: ${apt_run[*]} ${apt_kiosk[*]} and their dependencies"
  [ "$(id -u)" -eq 0 ] && apt-get update -qq
  : > "$tmp/.apt/status"
  apt-get install -qq --download-only --no-install-recommends \
    -o "Dir::State::status=$tmp/.apt/status" -o "Dir::Cache::Archives=$tmp/debs" \
    -o Debug::NoLocking=1 -o APT::Sandbox::User=root "${apt_run[@]}" "${apt_kiosk[@]}" >/dev/null
  rm -rf "$tmp/.apt" "$tmp/.build" "$tmp/debs/partial" "$tmp/debs/lock"
  write_packages "$tmp/debs"
  cat > "$tmp/bundle.env" <<ENV
version=$version
python=$bundle_python
machine=$bundle_machine
debian=$bundle_debian
made=$(date -u +%Y-%m-%dT%H:%M:%SZ)
ENV
  cat > "$tmp/BUNDLE.md" <<README
# exhibit $version, offline bundle

For Debian $bundle_debian on $bundle_machine (Python $bundle_python). Everything needed to set up
and run the exhibit without a network: the project (this folder, and wheels/exhibit-$version-*.whl),
every Python package of requirements/run.lock as a wheel (wheels/), and the Debian packages of the
run job and the deployed kiosk with their dependencies as a local apt repository (debs/).

    ./bootstrap.sh run               # as root: apt packages from debs/, .venv from wheels/
    ./bootstrap.sh update            # as root: install this as a new release of /opt/exhibit

SHA256SUMS lists every file; bootstrap.sh checks it before installing anything.
See docs/DEPLOYMENT.md, "Offline install".
README
  ( cd "$tmp" && find . -type f ! -path ./SHA256SUMS -printf '%P\0' | sort -z \
      | xargs -0 sha256sum > SHA256SUMS )
  mv "$tmp" "$dest"
  say "wrote $dest: $(ls "$dest/wheels" | wc -l) wheels, $(ls "$dest/debs"/*.deb | wc -l) .deb files, $(du -sh "$dest" | cut -f1)"
}

run_lock() {
  local tools="out/.lock-tools"
  local py; py="$(pick_python)"
  if [ ! -x "$tools/bin/uv" ] || [ "$("$tools/bin/uv" --version | cut -d' ' -f2)" != "$uv_version" ]; then
    say "installing uv $uv_version into $tools (for the lock only)"
    rm -rf "$tools"
    "$py" -m venv "$tools"
    "$tools/bin/python" -m pip install -q "uv==$uv_version"
  fi
  # What the project is built with ([build-system] requires), and pip itself.
  {
    echo "# Generated by ./bootstrap.sh lock from pyproject.toml's [build-system] requires, and pip."
    echo "pip"
    "$py" -c 'import tomllib; print("\n".join(tomllib.load(open("pyproject.toml", "rb"))["build-system"]["requires"]))'
  } > requirements/build.in
  local compile=("$tools/bin/uv" pip compile -q --generate-hashes --python-version "$bundle_python"
                 --python-platform "${bundle_machine}-manylinux_2_36"
                 --custom-compile-command "./bootstrap.sh lock")
  "${compile[@]}" "$@" pyproject.toml --extra test -o requirements/test.lock
  "${compile[@]}" "$@" pyproject.toml -c requirements/test.lock -o requirements/run.lock
  "${compile[@]}" "$@" requirements/build.in -c requirements/test.lock -o requirements/build.lock
  say "wrote requirements/test.lock, run.lock, build.lock ($(grep -c '^[a-z0-9]' requirements/test.lock) packages for the tests)"
}

update_kiosk() {
  local prefix=/opt/exhibit args=()
  while [ $# -gt 0 ]; do
    case "$1" in
      --prefix) [ $# -ge 2 ] || die "update: --prefix needs a folder"; prefix="$2"; shift 2 ;;
      --prefix=*) prefix="${1#--prefix=}"; shift ;;
      *) args+=("$1"); shift ;;
    esac
  done
  [ "$(id -u)" -eq 0 ] || die "update needs root (it installs into $prefix and restarts the kiosk)"
  case "$prefix" in /?*) ;; *) die "update: --prefix $prefix: must be an absolute path" ;; esac
  prefix="${prefix%/}"
  umask 022
  local release; release="$prefix-releases/$version-$(date -u +%Y%m%dT%H%M%SZ)"
  [ -e "$release" ] && die "$release exists already: wait a second and try again"
  install_system_packages "${apt_run[@]}" "${apt_kiosk[@]}"
  [ -n "$bundle" ] && check_bundle
  say "new release $release${bundle:+ from the bundle $bundle}"
  mkdir -p "$prefix-releases"
  mkdir "$release" || die "cannot make $release (see above)"
  # Held (flock) while the release is made, by this shell and pip under it: an update's pruning
  # leaves a release whose file is held alone, and removes one whose file nobody holds (what a
  # killed bootstrap left half-made). Removed once the release is made.
  local building="$release/.exhibit-building" lock_fd
  exec {lock_fd}>"$building"
  flock -n "$lock_fd" || die "cannot lock $building"
  copy_source "$release"
  chmod -R u+rwX,go+rX,go-w "$release"   # the service's user reads it
  if ! ( cd "$release" && EXHIBIT_BUNDLE="$bundle" PYTHON="${PYTHON:-/usr/bin/python3}" \
           ./bootstrap.sh run --version >/dev/null ); then
    rm -rf "$release"
    die "setting up $release failed (see above); nothing was changed"
  fi
  "$release/.venv/bin/python" -m compileall -q "$release/exhibit" >/dev/null   # no __pycache__ writes later
  rm -f "$building"
  exec {lock_fd}>&-
  say "$release is set up; its exhibit update now checks the site config and builds the mesh cache with it, then switches $prefix to it, installs and restarts"
  exec "$release/.venv/bin/exhibit" update "$release" --prefix "$prefix" "${args[@]}"
}

case "$job" in
  run)
    install_system_packages "${apt_run[@]}"
    setup_venv run
    # With arguments: that exhibit command (./bootstrap.sh run inspect collision).
    [ $# -gt 0 ] && exec .venv/bin/exhibit "$@"
    # The exhibit itself, fullscreen with the shipped config (configs/kiosk.toml); staff quit
    # with Ctrl+Alt+Shift+Q. Without a display, the headless renderer draws the paper's
    # Figures 6-17 into out/figures/ instead.
    if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
      exec .venv/bin/exhibit run
    fi
    say "no display (DISPLAY and WAYLAND_DISPLAY are unset): the kiosk needs a screen;"
    say "rendering the paper's figures headlessly into out/figures/ instead"
    mkdir -p out/figures
    for figure in 6 7 8 9 10 11 12 13 14 15 16 17; do
      .venv/bin/exhibit render --figure "$figure" --out "out/figures/figure-$figure.png"
    done
    exec .venv/bin/exhibit sweep
    ;;
  test)
    [ -z "$bundle" ] || die "a bundle holds what \`run\` needs, not the tests' packages: run the tests from a checkout, with a network"
    install_system_packages "${apt_test[@]}"
    setup_venv test
    # CI also runs the slow soak and fuzz tests.
    chosen="not slow"
    [ "${CI:-}" = "true" ] && chosen="slow or not slow"
    if [ $# -gt 0 ]; then
      exec .venv/bin/python -m pytest -m "$chosen" "$@"
    fi
    # The whole suite: lint, format and types first (pyproject.toml's [tool.ruff], [tool.mypy]);
    # then the tests on every core, a test file per worker (its module fixtures stay together);
    # under CI, then alone, the slow ones that time what a real screen does (marked serial).
    say "ruff check, ruff format --check, mypy"
    .venv/bin/ruff check --quiet exhibit tests
    .venv/bin/ruff format --check --quiet exhibit tests
    .venv/bin/mypy
    [ "${CI:-}" = "true" ] || exec .venv/bin/python -m pytest -n auto --dist loadfile -m "$chosen"
    .venv/bin/python -m pytest -n auto --dist loadfile -m "($chosen) and not serial"
    exec .venv/bin/python -m pytest -m "($chosen) and serial"
    ;;
  lock) run_lock "$@" ;;
  bundle)
    [ $# -le 1 ] || die "usage: ./bootstrap.sh bundle [DIR]"
    # An option is no folder name (rm, mkdir and mv would each read it as theirs).
    case "${1:-}" in -*) die "bundle takes no options, only a folder: usage: ./bootstrap.sh bundle [DIR] (./$1 for a folder called $1)" ;; esac
    make_bundle "$@"
    ;;
  update) update_kiosk "$@" ;;
esac
