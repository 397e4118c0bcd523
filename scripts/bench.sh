#!/usr/bin/env bash
# Runs every bench binary (benches/*.rs) and writes target/bench-report.md: a description of
# this machine, a summary of the targets, then each binary's tables. BENCHMARKS.md keeps the
# latest figure of each benchmark by hand, from this report and the scripts it names.
# About 5 minutes on 2 idle cores; --quick about 2 (fewer runs and seeds, smaller figures).
#   bash scripts/bench.sh [--quick] [SCENE]      (SCENE: the pipeline tables' scene, default venus_11k)
# Benchmarks, not tests: nothing here fails on a slow machine. Run it on a quiet machine when
# you can; the tables give CPU times too, which hold up on a shared one. Exact saliency of
# meshes over 3e8 pairs comes from an earlier `cargo bench --bench saliency` (without
# --quick) when one left its result in target/; otherwise its error is sampled.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=()
scene=../shared/models/venus_11k.glb
for arg in "$@"; do
    case $arg in
        --quick) quick=(--quick) ;;
        -h | --help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) scene=$arg ;;
    esac
done
if [ ! -f "$scene" ]; then
    echo "note: $scene is absent: the pipeline tables use the built-in still life" >&2
fi
benches=(pipeline saliency facet_stages segment paint serve)
cargo bench --locked --no-run $(printf -- '--bench %s ' "${benches[@]}") 2>/dev/null ||
    cargo bench --locked --no-run $(printf -- '--bench %s ' "${benches[@]}")
log=$(mktemp)
trap 'rm -f "$log"' EXIT
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
start=$(date +%s)
declare -A out
for b in "${benches[@]}"; do
    echo "running benches/$b.rs ..." >&2
    t0=$(date +%s)
    case $b in
        pipeline) args=(--scene "$scene" "${quick[@]}") ;;
        # The huge mesh's clustered figures always; its exact sums only from an earlier full run.
        saliency) args=(--quick) ;;
        *) args=("${quick[@]}") ;;
    esac
    out[$b]=$(cargo bench --locked --bench "$b" -- "${args[@]}" 2>>"$log") || {
        cat "$log" >&2
        exit 1
    }
    echo "  $(($(date +%s) - t0)) s" >&2
done
seconds=$(($(date +%s) - start))
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
flags=$(grep -m1 '^flags' /proc/cpuinfo)
simd=$(for f in sse4_2 popcnt avx2 fma avx512f; do case " $flags " in *" $f "*) printf '%s ' "$f" ;; esac; done)
mem=$(awk '/MemTotal/ {printf "%.1f GiB", $2 / 1048576}' /proc/meminfo)
obvhs=$(awk '/^name = "obvhs"/ {getline; print $3}' Cargo.lock | tr -d '"')
rustflags=$(grep -m1 'rustflags' .cargo/config.toml 2>/dev/null | sed 's/^ *//' || true)
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=$(git diff --quiet HEAD 2>/dev/null || echo " (with uncommitted changes)")
mode=${quick[0]:-full}
# The lines `TARGET | group | what | target | measured | met |` go to the summary; the rest
# stays in its section.
body() { grep -v '^TARGET |' <<<"${out[$1]}" || true; }
targets=$(for b in "${benches[@]}"; do grep '^TARGET |' <<<"${out[$b]}" || true; done | sort -t'|' -k2,2n -s | sed 's/^TARGET //')
report=target/bench-report.md
mkdir -p target
{
    echo "# Bench report"
    echo
    echo "Written by \`bash scripts/bench.sh\` (\`--quick\` for a shorter run). Benchmarks, not tests:"
    echo "each table says what it measures; the bench binaries in \`benches/\` say how."
    echo
    echo "## Machine"
    echo
    echo "- CPU: $cpu, $(nproc) logical cores available (SIMD: ${simd% })"
    echo "- Memory: $mem"
    echo "- $(uname -sr), $(rustc --version)"
    echo "- Build: release profile, \`$rustflags\` (.cargo/config.toml), obvhs $obvhs (BVH2: medium preset without reinsertion, see src/accel.rs)"
    echo "- Load average (1, 5, 15 min) before: $load_before; after: $load_after (the machine is shared: see each table's CPU times)"
    echo "- Commit $commit$dirty, $(date -u '+%Y-%m-%d %H:%M UTC'); run: $mode, $seconds s"
    echo
    echo "## Summary of targets"
    echo
    echo "| group | what | target | measured | met |"
    echo "|---|---|---|---|---|"
    if [ -n "$targets" ]; then echo "$targets"; fi
    echo
    echo "## The pipeline (\`benches/pipeline.rs\`)"
    echo
    body pipeline
    echo
    echo "## Mesh saliency (\`benches/saliency.rs --quick\`)"
    echo
    echo "Per mesh class (generated uniform, adaptive, scanned-like, CAD-like meshes; shared models;"
    echo "glTF samples; bunny_full refined by PN triangles) and size up to 2M vertices: the exact"
    echo "sums' work counted on the mesh, the method \`auto\` picks, its time, and the error of the"
    echo "final [0, 1] saliency against the exact method (full, or sampled where the exact sums"
    echo "are too long; an earlier full run's exact results are reused from target/saliency-bench)."
    echo
    body saliency
    echo
    echo "## Facets and spatial imprecision (\`benches/facet_stages.rs\`)"
    echo
    body facet_stages
    echo
    echo "## Segment faceting (\`benches/segment.rs\`)"
    echo
    body segment
    echo
    echo "## Painterly effects (\`benches/paint.rs\`)"
    echo
    body paint
    echo
    echo "## \`cubist serve\`, requests to a kept session (\`benches/serve.rs\`)"
    echo
    body serve
} >"$report"
echo "wrote $report ($seconds s)" >&2
