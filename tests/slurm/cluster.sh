#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for ppkat's tests (tests/cli/slurm.rs).
#
#   cluster.sh up DIR     installs Debian's slurm-wlm and munge when they are missing (as
#                         root), starts munged, slurmctld and slurmd with a generated
#                         slurm.conf, their key, state, spool and logs all in DIR, waits
#                         until the node is idle and prints SLURM_CONF=DIR/slurm.conf
#   cluster.sh down DIR   stops the daemons that `up` started, by the PIDs they wrote in DIR
#
# Nothing outside DIR is changed but the packages; other Slurm or munge daemons on the
# machine are left alone (the cluster has its own ports, socket and key).
set -euo pipefail

usage() { echo "usage: $0 up|down DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
dir=$(realpath -m "$2")

down() {
    for pidfile in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munge/munged.pid"; do
        [ -s "$pidfile" ] || continue
        pid=$(cat "$pidfile")
        kill "$pid" 2>/dev/null || true
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null || true
        rm -f "$pidfile"
    done
}

install() {
    command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
        && command -v munged >/dev/null && command -v sbatch >/dev/null && return 0
    if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null; then
        echo "Slurm is not installed and cannot be installed here (not root, or no apt-get):" \
             "install Debian's slurm-wlm and munge packages (apt-get install slurm-wlm munge)," \
             "then run the tests as root" >&2
        exit 3
    fi
    export DEBIAN_FRONTEND=noninteractive
    if ! apt-get install -y -q slurm-wlm munge >"$dir/apt.log" 2>&1; then
        apt-get update -q >>"$dir/apt.log" 2>&1 || true
        apt-get install -y -q slurm-wlm munge >>"$dir/apt.log" 2>&1 || {
            echo "apt-get could not install slurm-wlm and munge (see $dir/apt.log):" \
                 "install them by hand, then run the tests again" >&2
            exit 3
        }
    fi
}

up() {
    mkdir -p "$dir"
    install
    if [ "$(id -u)" != 0 ]; then
        echo "the test cluster's daemons run as root (SlurmUser=root, munged's key):" \
             "run the tests as root" >&2
        exit 3
    fi
    down
    mkdir -p "$dir/munge" "$dir/state" "$dir/spool" "$dir/log"
    chmod 700 "$dir/munge"
    [ -s "$dir/munge/munge.key" ] || head -c 1024 /dev/urandom >"$dir/munge/munge.key"
    chmod 400 "$dir/munge/munge.key"
    local host cpus mem port
    host=$(hostname -s)
    cpus=$(nproc)
    mem=$(( $(awk '/^MemTotal:/ {print $2}' /proc/meminfo) / 1024 * 9 / 10 ))
    port=$(( 20000 + ($$ % 2000) * 2 ))
    cat >"$dir/slurm.conf" <<CONF
# The one-node test cluster of ppkat's tests (tests/slurm/cluster.sh).
ClusterName=ppkat-test
SlurmctldHost=$host
SlurmUser=root
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
AuthInfo=socket=$dir/munge/socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
JobAcctGatherType=jobacct_gather/none
SchedulerType=sched/backfill
SchedulerParameters=sched_interval=2,bf_interval=1
MpiDefault=none
ReturnToService=2
MinJobAge=300
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF="$dir/slurm.conf"
    munged --key-file="$dir/munge/munge.key" --socket="$dir/munge/socket" \
        --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" \
        --seed-file="$dir/munge/seed" --force
    slurmctld
    slurmd
    for _ in $(seq 150); do
        if [ "$(sinfo -h -o %t 2>/dev/null)" = idle ]; then
            echo "SLURM_CONF=$SLURM_CONF"
            return 0
        fi
        sleep 0.2
    done
    echo "the test cluster's node did not come up in 30 s: see $dir/log/" >&2
    down
    exit 1
}

case $1 in
    up) up ;;
    down) down ;;
    *) usage ;;
esac
