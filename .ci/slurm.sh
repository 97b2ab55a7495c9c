#!/usr/bin/env bash
# The Slurm recipe of docs/CAMPAIGNS.md on a one-node cluster (slurmctld + slurmd on this
# machine, Debian 12's slurm-wlm 22.05 and munge): the job array of campaigns/sweep.sbatch, the
# merge job after it, and the merged results.csv and campaign.json compared byte for byte with
# one local sweep. The daemons are stopped on exit. 13 s with host-sim built in release (array +
# merge 9 s); otherwise a release build of host-sim comes first (minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
fi
cargo build --release -p host-sim --bin host-sim
export PATH="$root/target/release:$PATH"

work=$(mktemp -d /tmp/slurm-ci.XXXXXX)
state=$work/state
mkdir -p "$state/ctld" "$state/d" "$work/munge"
chmod 755 "$work"

export SLURM_CONF=$work/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=ci
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
SlurmctldPort=6817
SlurmdPort=6818
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
ReturnToService=2
MpiDefault=none
NodeName=localhost CPUs=2 State=UNKNOWN
PartitionName=ci Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF

# munge: this run's own key and socket, so an installed munged is left alone.
key=$work/munge/munge.key
dd if=/dev/urandom of="$key" bs=1 count=1024 status=none
chmod 400 "$key"
socket=$work/munge/munge.socket
munged --force --key-file="$key" --socket="$socket" \
  --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" \
  --seed-file="$work/munge/munged.seed"
export MUNGE_SOCKET=$socket
cat >>"$SLURM_CONF" <<CONF
AuthInfo=socket=$socket
CONF

stop() {
  scontrol shutdown >/dev/null 2>&1 || true
  sleep 1
  for p in "$state/slurmd.pid" "$state/slurmctld.pid" "$work/munge/munged.pid"; do
    [ -f "$p" ] && kill "$(cat "$p")" 2>/dev/null || true
  done
  cd /
  rm -rf "$work"
}
trap stop EXIT

slurmctld
slurmd -N localhost
for _ in $(seq 60); do
  [ "$(sinfo -h -o %t 2>/dev/null)" = idle ] && break
  sleep 1
done
sinfo

started=$(date +%s)
out=$work/map
cd "$work"
cp -r "$root/campaigns" "$root/scenarios" .
# The documented submission, with what a user of a 2-CPU node changes: 4 shards of 1 CPU.
jobid=$(sbatch --parsable --array=1-4 --cpus-per-task=1 --export=ALL,SHARDS=4,OUT="$out" \
  campaigns/sweep.sbatch)
merge=$(sbatch --parsable --dependency=afterok:"$jobid" --output="$work/merge.out" \
  --wrap "host-sim merge $out/shard-* --out $out")
while [ -n "$(squeue -h -j "$jobid,$merge" 2>/dev/null)" ]; do
  sleep 1
  if [ $(($(date +%s) - started)) -gt 300 ]; then
    echo "slurm: jobs still queued after 300 s" >&2
    squeue
    exit 1
  fi
done
state_of() { scontrol show job "$1" | grep -o 'JobState=[A-Z_]*' | sort -u | tr '\n' ' '; }
echo "array: $(state_of "$jobid"); merge: $(state_of "$merge")"
[ "$(state_of "$merge")" = "JobState=COMPLETED " ] || {
  cat "$work"/slurm-*.out "$work/merge.out" "$work/slurmctld.log" "$work/slurmd.log" >&2 || true
  exit 1
}
echo "slurm: array + merge took $(($(date +%s) - started)) s"

host-sim sweep campaigns/example1-ts-h.toml --out "$work/local" --quiet
for f in results.csv campaign.json; do
  cmp "$out/$f" "$work/local/$f"
done
echo "slurm: merged results.csv and campaign.json equal the local sweep's byte for byte"
