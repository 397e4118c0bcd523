#!/usr/bin/env bash
# Submits a cubist render to Slurm as two jobs: the layout step, then an array of TASKS tasks
# that starts when it succeeded (docs/farm.md).
#
#   farm/slurm/submit.sh gltf  SCENE.glb  FIRST-LAST TASKS OUT [CUBIST RENDER FLAGS...]
#   farm/slurm/submit.sh blend SHOT.blend FIRST-LAST TASKS OUT
#
# The frames are split into TASKS chunks of equal size (the last may be shorter). SCENE and OUT
# must be on storage every node sees; the frames go to OUT/frames/, the logs to OUT/logs/.
# Prints the two job ids ("LAYOUT_JOB FRAMES_JOB") on stdout. Other sbatch options come from
# sbatch's own environment variables (e.g. SBATCH_PARTITION, SBATCH_TIMELIMIT).
set -euo pipefail

usage() {
    echo "usage: $0 gltf SCENE.glb FIRST-LAST TASKS OUT [CUBIST RENDER FLAGS...]" >&2
    echo "       $0 blend SHOT.blend FIRST-LAST TASKS OUT" >&2
    exit 2
}
[ $# -ge 5 ] || usage
kind=$1 scene=$2 range=$3 tasks=$4 out=$5
shift 5
case $kind in
    gltf) script=cubist-gltf.sbatch ;;
    blend) script=cubist-blend.sbatch; [ $# = 0 ] || usage ;;
    *) usage ;;
esac
[[ $range =~ ^([0-9]+)-([0-9]+)$ ]] && [ "${BASH_REMATCH[1]}" -le "${BASH_REMATCH[2]}" ] \
    || { echo "error: frame range '$range' is not FIRST-LAST" >&2; exit 2; }
total=$((BASH_REMATCH[2] - BASH_REMATCH[1] + 1))
[[ $tasks =~ ^[1-9][0-9]*$ ]] || { echo "error: TASKS '$tasks' is not a positive number" >&2; exit 2; }
[ -f "$scene" ] || { echo "error: $scene not found" >&2; exit 1; }
chunk=$(((total + tasks - 1) / tasks))
count=$(((total + chunk - 1) / chunk))
here=$(cd "$(dirname "$0")" && pwd)
scene=$(realpath "$scene")
out=$(realpath -m "$out")
mkdir -p "$out/logs"

id() { cut -d';' -f1; }
layout=$(sbatch --parsable --output "$out/logs/%x-%j-layout.log" \
    "$here/$script" "$scene" "$range" "$chunk" "$out" "$@" | id)
frames=$(sbatch --parsable --array="1-$count" --dependency="afterok:$layout" --kill-on-invalid-dep=yes \
    --output "$out/logs/%x-%A_%a.log" "$here/$script" "$scene" "$range" "$chunk" "$out" "$@" | id)
echo "submitted: layout job $layout, then job $frames: $count tasks of $chunk frames ($range) -> $out/frames" >&2
echo "$layout $frames"
