#!/usr/bin/env bash
# Creates .venv with what the Python tests need. Idempotent and quick when already set up.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
    "$PY" -m venv .venv
fi
stamp=.venv/.requirements-$(sha256sum requirements-test.txt | cut -c1-16)
if [ ! -f "$stamp" ]; then
    .venv/bin/pip install --quiet --upgrade pip
    .venv/bin/pip install --quiet -r requirements-test.txt
    touch "$stamp"
fi
