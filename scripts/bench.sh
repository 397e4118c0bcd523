#!/usr/bin/env bash
# Regenerates BENCHMARKS.md: a description of this machine, then the tables printed by
# benches/pipeline.rs (primary rays, spp against PSNR, stage timings). About 2-4 minutes.
#   bash scripts/bench.sh [SCENE] [extra bench options, see: cargo bench --bench pipeline -- --help]
# Benchmarks, not tests: nothing here fails on a slow machine. Run it on a quiet machine when
# you can; the tables give CPU times too, which hold up on a shared one.
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-../shared/models/venus_11k.glb}
shift || true
if [ ! -f "$scene" ]; then
    echo "note: $scene is absent: benchmarking the built-in still life" >&2
fi
cargo bench --locked --bench pipeline --no-run
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
tables=$(cargo bench --locked --bench pipeline -- --scene "$scene" "$@")
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
flags=$(grep -m1 '^flags' /proc/cpuinfo)
simd=$(for f in sse4_2 popcnt avx2 fma avx512f; do case " $flags " in *" $f "*) printf '%s ' "$f";; esac; done)
mem=$(awk '/MemTotal/ {printf "%.1f GiB", $2 / 1048576}' /proc/meminfo)
obvhs=$(awk '/^name = "obvhs"/ {getline; print $3}' Cargo.lock | tr -d '"')
rustflags=$(grep -m1 'rustflags' .cargo/config.toml 2>/dev/null | sed 's/^ *//' || true)
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=$(git diff --quiet 2>/dev/null || echo " (with uncommitted changes)")
tmp=BENCHMARKS.md.tmp
{
    echo "# Benchmarks"
    echo
    echo "Regenerate with \`bash scripts/bench.sh\` (writes this file). Benchmarks, not tests: see"
    echo "\`benches/pipeline.rs\` for what each table measures."
    echo
    echo "## Machine"
    echo
    echo "- CPU: $cpu, $(nproc) logical cores available (SIMD: ${simd% })"
    echo "- Memory: $mem"
    echo "- $(uname -sr), $(rustc --version)"
    echo "- Build: release profile, \`$rustflags\` (.cargo/config.toml), obvhs $obvhs (BVH2: medium preset without reinsertion, see src/accel.rs)"
    echo "- Load average (1, 5, 15 min) before: $load_before; after: $load_after"
    echo "- Commit $commit$dirty, $(date -u '+%Y-%m-%d %H:%M UTC')"
    echo
    echo "## Results"
    echo
    echo "$tables"
    echo
    echo "## Not measured yet"
    echo
    echo "These need stages that are being built on other branches; the bench gains a table for"
    echo "each when they are merged: mesh saliency exact against any approximation (error, time),"
    echo "Segment faceting's superpixel count against boundary agreement. The stage table above"
    echo "lists whatever stages \`render\` times, so saliency, facets, imprecision and paint appear"
    echo "there by themselves."
} > "$tmp"
mv "$tmp" BENCHMARKS.md
echo "wrote BENCHMARKS.md" >&2
