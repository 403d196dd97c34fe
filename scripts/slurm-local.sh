#!/bin/sh
# scripts/slurm-local.sh start|stop|status -- a private single-node Slurm on
# this machine, to run `sweep --list-jobs` as an array job in tests
# (tests/engines.sh) without a cluster. Needs root, Debian's slurm-wlm and
# munge (scripts/deps.sh --engines); nothing is left running after `stop`.
#
# Everything lives in one folder, $RT_SLURM_DIR (default /tmp/rt-slurm):
# slurm.conf, state, spool, logs and pid files. Settings that work without
# systemd or cgroups: proctrack/linuxproc, task/none, no accounting,
# cons_tres with CR_Core, SlurmUser root, one node (this host, nproc CPUs)
# in one default partition. munged is started only if none answers, and
# stopped by `stop` only if this script started it.
#
# After `start`, use Slurm with SLURM_CONF=$RT_SLURM_DIR/slurm.conf (the
# command prints the export line). Exit status: 0 ok; 1 failure (message on
# stderr); `status` exits 0 when the node is up, 3 when Slurm is not running.
set -u
dir=${RT_SLURM_DIR:-/tmp/rt-slurm}
conf=$dir/slurm.conf
export SLURM_CONF="$conf"
say() { echo "slurm-local: $*" >&2; }

node_state() { sinfo -h -N -o %T 2>/dev/null | head -n 1; }

stop_pidfile() { # kills the daemon whose pid is in file $1 and waits for it
    [ -s "$1" ] || return 0
    pid=$(cat "$1")
    if kill -0 "$pid" 2>/dev/null; then
        kill -TERM "$pid" 2>/dev/null
        i=0
        while kill -0 "$pid" 2>/dev/null && [ $i -lt 50 ]; do sleep 0.1; i=$((i + 1)); done
        kill -0 "$pid" 2>/dev/null && kill -KILL "$pid" 2>/dev/null
    fi
    rm -f "$1"
}

start() {
    [ "$(id -u)" = 0 ] || { say "needs root (slurmd runs jobs as their users)"; return 1; }
    for p in slurmctld slurmd munged sinfo sbatch; do
        command -v $p >/dev/null 2>&1 || [ -x /usr/sbin/$p ] || { say "$p not found: install slurm-wlm and munge"; return 1; }
    done
    if [ -s "$dir/slurmctld.pid" ] && kill -0 "$(cat "$dir/slurmctld.pid")" 2>/dev/null; then
        say "already running (SLURM_CONF=$conf)"
        return 0
    fi
    mkdir -p "$dir/state" "$dir/spool" "$dir/log" || return 1
    # munge: authentication between the daemons and the commands
    if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
        mkdir -p /run/munge && chown munge:munge /run/munge && chmod 755 /run/munge
        su -s /bin/sh munge -c /usr/sbin/munged || { say "munged did not start"; return 1; }
        cp /run/munge/munged.pid "$dir/munged.pid" 2>/dev/null
        i=0
        until munge -n 2>/dev/null | unmunge >/dev/null 2>&1; do
            i=$((i + 1)); [ $i -lt 50 ] || { say "munge does not answer"; return 1; }; sleep 0.1
        done
    fi
    host=$(hostname -s)
    cpus=$(nproc)
    mem=$(awk '/MemTotal/ { m = int($2 / 1024) - 1024; print (m > 512 ? m : 512) }' /proc/meminfo)
    cat > "$conf" <<CONF
ClusterName=rtlocal
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldPort=${RT_SLURM_PORT:-6917}
SlurmdPort=$(( ${RT_SLURM_PORT:-6917} + 1 ))
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
ReturnToService=2
MaxArraySize=100001
MaxJobCount=200000
MinJobAge=60
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    /usr/sbin/slurmctld -f "$conf" || { say "slurmctld did not start (see $dir/log/slurmctld.log)"; return 1; }
    /usr/sbin/slurmd -f "$conf" || { say "slurmd did not start (see $dir/log/slurmd.log)"; stop; return 1; }
    i=0
    while :; do
        st=$(node_state)
        case "$st" in idle*|mix*|alloc*) break ;; esac
        i=$((i + 1))
        [ $i -lt 300 ] || { say "node not idle after 30 s (state '$st'; see $dir/log)"; stop; return 1; }
        sleep 0.1
    done
    say "up: node $host, $cpus CPUs"
    echo "export SLURM_CONF=$conf"
}

stop() {
    stop_pidfile "$dir/slurmd.pid"
    stop_pidfile "$dir/slurmctld.pid"
    stop_pidfile "$dir/munged.pid"
    return 0
}

status() {
    if [ -s "$dir/slurmctld.pid" ] && kill -0 "$(cat "$dir/slurmctld.pid")" 2>/dev/null; then
        echo "slurmctld running (pid $(cat "$dir/slurmctld.pid")), node: $(node_state || echo unknown)"
        return 0
    fi
    echo "not running"
    return 3
}

case "${1:-}" in
start) start ;;
stop) stop ;;
status) status ;;
*) echo "usage: $0 start|stop|status" >&2; exit 2 ;;
esac
