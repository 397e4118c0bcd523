#!/usr/bin/env bash
# Fuzzes the malformed-input paths for a bounded time (not part of CI):
#   bash scripts/fuzz.sh [SECONDS_PER_TARGET=120] [TARGET...]
# Targets (fuzz/fuzz_targets/): gltf_loader (Scene::from_slice on GLB / .gltf bytes, then a
# tiny render of whatever loads) and settings_json (Settings::from_layers, then framing).
# The corpus starts from fuzz/seeds/<target> (ours, committed), tests/fuzz_regressions/<target>
# (every crash found so far) and, when ../shared is present, its glTF samples and invalid
# files (copied at run time, never committed: their licences vary). Crashes land in
# fuzz/artifacts/<target>/; minimise one with `cargo +nightly fuzz tmin <target> <file>`, fix
# it, and keep it as tests/fuzz_regressions/<target>/<name> (tests/fuzz_regressions.rs).
# cargo-fuzz needs a nightly compiler: the nightly toolchain when installed, else the stable
# one with RUSTC_BOOTSTRAP=1.
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-120}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(gltf_loader settings_json settings_scene layout_file)

if rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
    tc=(+nightly)
else
    tc=()
    export RUSTC_BOOTSTRAP=1
fi
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
[ -d fuzz/seeds/gltf_loader ] || python3 fuzz/make_seeds.py

shared=../shared
status=0
for t in "${targets[@]}"; do
    corpus=fuzz/corpus/$t
    mkdir -p "$corpus" "fuzz/artifacts/$t"
    cp -n fuzz/seeds/"$t"/* "$corpus"/ 2>/dev/null || true
    cp -n tests/fuzz_regressions/"$t"/* "$corpus"/ 2>/dev/null || true
    if [ "$t" = gltf_loader ] && [ -d "$shared" ]; then
        find "$shared/gltf-samples" "$shared/gltf-invalid" -type f \( -name '*.glb' -o -name '*.gltf' \) -size -300k \
            -exec sh -c 'for f; do n=${f#../}; cp -n "$f" "$0/$(echo "$n" | tr / _)"; done' "$corpus" {} +
    fi
    before=$(ls "fuzz/artifacts/$t" | wc -l)
    echo "== fuzzing $t for $secs s (corpus: $(ls "$corpus" | wc -l) files)"
    set +e
    (cd fuzz && cargo "${tc[@]}" fuzz run "$t" "corpus/$t" -- \
        -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1) \
        2>&1 | tee "fuzz/artifacts/$t.log" | grep -E '^(#[0-9]+ +(DONE|INITED)|stat::number_of_executed_units|stat::average_exec_per_sec|==[0-9]+==ERROR|SUMMARY|Test unit written|thread .* panicked)'
    rc=${PIPESTATUS[0]}
    set -e
    after=$(ls "fuzz/artifacts/$t" | wc -l)
    echo "== $t: exit $rc, $((after - before)) new crashing input(s) in fuzz/artifacts/$t (log: fuzz/artifacts/$t.log)"
    [ "$rc" -eq 0 ] || status=1
done
exit $status
