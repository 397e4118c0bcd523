#!/usr/bin/env bash
# The cost of an animation frame after the first, as whole processes.
# A: `cubist render venus_11k --frames 1-2 --orbit 2` at 1000 x 1000 (4 spp, default look);
# B: the same with `--frames 1-1`. Runs A and B in turn RUNS times (default 5) after one warm-up
# each, with /usr/bin/time, and prints the median CPU (user + sys) of each, frame 2's cost A - B
# and its share of B (target <= 0.5), as a table and a `TARGET |` row for BENCHMARKS.md.
# Usage: bash scripts/frames-bench.sh [RUNS]   (builds the release binary first)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
scene=../shared/models/venus_11k.glb
[ -f "$scene" ] || { echo "frames-bench: $scene not found (needs ../shared)" >&2; exit 1; }
cargo build --release --bin cubist >&2
bin=target/release/cubist
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
run() { # $1: frames range; prints "cpu_seconds wall_seconds peak_kib"
    /usr/bin/time -f '%U %S %e %M' -o "$out/time" "$bin" render "$scene" --frames "$1" --orbit 2 \
        --width 1000 --height 1000 -o "$out/f_#.png" --progress none >/dev/null 2>&1
    awk '{ printf "%.3f %.3f %d\n", $1 + $2, $3, $4 }' "$out/time"
}
run 1-2 >/dev/null
run 1-1 >/dev/null
: >"$out/a"
: >"$out/b"
for _ in $(seq "$runs"); do
    run 1-2 >>"$out/a"
    run 1-1 >>"$out/b"
done
median() { sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
a_cpu=$(cut -d' ' -f1 "$out/a" | median)
b_cpu=$(cut -d' ' -f1 "$out/b" | median)
a_wall=$(cut -d' ' -f2 "$out/a" | median)
b_wall=$(cut -d' ' -f2 "$out/b" | median)
share=$(awk -v a="$a_cpu" -v b="$b_cpu" 'BEGIN { printf "%.2f", (a - b) / b }')
frame2=$(awk -v a="$a_cpu" -v b="$b_cpu" 'BEGIN { printf "%.2f", a - b }')
met=$(awk -v s="$share" 'BEGIN { print (s <= 0.5) ? "yes" : "**no**" }')
echo "| figure | A: frames 1-2 | B: frame 1 |"
echo "|---|---:|---:|"
echo "| CPU s (median of $runs) | $a_cpu | $b_cpu |"
echo "| wall s (median of $runs) | $a_wall | $b_wall |"
echo
echo "Frame 2 costs A - B = $frame2 s CPU, ${share}x the first."
echo "TARGET | 15 | frame 2 of a venus_11k turntable (1000 x 1000, 4 spp, default look) against frame 1 (with load and layout), CPU (\`bash scripts/frames-bench.sh\`) | <= 0.5x | ${share}x ($frame2 s against $b_cpu s CPU) | $met |"
