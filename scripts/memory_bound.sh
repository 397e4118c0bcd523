#!/usr/bin/env bash
# Peak memory of the largest jobs the settings allow (README "Limits"): each runs
# under /usr/bin/time and its peak resident memory is printed beside the estimate the
# settings were checked against (`Settings::memory_estimate`, bound `MAX_JOB_MEMORY`, 6 GiB).
# Too slow for CI (minutes each on two cores); tests/memory_bound.rs checks the same estimate
# per pixel at 1 Mpx on every run. Figures: README.md, "Limits".
#   bash scripts/memory_bound.sh [BINARY]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/cubist}
[ -x "$bin" ] || cargo build --release --bin cubist
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf '| job | estimate | peak | time |\n|---|---|---|---|\n'
run() {
    local name=$1
    shift
    local est
    est=$("$bin" settings "$@" | python3 -c '
import json, sys
s = json.load(sys.stdin)
px = s["width"] * s["height"]
per = 72 + 12 * s["spp"]
loaded = s["facets"] is not None
if s["faceting"] != "none" or loaded: per += 28
if s["faceting"] == "segment" and not loaded: per += 28 + 6 * len(s["segments"])
print(round((px * per + (64 << 20)) / 2**30, 2))')
    /usr/bin/time -f '%M %e' -o "$out/time" "$bin" render -o "$out/o.png" "$@" >/dev/null 2>&1
    read -r kb secs <"$out/time"
    printf '| `%s` | %s GiB | %.2f GiB | %.0f s |\n' "$name" "$est" "$(echo "$kb / 1048576" | bc -l)" "$secs"
}
run "--preset plain --width 8192 --height 8192 --spp 1" --preset plain --width 8192 --height 8192 --spp 1
run "--width 6336 --height 6336 (analytic)" --width 6336 --height 6336 --spp 1
run "--width 7680 --height 4320 (analytic, 8K UHD)" --width 7680 --height 4320 --spp 1
run "--width 5600 --height 5600 --segments 8 levels" --width 5600 --height 5600 --spp 1 \
    --segments 5,10,20,30,60,90,120,150 --thresholds 0,0,0,0,0,0,0,0
