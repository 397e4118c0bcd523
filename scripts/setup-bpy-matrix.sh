#!/usr/bin/env bash
# Creates one venv per Blender release of requirements-bpy-matrix.txt (.venv-bpy42 for bpy 4.2.x,
# .venv-bpy45 for 4.5.x), each with that bpy only, for tests/python/test_blender_versions.py
# (bpy 5.0.1 comes from .venv, scripts/setup-python.sh). Idempotent: a venv whose stamp names its
# pinned version is kept. The venvs are created in parallel (the wheels are ~370 MB each: the
# time is mostly download), and scripts/test.sh runs this in the background while cargo tests.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}

one() {
    local pin=$1 version venv stamp
    version=${pin#bpy==}
    venv=.venv-bpy$(echo "$version" | cut -d. -f1,2 | tr -d .)
    stamp=$venv/.bpy-$version
    [ -f "$stamp" ] && return 0
    rm -rf "$venv"
    "$PY" -m venv "$venv"
    "$venv/bin/pip" install --quiet --disable-pip-version-check --no-cache-dir "$pin"
    touch "$stamp"
    echo "$venv: bpy $version"
}

pids=()
while read -r pin; do
    one "$pin" &
    pids+=($!)
done < <(grep -E '^bpy==' requirements-bpy-matrix.txt)
status=0
for pid in "${pids[@]}"; do
    wait "$pid" || status=1
done
exit $status
