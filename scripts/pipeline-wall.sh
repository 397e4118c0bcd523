#!/usr/bin/env bash
# The default pipeline on venus_11k at 1000 x 1000 as whole processes, wall and
# CPU (user + sys) medians, and each stage's wall and CPU medians from `cubist render -v`.
# With a second binary (B), runs A B A B ... and prints the ratios A/B pair by pair: under load
# the paired ratio is the figure to trust.
#
#   bash scripts/pipeline-wall.sh [RUNS] [BINARY_A] [BINARY_B]
#
# RUNS defaults to 7; BINARY_A to target/release/cubist (built if absent). Extra arguments for
# the render (another scene, size or preset) go in CUBIST_ARGS. A warm-up run of each binary
# is not counted. Needs ../shared/models/venus_11k.glb beside the checkout.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-7}
a=${2:-target/release/cubist}
b=${3:-}
scene=../shared/models/venus_11k.glb
[[ -f $scene ]] || { echo "no $scene: nothing measured" >&2; exit 1; }
[[ -x $a ]] || cargo build --release --bin cubist
args=(render "$scene" --width 1000 --height 1000 ${CUBIST_ARGS:-})
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# One run of binary $1 into files $tmp/$2.*: "wall cpu" and the -v stage lines.
one() {
    /usr/bin/time -f "%e %U %S" -o "$tmp/t" "$1" "${args[@]}" -o "$tmp/out.png" -v >"$tmp/v" 2>&1
    read -r wall user sys <"$tmp/t"
    awk -v w="$wall" -v u="$user" -v s="$sys" 'BEGIN {print w, u + s}' >>"$tmp/$2.time"
    # "      stage:   12.3 ms (20.1 ms CPU)" -> "stage wall cpu"
    sed -n 's/^ *\([a-z+ -]*[a-z+-]\): *\([0-9.]*\) ms (\([0-9.]*\) ms CPU)$/\1|\2|\3/p;
            s/^ *\(load+bvh\): *\([0-9.]*\) ms$/\1|\2|/p' "$tmp/v" >>"$tmp/$2.stages"
}

median() { sort -g | awk '{v[NR]=$1} END {if (NR==0) print "-"; else if (NR%2) print v[(NR+1)/2]; else printf "%.4g\n", (v[NR/2]+v[NR/2+1])/2}'; }

one "$a" warm
[[ -n $b ]] && one "$b" warm
for ((i = 0; i < runs; i++)); do
    one "$a" A
    [[ -n $b ]] && one "$b" B
done

echo "venus_11k 1000 x 1000 ${CUBIST_ARGS:-(defaults)}, $runs runs each, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| figure | A median | B median | A/B median (min-max) |"
echo "|---|---|---|---|"
for col in 1 2; do
    name=$([[ $col == 1 ]] && echo "wall s" || echo "CPU s")
    ma=$(cut -d' ' -f$col "$tmp/A.time" | median)
    if [[ -n $b ]]; then
        mb=$(cut -d' ' -f$col "$tmp/B.time" | median)
        ratios=$(paste -d' ' <(cut -d' ' -f$col "$tmp/A.time") <(cut -d' ' -f$col "$tmp/B.time") | awk '{printf "%.4f\n", $1/$2}')
        rm=$(echo "$ratios" | median)
        rmin=$(echo "$ratios" | sort -g | head -1)
        rmax=$(echo "$ratios" | sort -g | tail -1)
        echo "| $name | $ma | $mb | $rm ($rmin-$rmax) |"
    else
        echo "| $name | $ma | - | - |"
    fi
done
echo
echo "| stage | A wall ms | A CPU ms | B wall ms | B CPU ms |"
echo "|---|---|---|---|---|"
cut -d'|' -f1 "$tmp/A.stages" | awk '!seen[$0]++' | while read -r stage; do
    col() {
        if [[ -f $tmp/$1.stages ]]; then
            { grep "^$stage|" "$tmp/$1.stages" || true; } | cut -d'|' -f"$2" | { grep . || true; } | median
        else
            echo -
        fi
    }
    echo "| $stage | $(col A 2) | $(col A 3) | $(col B 2) | $(col B 3) |"
done
