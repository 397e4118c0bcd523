#!/usr/bin/env bash
# Creates .venv with what the Python tests need. Idempotent and quick when already set up.
# Two pip calls: requirements-test.txt, then requirements-test-late.txt (PyOpenGL 3.1.7 over
# pyrender's pin; one call makes pip backtrack to a pyrender that breaks on Python 3.11).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
    "$PY" -m venv .venv
fi
late=requirements-test-late.txt
stamp=.venv/.requirements-$(cat requirements-test.txt $late 2>/dev/null | sha256sum | cut -c1-16)
if [ ! -f "$stamp" ]; then
    .venv/bin/pip install --quiet --upgrade pip
    .venv/bin/pip install --quiet -r requirements-test.txt
    if [ -f "$late" ]; then
        # pip warns that pyrender wants PyOpenGL==3.1.0: expected (see the file).
        if ! out=$(.venv/bin/pip install --quiet -r "$late" 2>&1); then
            echo "$out" >&2
            exit 1
        fi
        echo "$out" | grep -v -e "dependency resolver" -e "requires PyOpenGL==3.1.0" -e "^$" >&2 || true
    fi
    rm -f .venv/.requirements-*
    touch "$stamp"
fi
# pyrender renders offscreen on the CPU through EGL (Mesa llvmpipe). Debian 12 machines of
# this project have libEGL and Mesa's drivers; say what is missing rather than fail obscurely.
if ! ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1'; then
    echo "warning: libEGL.so.1 not found: the pyrender reference test needs Mesa's EGL" \
        "(Debian: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri)" >&2
fi
