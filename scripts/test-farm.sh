#!/usr/bin/env bash
# The render-farm test: installs Slurm, munge and Blender from Debian when missing and runs
# farm/slurm/test-cluster.sh, which starts a one-node Slurm cluster, renders with the job
# scripts of farm/slurm/ and stops it (a few minutes on two cores).
#
# Without root/apt the test skips, saying why; with CUBIST_REQUIRE_FARM_TEST=1 (.ci/run sets
# it) a failed install, or a cluster that cannot run, is an error instead.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(slurm-wlm munge blender)
have_all() {
    command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v sbatch >/dev/null \
        && command -v munged >/dev/null && command -v blender >/dev/null
}
fail() {
    if [ "${CUBIST_REQUIRE_FARM_TEST:-0}" = 1 ]; then
        echo "error: $1" >&2
        exit 1
    fi
    echo "warning: $1; the Slurm farm test is skipped" >&2
    exit 0
}
if ! have_all; then
    command -v apt-get >/dev/null || fail "apt-get not found: install ${packages[*]} yourself"
    [ "$(id -u)" = 0 ] || fail "not root: the farm test starts munged and slurmd (apt-get install ${packages[*]})"
    echo "== apt-get install ${packages[*]} (Slurm farm test)"
    export DEBIAN_FRONTEND=noninteractive
    if ! apt-get update -qq || ! apt-get install -y -qq "${packages[@]}" >/dev/null; then
        fail "apt-get install ${packages[*]} failed"
    fi
    have_all || fail "installed ${packages[*]} but a command is still missing"
fi
# The renderer as `cargo test --release` builds it (scripts/test.sh just did: nothing to do
# then; `cargo build` would build it again with the non-test feature set).
cargo test --release --locked --quiet --no-run --test nodes
start=$SECONDS
bash farm/slurm/test-cluster.sh
echo "farm test: $((SECONDS - start)) s"
