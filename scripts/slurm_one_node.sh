#!/usr/bin/env bash
# A one-node Slurm cluster on localhost, for testing `rtsim sweep --emit-slurm` for real.
#
#   scripts/slurm_one_node.sh start DIR   # munged + slurmctld + slurmd, state under DIR
#   scripts/slurm_one_node.sh stop DIR    # scontrol shutdown, stop munged
#
# Needs root and Debian's slurm-wlm and munge (`apt-get install slurm-wlm munge`). No systemd:
# the daemons are started by hand with their sockets, state, spool and logs under DIR, and every
# Slurm command must see SLURM_CONF=DIR/slurm.conf (printed by `start`). Exit code 3 means
# "cannot run here" (not root, packages missing), so callers can skip.
set -euo pipefail

cmd=${1:-}
dir=${2:-}
[ -n "$cmd" ] && [ -n "$dir" ] || { echo "usage: $0 start|stop DIR" >&2; exit 2; }

if [ "$cmd" = stop ]; then
    export SLURM_CONF="$dir/slurm.conf"
    scontrol shutdown >/dev/null 2>&1 || true
    for f in slurmd slurmctld munged; do
        [ -f "$dir/$f.pid" ] && kill "$(cat "$dir/$f.pid")" 2>/dev/null || true
    done
    exit 0
fi
[ "$cmd" = start ] || { echo "usage: $0 start|stop DIR" >&2; exit 2; }

[ "$(id -u)" = 0 ] || { echo "not root: cannot start Slurm daemons" >&2; exit 3; }
for b in munged slurmctld slurmd sbatch squeue scontrol sinfo; do
    command -v "$b" >/dev/null || { echo "$b not installed (apt-get install slurm-wlm munge)" >&2; exit 3; }
done

mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
chmod 700 "$dir/munge"
# A fresh key for this cluster only.
head -c 1024 /dev/urandom > "$dir/munge/munge.key"
chmod 400 "$dir/munge/munge.key"
munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
    --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munge/seed"

host=$(hostname -s)
cpus=$(nproc)
# Ports picked from the PID so parallel runs on one machine do not collide.
base=$(( 20000 + ($$ % 20000) ))
cat > "$dir/slurm.conf" <<EOF
ClusterName=rtsim-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$base
SlurmdPort=$(( base + 1 ))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=main Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$dir/slurm.conf"
slurmctld
slurmd
# Wait until the node takes jobs.
for _ in $(seq 1 60); do
    if sinfo -h -o '%t' 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then
        echo "SLURM_CONF=$dir/slurm.conf"
        exit 0
    fi
    sleep 1
done
echo "the Slurm node did not come up; see $dir/slurmctld.log and $dir/slurmd.log" >&2
exit 1
