#!/usr/bin/env bash
# Runs the Slurm job scripts on a live one-node cluster on this machine and checks them:
#
# 1. glTF: farm/slurm/submit.sh renders 12 frames of an animated sample in 4 array tasks after
#    a layout step; every frame must equal, byte for byte, one `cubist render --frames 1-12`
#    process. A requeued task must rewrite its frames (new files) with the same bytes.
# 2. .blend: the same through Blender (Debian's) and the Cubist add-on installed on the "node"
#    as a legacy add-on, against one `blender -b shot.blend -E CUBIST -a` process.
# 3. Bad nodes: a task whose Blender lacks the add-on, one whose add-on finds no `cubist`
#    binary, and a glTF task without the binary must end FAILED, naming the cause in their
#    log, having written no frame.
#
# The cluster (munged, slurmctld, slurmd) runs from a scratch folder holding its config, key,
# state and logs, on free ports; it is stopped and the folder removed at the end, also on
# failure or Ctrl-C. Needs root, slurm-wlm, munge and blender (scripts/test-farm.sh installs
# them), a release build of cubist and ../shared. When something is missing the test says so
# and skips, or fails when CUBIST_REQUIRE_FARM_TEST=1 (CI); a cluster that does not start
# always fails, with its logs.
#
#   bash farm/slurm/test-cluster.sh            # CUBIST=path overrides target/release/cubist
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
fox=$root/../shared/gltf-samples/Fox.glb
cubist=$(realpath -m "${CUBIST:-$root/target/release/cubist}")
# The frames' size and motion: small, so the test takes a few minutes on two cores.
gltf_flags=(--width 128 --height 96 --animation Walk --fps 12)

skip() {
    if [ "${CUBIST_REQUIRE_FARM_TEST:-0}" = 1 ]; then
        echo "error: farm test: $1" >&2
        exit 1
    fi
    echo "SKIPPED farm/slurm/test-cluster.sh: $1"
    exit 0
}
for cmd in munged munge unmunge slurmctld slurmd sbatch squeue scontrol sinfo blender python3 sha256sum; do
    command -v "$cmd" >/dev/null || skip "'$cmd' not found (apt-get install slurm-wlm munge blender)"
done
[ "$(id -u)" = 0 ] || skip "needs root (munged runs as the munge user, slurmd as root)"
id munge >/dev/null 2>&1 || skip "no 'munge' user (the munge package creates it)"
[ -x "$cubist" ] || skip "no cubist binary at $cubist: cargo build --release"
[ -f "$fox" ] || skip "$fox not found (../shared beside the checkout)"

failures=0
check() {  # check NAME CONDITION-COMMAND...: records and prints the outcome
    local name=$1
    shift
    if "$@"; then
        echo "PASS: $name"
    else
        echo "FAIL: $name"
        failures=$((failures + 1))
    fi
}
die() {
    echo "FAIL: $*" >&2
    exit 1
}

work=$(mktemp -d /tmp/cubist-slurm.XXXXXX)
chmod 755 "$work"
export SLURM_CONF=$work/slurm.conf
stop_cluster() {
    local code=$?
    set +e
    if [ -f "$SLURM_CONF" ] && [ -f "$work/slurmctld.pid" ]; then
        scancel --user=root --full >/dev/null 2>&1
    fi
    for pidfile in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munge/munged.pid"; do
        [ -f "$pidfile" ] || continue
        pid=$(cat "$pidfile")
        kill "$pid" 2>/dev/null
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null
    done
    if [ "$code" != 0 ] && [ -z "${KEEP:-}" ]; then
        for log in "$work"/slurmctld.log "$work"/slurmd.log; do
            [ -f "$log" ] && { echo "--- last lines of $log"; tail -n 15 "$log"; }
        done
    fi
    if [ -n "${KEEP:-}" ]; then
        echo "kept $work (KEEP is set)"
    else
        rm -rf "$work"
    fi
    exit "$code"
}
trap stop_cluster EXIT
trap 'exit 130' INT TERM

# ---- the cluster

echo "== starting a one-node Slurm cluster in $work"
mkdir -p "$work/munge/key" "$work/state" "$work/spool" "$work/shared"
chown -R munge:munge "$work/munge"
chmod 755 "$work/munge"
chmod 700 "$work/munge/key"
head -c 1024 /dev/urandom >"$work/munge/key/munge.key"
chown munge:munge "$work/munge/key/munge.key"
chmod 400 "$work/munge/key/munge.key"
runuser -u munge -- munged --key-file="$work/munge/key/munge.key" --socket="$work/munge/munge.socket" \
    --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" --seed-file="$work/munge/munged.seed" \
    || die "munged did not start: $(tail -n 3 "$work/munge/munged.log" 2>/dev/null)"
munge -S "$work/munge/munge.socket" -n | unmunge -S "$work/munge/munge.socket" >/dev/null \
    || die "munge does not work: $(tail -n 3 "$work/munge/munged.log")"

host=$(hostname -s)
read -r ctld_port slurmd_port < <(python3 -c '
import socket
socks = [socket.socket() for _ in range(2)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*(s.getsockname()[1] for s in socks))')
memory=$(awk '/MemTotal/ { print int($2 / 1024 * 0.9) }' /proc/meminfo)
cat >"$SLURM_CONF" <<EOF
ClusterName=cubisttest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$work/jobcomp.txt
MinJobAge=900
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=$memory State=UNKNOWN
PartitionName=farm Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -f "$SLURM_CONF" || die "slurmctld did not start: $(tail -n 5 "$work/slurmctld.log" 2>/dev/null)"
slurmd -f "$SLURM_CONF" -N "$host" || die "slurmd did not start: $(tail -n 5 "$work/slurmd.log" 2>/dev/null)"
for i in $(seq 60); do
    state=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
    [ "$state" = idle ] && break
    [ "$i" = 60 ] && die "the node is '${state:-unknown}', not idle, 60 s after starting slurmd"
    sleep 1
done
echo "node $host idle (slurmctld port $ctld_port, slurmd port $slurmd_port)"

# ---- helpers

# Waits until every task of job $1 has ended (at most $2 s); prints each task's state.
wait_job() {
    local job=$1 limit=$2 start=$SECONDS
    while squeue -h -j "$job" -o %i 2>/dev/null | grep -q .; do
        if [ $((SECONDS - start)) -gt "$limit" ]; then
            squeue -j "$job" >&2
            die "job $job still queued or running after $limit s"
        fi
        sleep 0.5
    done
}
# The states of job $1's tasks, one per line (COMPLETED, FAILED, ...).
job_states() {
    scontrol -o show job "$1" | grep -o 'JobState=[A-Z_]*' | cut -d= -f2
}
all_completed() {  # all_completed JOB COUNT
    local states
    states=$(job_states "$1")
    [ "$(grep -c '^COMPLETED$' <<<"$states")" = "$2" ] && [ "$(wc -l <<<"$states")" = "$2" ] \
        || { echo "job $1: $(tr '\n' ' ' <<<"$states")" >&2; return 1; }
}
# Every frame_NNNN.* of folder $1 equals the same file of $2, and there are $3 of them.
same_frames() {
    local a=$1 b=$2 count=$3 n=0 f
    for f in "$b"/frame_*; do
        cmp -s "$f" "$a/$(basename "$f")" || { echo "$(basename "$f") differs (or is missing) in $a" >&2; return 1; }
        n=$((n + 1))
    done
    [ "$n" = "$count" ] && [ "$(find "$a" -maxdepth 1 -name 'frame_*' | wc -l)" = "$count" ] \
        || { echo "expected $count frames, found $n in $b and $(find "$a" -maxdepth 1 -name 'frame_*' | wc -l) in $a" >&2; return 1; }
}
# Whether $1 (a log) holds the text $2.
log_says() { grep -q -F -- "$2" "$1" || { echo "$1 does not say '$2':" >&2; tail -n 5 "$1" >&2; return 1; }; }
no_frames() {  # no frame and no leftover under folder $1
    local found
    found=$(find "$1" -type f \( -name 'frame_*' -o -name '*.tmp*' \) 2>/dev/null | head -n 3)
    [ -z "$found" ] || { echo "written: $found" >&2; return 1; }
}

# ---- 1. glTF: 12 frames in 4 array tasks after the layout step

echo "== glTF: one process, frames 1-12"
t0=$(date +%s.%N)
"$cubist" render "$fox" --frames 1-12 -o "$work/ref-gltf/frame_####.png" --progress none "${gltf_flags[@]}"
one_process=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$t0" "$(date +%s.%N)")
echo "one process: $one_process s"

echo "== glTF: farm/slurm/submit.sh, 4 tasks"
t0=$(date +%s.%N)
read -r layout_job frames_job < <(CUBIST=$cubist bash "$here/submit.sh" gltf "$fox" 1-12 4 "$work/shared/gltf" \
    "${gltf_flags[@]}")
[ -n "${frames_job:-}" ] || die "farm/slurm/submit.sh gltf did not submit"
wait_job "$frames_job" 600
cluster=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$t0" "$(date +%s.%N)")
echo "cluster (submit to last frame): $cluster s"
run_times() {  # each task's run time (whole seconds, as Slurm records them)
    scontrol -o show job "$1" | sed -E 's/.*JobId=([0-9]+).*RunTime=([0-9:-]+).*/\2/' | tr '\n' ' '
}
echo "run times: layout step $(run_times "$layout_job")- tasks $(run_times "$frames_job")"
check "glTF layout step COMPLETED" all_completed "$layout_job" 1
check "glTF array job: 4 tasks COMPLETED" all_completed "$frames_job" 4
check "glTF: the 12 frames equal one process's byte for byte" same_frames "$work/shared/gltf/frames" "$work/ref-gltf" 12
logs_list_frames() {
    local f n=0
    for f in "$work/shared/gltf/frames"/frame_*.png; do
        grep -h -q -F "wrote $f sha256 $(sha256sum "$f" | cut -d' ' -f1)" "$work/shared/gltf/logs"/cubist-gltf-"${frames_job}"_*.log \
            || { echo "no task log lists $f with its SHA-256" >&2; return 1; }
        n=$((n + 1))
    done
    [ "$n" = 12 ]
}
check "glTF: the task logs list every frame with its SHA-256" logs_list_frames

echo "== glTF: requeue task 2 (frames 4-6)"
inodes() { stat -c %i "$work/shared/gltf/frames"/frame_000{4,5,6}.png | tr '\n' ' '; }
before=$(inodes)
cp -p "$work/shared/gltf/frames"/frame_000{4,5,6}.png "$work/"
scontrol requeue "${frames_job}_2"
# A requeued job waits two minutes before it may start again (Slurm's default): not here.
scontrol update JobId="${frames_job}_2" StartTime=now
wait_job "${frames_job}_2" 300
requeue_rewrote() {
    local after
    after=$(inodes)
    [ "$after" != "$before" ] || { echo "frames 4-6 were not rewritten (same inodes $after)" >&2; return 1; }
    local f
    for f in 4 5 6; do
        cmp -s "$work/frame_000$f.png" "$work/shared/gltf/frames/frame_000$f.png" \
            || { echo "frame $f changed on requeue" >&2; return 1; }
    done
}
check "glTF: the requeued task COMPLETED" all_completed "${frames_job}_2" 1
check "glTF: the requeue rewrote frames 4-6 with the same bytes" requeue_rewrote

echo "== glTF: a node without the cubist binary"
node_path=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
PATH=$node_path command -v cubist >/dev/null && die "cubist is on the system PATH ($node_path): cannot simulate a node without it"
mkdir -p "$work/shared/gltf-nobin/layout"
cp "$work/shared/gltf/layout/facets.json" "$work/shared/gltf-nobin/layout/"
job=$(env -u CUBIST PATH=$node_path sbatch --parsable --array=1 --output "$work/gltf-nobin.log" \
    "$here/cubist-gltf.sbatch" "$fox" 1-12 3 "$work/shared/gltf-nobin" "${gltf_flags[@]}" | cut -d';' -f1)
wait_job "$job" 120
check "glTF without the binary: FAILED" test "$(job_states "$job")" = FAILED
check "glTF without the binary: the log names the cause" log_says "$work/gltf-nobin.log" "no cubist binary on this node"
check "glTF without the binary: no frame written" no_frames "$work/shared/gltf-nobin/frames"

# ---- 2. .blend through Blender and the add-on

echo "== Blender nodes: the add-on installed (legacy), without a binary, without the add-on"
blender_version=$(blender --version 2>/dev/null | head -n 1)
python3 "$root/scripts/build_addon.py" --binary "$cubist" --out "$work/dist" >/dev/null
python3 "$root/scripts/build_addon.py" --no-binary --out "$work/dist" >/dev/null
with_renderer=$(find "$work/dist" -name 'cubist-*-linux-*.zip' | head -n 1)
no_renderer=$(find "$work/dist" -name 'cubist-*-no-renderer.zip' | head -n 1)
[ -f "$with_renderer" ] && [ -f "$no_renderer" ] || die "scripts/build_addon.py made no zips in $work/dist"
# A node's Blender user folders; the add-on unzipped into its scripts/addons/ and enabled in
# its saved preferences, as on a farm node.
node_env() { echo "BLENDER_USER_CONFIG=$work/nodes/$1/config BLENDER_USER_SCRIPTS=$work/nodes/$1/scripts"; }
make_node() {  # make_node NAME [ZIP]
    mkdir -p "$work/nodes/$1/config" "$work/nodes/$1/scripts/addons"
    [ $# = 2 ] || return 0
    python3 -c "import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])" "$2" \
        "$work/nodes/$1/scripts/addons/cubist"
    env $(node_env "$1") PATH=$node_path blender -b --python-exit-code 1 --python-expr "
import addon_utils, bpy
assert addon_utils.enable('cubist', default_set=True, persistent=True) is not None
bpy.ops.wm.save_userpref()" >"$work/nodes/$1.log" 2>&1 || { cat "$work/nodes/$1.log"; die "cannot enable the add-on on node $1"; }
}
make_node good "$with_renderer"
make_node nobin "$no_renderer"
make_node noaddon

echo "== the shot: 12 frames of a moving cube, seen by a moving camera"
env $(node_env good) PATH=$node_path blender -b --factory-startup --python-exit-code 1 --python-expr "
import sys, bpy
import addon_utils
addon_utils.enable('cubist')
scene = bpy.context.scene
r = scene.render
r.engine = 'CUBIST'
r.resolution_x, r.resolution_y, r.resolution_percentage = 128, 96, 100
r.image_settings.file_format = 'PNG'
# Metadata that changes from run to run (dates, render time, memory) would change the files,
# and Blender pads the Frame field to the digits of the run's last frame (-e).
r.use_stamp_date = r.use_stamp_time = r.use_stamp_render_time = r.use_stamp_memory = False
r.use_stamp_frame = False
scene.view_settings.view_transform = 'Standard'

scene.frame_start, scene.frame_end = 1, 12
cube, camera = bpy.data.objects['Cube'], bpy.data.objects['Camera']
for frame, z, turn in ((1, 0.0, 0.0), (12, 1.5, 1.2)):
    cube.location.z, cube.rotation_euler.z = z, turn
    cube.keyframe_insert('location', frame=frame)
    cube.keyframe_insert('rotation_euler', frame=frame)
camera.keyframe_insert('location', frame=1)
camera.location.x += 1.5
camera.keyframe_insert('location', frame=12)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])
" -- "$work/shared/shot.blend" >"$work/shot.log" 2>&1 || { tail -n 20 "$work/shot.log"; die "cannot make the .blend"; }

echo "== .blend: one process, blender -b shot.blend -E CUBIST -a"
t0=$(date +%s.%N)
env $(node_env good) PATH=$node_path blender -b "$work/shared/shot.blend" -E CUBIST -o "$work/ref-blend/frame_####" -a \
    >"$work/ref-blend.log" 2>&1 || { tail -n 20 "$work/ref-blend.log"; die "the one-process Blender render failed"; }
blend_one=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$t0" "$(date +%s.%N)")
grep -q 'Error' "$work/ref-blend.log" && { grep 'Error' "$work/ref-blend.log"; die "the one-process Blender render reported errors"; }
echo "one process: $blend_one s"

echo "== .blend: farm/slurm/submit.sh, 4 tasks"
t0=$(date +%s.%N)
read -r blend_layout blend_job < <(env $(node_env good) PATH=$node_path bash "$here/submit.sh" blend \
    "$work/shared/shot.blend" 1-12 4 "$work/shared/blend")
[ -n "${blend_job:-}" ] || die "farm/slurm/submit.sh blend did not submit"
wait_job "$blend_job" 900
blend_cluster=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$t0" "$(date +%s.%N)")
echo "cluster (submit to last frame): $blend_cluster s"
check ".blend layout step COMPLETED" all_completed "$blend_layout" 1
check ".blend array job: 4 tasks COMPLETED" all_completed "$blend_job" 4
check ".blend: the 12 frames equal one Blender process's byte for byte" \
    same_frames "$work/shared/blend/frames" "$work/ref-blend" 12
layout_reused() {
    [ "$(find "$work/shared/blend/cubist-layout" -maxdepth 1 -name '*.facets.json' | wc -l)" = 1 ] \
        || { echo "no facet layout (or several) in $work/shared/blend/cubist-layout" >&2; return 1; }
    # A chunk without a current layout computes it first, saying "facet layout from frame N".
    ! grep -a -l "facet layout from frame" "$work/shared/blend/logs"/cubist-blend-"${blend_job}"_*.log
}
check ".blend: the layout step saved one facet layout, every task loaded it" layout_reused
check ".blend: no task left a partial folder" no_frames "$work/shared/blend/.partial"

bad_blend_task() {  # bad_blend_task NODE OUT: one array task of frames 1-3 on that node
    env $(node_env "$1") PATH=$node_path sbatch --parsable --array=1 --output "$work/$2.log" \
        "$here/cubist-blend.sbatch" "$work/shared/shot.blend" 1-12 3 "$work/shared/$2" | cut -d';' -f1
}
echo "== .blend: a node without the add-on, a node without the binary"
noaddon_job=$(bad_blend_task noaddon blend-noaddon)
nobin_job=$(bad_blend_task nobin blend-nobin)
wait_job "$noaddon_job" 300
wait_job "$nobin_job" 300
check ".blend without the add-on: FAILED" test "$(job_states "$noaddon_job")" = FAILED
check ".blend without the add-on: the log names the cause" log_says "$work/blend-noaddon.log" \
    "cubist-blend: FAILED on node $host: Cubist: this node's Blender"
check ".blend without the add-on: the log says which add-on" log_says "$work/blend-noaddon.log" \
    "has no Cubist render engine: install and enable the Cubist add-on"
check ".blend without the add-on: no frame written" no_frames "$work/shared/blend-noaddon"
check ".blend without the binary: FAILED" test "$(job_states "$nobin_job")" = FAILED
check ".blend without the binary: the log names the cause" log_says "$work/blend-nobin.log" \
    "cubist-blend: FAILED on node $host: Cubist: the add-on finds no renderer on this node: cubist binary not found"
check ".blend without the binary: no frame written" no_frames "$work/shared/blend-nobin"

echo
echo "Slurm $(sinfo --version | cut -d' ' -f2), $blender_version, $(nproc) cores, one node"
echo "glTF, 12 frames of ${gltf_flags[*]}: one process $one_process s, cluster (layout step + 4 tasks) $cluster s"
echo ".blend, 12 frames at 128x96: one Blender process $blend_one s, cluster (layout step + 4 tasks) $blend_cluster s"
[ "$failures" = 0 ] || die "$failures check(s) failed"
echo "all farm checks passed"
