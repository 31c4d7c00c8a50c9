#!/usr/bin/env bash
# Sets up this checkout on a fresh Debian machine and runs one job:
#   ./bootstrap.sh run  [ARGS...]   install what the exhibit needs, then run it
#   ./bootstrap.sh test [ARGS...]   install what the tests need, then run the test suite
# System packages come from apt-get when run as root; otherwise the missing ones are named and
# the script stops. Python packages go into ./.venv (reused while pyproject.toml is unchanged).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$here"

job="${1:-}"
case "$job" in
  run|test) shift ;;
  *) echo "usage: ./bootstrap.sh run|test [ARGS...]" >&2; exit 2 ;;
esac

# System packages, by job. Each line says who needs it.
apt_run=(
  python3 python3-venv python3-pip   # the interpreter and venv (Python >= 3.11)
  libegl1 libgl1 libgl1-mesa-dri     # OpenGL/EGL, with Mesa llvmpipe where there is no GPU
  fonts-dejavu-core                  # the HUD's font (has θ and ∞)
)
apt_test=(
  "${apt_run[@]}"
  gcc make pkg-config gcc-avr binutils-avr avr-libc arduino-core-avr libsimavr-dev libelf-dev  # firmware: host and AVR builds, simavr harness (tests/firmware)
  xvfb                     # renderer: window tests under Xvfb
  systemd                  # kiosk: systemd-analyze verify/security on the units (tests/kiosk)
  cage xwayland grim       # deploy: the kiosk on cage as in docs/DEPLOYMENT.md, frame grabbed (tests/deploy)
  libwayland-client0 libwayland-egl1 libwayland-cursor0 libxkbcommon0  # deploy: GLFW's Wayland build
  prometheus               # kiosk: promtool checks `exhibit status --prometheus` (tests/kiosk)
)

say() { printf 'bootstrap: %s\n' "$*" >&2; }

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
    say "install them as root:  apt-get update && apt-get install -y ${missing[*]}"
    exit 1
  fi
  say "installing system packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
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

setup_venv() {
  local extras="$1"
  local py; py="$(pick_python)"
  if [ ! -x .venv/bin/python ]; then
    say "creating .venv with $py"
    "$py" -m venv .venv
  fi
  local stamp=".venv/.exhibit-install-stamp"
  local want; want="$extras $(sha256sum pyproject.toml | cut -d' ' -f1)"
  if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    say "installing Python packages into .venv"
    .venv/bin/python -m pip install -q --upgrade pip
    .venv/bin/python -m pip install -q -e ".${extras}"
    echo "$want" > "$stamp"
  fi
}

case "$job" in
  run)
    install_system_packages "${apt_run[@]}"
    setup_venv ""
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
    install_system_packages "${apt_test[@]}"
    setup_venv "[test]"
    markers=()
    # CI also runs the slow soak and fuzz tests.
    [ "${CI:-}" = "true" ] && markers=(-m "")
    exec .venv/bin/python -m pytest "${markers[@]}" "$@"
    ;;
esac
