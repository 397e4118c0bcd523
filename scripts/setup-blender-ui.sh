#!/usr/bin/env bash
# Installs what the windowed-Blender test (tests/python/test_blender_ui.py) needs on Debian:
# Debian's Blender (3.4.1 on Debian 12, the only windowed Blender installable from a package
# registry), Xvfb to give it a display, xauth for xvfb-run, xdotool to press Esc, and numpy for
# Blender's system Python. Idempotent: nothing is done when they are there.
#
# Without root/apt the test skips, saying why; with CUBIST_REQUIRE_UI_TEST=1 (.ci/run sets it)
# a failed install is an error instead.
set -euo pipefail

packages=(blender xvfb xauth xdotool python3-numpy)
have_all() {
    command -v blender >/dev/null && command -v xvfb-run >/dev/null && command -v xauth >/dev/null \
        && command -v xdotool >/dev/null && dpkg -s python3-numpy >/dev/null 2>&1
}

if have_all; then
    exit 0
fi
fail() {
    if [ "${CUBIST_REQUIRE_UI_TEST:-0}" = 1 ]; then
        echo "error: $1" >&2
        exit 1
    fi
    echo "warning: $1; the windowed Blender test will be skipped" >&2
    exit 0
}
if ! command -v apt-get >/dev/null; then
    fail "apt-get not found: install ${packages[*]} yourself"
fi
if [ "$(id -u)" = 0 ]; then
    sudo=()
elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
    sudo=(sudo -n)
else
    fail "not root (and no password-less sudo): apt-get install ${packages[*]}"
fi
echo "== apt-get install ${packages[*]} (windowed Blender test)"
export DEBIAN_FRONTEND=noninteractive
if ! "${sudo[@]}" apt-get update -qq || ! "${sudo[@]}" apt-get install -y -qq "${packages[@]}" >/dev/null; then
    fail "apt-get install ${packages[*]} failed"
fi
have_all || fail "installed ${packages[*]} but some command is still missing"
