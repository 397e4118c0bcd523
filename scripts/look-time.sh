#!/usr/bin/env bash
# The look's time target: "the whole look at 1000x1000 takes at most 1.2x today's time", where
# "today" is the default render of commit f4ae480, before the look work. Times OLD_BIN's
# default render and NEW_BIN's default render at 1000 x 1000, runs paired (old, new; then new,
# old; ...) so a drift in the machine's speed hits both, and prints per scene the median wall
# and CPU (user + sys) seconds of each and the median of the paired ratios new / old.
#
#   git worktree add ../wt-old f4ae480
#   (cd ../wt-old && CARGO_TARGET_DIR=$PWD/target cargo build --release --bin cubist)
#   bash scripts/look-time.sh ../wt-old/target/release/cubist target/release/cubist
#   RUNS=5 bash scripts/look-time.sh OLD NEW ../shared/models/venus_11k.glb still-life
#
# Scenes: .glb/.gltf files, folders of them, or `still-life` (the built-in scene: no scene
# argument); default ../shared/models, ../shared/gltf-samples and the still life. A scene
# either binary refuses (an unsupported extension) is listed as skipped. Both CLIs take
# `render [SCENE] -o OUT --width W --height H --progress none`. Wall times on a shared machine
# are inflated by the load (printed before and after): quote the CPU ratios beside them.
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: $0 OLD_BIN NEW_BIN [SCENE|DIR|still-life ...]" >&2
    exit 2
fi
old=$1
new=$2
shift 2
for b in "$old" "$new"; do
    if [ ! -x "$b" ]; then
        echo "not an executable: $b" >&2
        exit 2
    fi
done
SHARED=${SHARED:-$(dirname "$0")/../../shared}
RUNS=${RUNS:-3}
SIZE=${SIZE:-1000}
args=("$@")
if [ ${#args[@]} -eq 0 ]; then args=("$SHARED/models" "$SHARED/gltf-samples" still-life); fi
scenes=()
for a in "${args[@]}"; do
    if [ -d "$a" ]; then
        for f in "$a"/*.glb "$a"/*.gltf; do [ -e "$f" ] && scenes+=("$f"); done
    else
        scenes+=("$a")
    fi
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# One render; prints "wall cpu" in seconds, or nothing when the render failed.
run() {
    local bin=$1 scene=$2 scene_arg=()
    [ "$scene" != still-life ] && scene_arg=("$scene")
    if /usr/bin/time -f "%e %U %S" -o "$tmp/t" "$bin" render "${scene_arg[@]}" -o "$tmp/out.png" \
        --width "$SIZE" --height "$SIZE" --progress none >/dev/null 2>"$tmp/err"; then
        awk '{ printf "%.3f %.3f\n", $1, $2 + $3 }' "$tmp/t"
    fi
}
median() { sort -g | awk '{ v[NR] = $1 } END { if (NR % 2) print v[(NR + 1) / 2]; else print (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg); $(nproc) cpus; $RUNS paired runs per scene, ${SIZE} x ${SIZE}"
echo
echo "| scene | old wall s | new wall s | wall ratio | old CPU s | new CPU s | CPU ratio |"
echo "|---|---|---|---|---|---|---|"
worst_cpu=0
worst_wall=0
worst_scene=
skipped=()
for scene in "${scenes[@]}"; do
    name=$(basename "$scene")
    : >"$tmp/rows"
    ok=1
    for ((i = 0; i < RUNS; i++)); do
        # Alternate which binary goes first, so neither always runs on a warmer cache.
        if ((i % 2 == 0)); then
            o=$(run "$old" "$scene") || true
            n=$(run "$new" "$scene") || true
        else
            n=$(run "$new" "$scene") || true
            o=$(run "$old" "$scene") || true
        fi
        if [ -z "$o" ] || [ -z "$n" ]; then
            ok=0
            break
        fi
        echo "$o $n" >>"$tmp/rows"
    done
    if [ $ok = 0 ]; then
        skipped+=("$name: $(head -c 200 "$tmp/err" | tr '\n' ' ')")
        continue
    fi
    ow=$(awk '{ print $1 }' "$tmp/rows" | median)
    oc=$(awk '{ print $2 }' "$tmp/rows" | median)
    nw=$(awk '{ print $3 }' "$tmp/rows" | median)
    nc=$(awk '{ print $4 }' "$tmp/rows" | median)
    rw=$(awk '{ print $3 / $1 }' "$tmp/rows" | median)
    rc=$(awk '{ print $4 / $2 }' "$tmp/rows" | median)
    printf "| %s | %.2f | %.2f | %.2fx | %.2f | %.2f | %.2fx |\n" "$name" "$ow" "$nw" "$rw" "$oc" "$nc" "$rc"
    if awk -v a="$rc" -v b="$worst_cpu" 'BEGIN { exit !(a > b) }'; then
        worst_cpu=$rc
        worst_scene=$name
    fi
    if awk -v a="$rw" -v b="$worst_wall" 'BEGIN { exit !(a > b) }'; then worst_wall=$rw; fi
done
echo
printf "worst CPU ratio %.2fx (%s); worst wall ratio %.2fx; target <= 1.2x\n" "$worst_cpu" "$worst_scene" "$worst_wall"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
for s in "${skipped[@]}"; do echo "skipped: $s"; done
