#!/usr/bin/env bash
# A sharded animation on a real Slurm cluster of one node (this machine):
# installs Debian's slurm-wlm and munge, starts munged, slurmctld and slurmd,
# renders a 48-frame animation as a 4-task job array (`sbatch --array=0-3`,
# each task `isoray render --shard $SLURM_ARRAY_TASK_ID/4`), renders the
# same frames in one process, and checks that every frame is byte-identical.
# Then it runs the Kubernetes Indexed Job's command (bench/scale/k8s-job.yaml)
# for each JOB_COMPLETION_INDEX the same way. Run as root; docs/SCALE.md
# records the result.
#
#   bash bench/scale/slurm.sh            (TASKS=4 FRAMES=48 by default)
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
TASKS=${TASKS:-4}
FRAMES=${FRAMES:-48}
WORK=${WORK:-/tmp/isoray-slurm}
export DEBIAN_FRONTEND=noninteractive

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi
cargo build --release -q -p isoray
ISORAY=$ROOT/target/release/isoray

# The animation: the MIDI-scale demo played from its recorded take, 48 frames.
SCENE=$ROOT/examples/realtime/midi-scale.toml
TAKE=$ROOT/examples/realtime/midi-scale.mid
ARGS=(--midi "$TAKE" --width 360 --height 167 -q)

rm -rf "$WORK"; mkdir -p "$WORK"/{array,single,k8s,state,spool,log}
chmod 777 "$WORK" "$WORK"/*

# munge: a key, and its daemon as the munge user.
if [ ! -s /etc/munge/munge.key ]; then mungekey --create --force; fi
chown munge:munge /etc/munge/munge.key; chmod 400 /etc/munge/munge.key
mkdir -p /run/munge /var/log/munge /var/lib/munge
chown munge:munge /run/munge /var/log/munge /var/lib/munge
pgrep -x munged >/dev/null || runuser -u munge -- /usr/sbin/munged
munge -n | unmunge >/dev/null

# Slurm: one node with this machine's cores, processes tracked without cgroups.
HOST=$(hostname -s)
MEM=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
cat > /etc/slurm/slurm.conf <<CONF
ClusterName=isoray
SlurmctldHost=$HOST
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$WORK/spool
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/log/slurmctld.log
SlurmdLogFile=$WORK/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
NodeName=$HOST CPUs=$(nproc) RealMemory=$MEM State=UNKNOWN
PartitionName=batch Nodes=ALL Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
CONF
stop() {
  scontrol shutdown >/dev/null 2>&1 || true
  sleep 1
  pkill -x slurmd 2>/dev/null || true
  pkill -x slurmctld 2>/dev/null || true
}
trap stop EXIT
stop
slurmctld -i
slurmd
for _ in $(seq 60); do
  sinfo -h -o %T 2>/dev/null | grep -qE 'idle|mixed' && break
  sleep 1
done
sinfo

# The job array: each task renders its shard of frames 0..FRAMES-1.
cat > "$WORK/job.sh" <<JOB
#!/bin/bash
#SBATCH --job-name=isoray-frames
#SBATCH --output=$WORK/log/task-%a.out
#SBATCH --cpus-per-task=1
set -euo pipefail
"$ISORAY" render "$SCENE" ${ARGS[*]} --frames 0..$((FRAMES - 1)) \\
    --shard "\$SLURM_ARRAY_TASK_ID/$TASKS" --threads 1 -o "$WORK/array/frame_%04d.png"
JOB
start=$(date +%s.%N)
sbatch --wait --array=0-$((TASKS - 1)) "$WORK/job.sh"
array_s=$(printf %.2f "$(echo "$(date +%s.%N) - $start" | bc)")
sacct >/dev/null 2>&1 || true

start=$(date +%s.%N)
"$ISORAY" render "$SCENE" "${ARGS[@]}" --frames 0..$((FRAMES - 1)) --threads 1 -o "$WORK/single/frame_%04d.png"
single_s=$(printf %.2f "$(echo "$(date +%s.%N) - $start" | bc)")

# The Kubernetes Indexed Job's command, once per index, as its pods would run it.
CMD=$(awk '/BEGIN isoray command/ {on = 1; next} /END isoray command/ {on = 0} on' bench/scale/k8s-job.yaml | sed 's/^ *//')
for i in $(seq 0 $((TASKS - 1))); do
  JOB_COMPLETION_INDEX=$i ISORAY=$ISORAY SCENE=$SCENE TAKE=$TAKE OUT=$WORK/k8s SHARDS=$TASKS \
    LAST=$((FRAMES - 1)) bash -c "$CMD" &
done
wait

bad=0
for n in $(seq 0 $((FRAMES - 1))); do
  f=$(printf 'frame_%04d.png' "$n")
  for d in array k8s; do
    if ! cmp -s "$WORK/$d/$f" "$WORK/single/$f"; then
      echo "frame $n differs ($d)"; bad=$((bad + 1))
    fi
  done
done
count=$(ls "$WORK/array" | wc -l)
echo "slurm $(sinfo -V | awk '{print $2}'), $(nproc) cores: $TASKS-task array wrote $count frames in ${array_s} s; one process ${single_s} s; k8s index commands wrote $(ls "$WORK/k8s" | wc -l) frames"
if [ "$bad" -eq 0 ] && [ "$count" -eq "$FRAMES" ]; then
  echo "all $FRAMES frames byte-identical to the single-process render (Slurm array and Kubernetes indices)"
else
  echo "MISMATCH: $bad frame(s) differ"; exit 1
fi
