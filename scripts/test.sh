#!/usr/bin/env bash
# Sets up everything the tests need on a fresh machine (Rust toolchain + Python 3.11 only)
# and runs every test: cargo's (unit, integration, property, golden) and the Python ones
# (Blender add-on in headless bpy and in a windowed Blender under Xvfb, pyrender reference).
# Safe to re-run: the venv is reused, installed packages are kept.
# Tests that need the shared test data (../shared, beside the checkout) are marked
# `#[ignore = "needs ../shared"]`: they run here when ../shared is present, and are counted
# as ignored without it.
set -euo pipefail
cd "$(dirname "$0")/.."

# The Blender LTS venvs (bpy 4.2, 4.5: ~370 MB each) download while cargo builds and tests.
mkdir -p target
bash scripts/setup-bpy-matrix.sh >target/setup-bpy-matrix.log 2>&1 &
bpy_matrix=$!

echo "== cargo test (release: the same build the CLI uses)"
if [ -d ../shared ]; then
    cargo test --release --locked -- --include-ignored
else
    echo "../shared is absent: the tests that need it are reported as ignored"
    cargo test --release --locked
fi

if ls tests/python/test_*.py >/dev/null 2>&1; then
    echo "== python tests"
    bash scripts/setup-python.sh
    # Debian's Blender, Xvfb and xdotool for the windowed-Blender test (skipped, saying why,
    # where they cannot be installed; .ci/run requires them).
    bash scripts/setup-blender-ui.sh
    wait "$bpy_matrix" || { cat target/setup-bpy-matrix.log >&2; exit 1; }
    .venv/bin/python -m pytest -q -rs tests/python
fi

# A one-node Slurm cluster running farm/slurm/'s job scripts (skipped, saying why, without
# root; .ci/run requires it).
bash scripts/test-farm.sh
