#!/usr/bin/env bash
# A single-node Slurm cluster on loopback for the cluster tests (make test-cluster), as
# recorded in ../shared/slurm-local.md: munged, slurmctld and slurmd started as root on
# 127.0.0.1 only, one node with this machine's CPUs and memory, proctrack/linuxproc,
# task/none, no cgroups, state and logs in a temporary directory. Installs nothing
# (Debian: apt-get install slurm-wlm munge).
#
#   scripts/slurm-local.sh start   # prints `export SLURM_CONF=...`, also written to $ENV_FILE
#   scripts/slurm-local.sh stop    # stops exactly the daemons `start` started (pid files)
#
# ENV_FILE is $SLURM_LOCAL_ENV, default /tmp/stokes-slurm-local.env: it holds SLURM_CONF,
# the state directory and which daemons this script started.
set -euo pipefail
ENV_FILE=${SLURM_LOCAL_ENV:-/tmp/stokes-slurm-local.env}

die() { echo "slurm-local: $*" >&2; exit 1; }

alive() { [ -n "${1:-}" ] && kill -0 "$1" 2>/dev/null; }

# Stops the process whose pid is in file $1 and waits up to 15 s for it to exit.
stop_pidfile() {
    local file=$1 what=$2 pid
    [ -f "$file" ] || return 0
    pid=$(cat "$file")
    if alive "$pid"; then
        kill "$pid"
        for _ in $(seq 150); do alive "$pid" || break; sleep 0.1; done
        if alive "$pid"; then
            echo "slurm-local: $what (pid $pid) did not exit after SIGTERM; sending SIGKILL" >&2
            kill -9 "$pid" 2>/dev/null || true
        fi
        echo "slurm-local: stopped $what (pid $pid)" >&2
    fi
}

start() {
    [ "$(id -u)" -eq 0 ] || die "start needs root (the daemons run as root)"
    for tool in munged munge unmunge slurmctld slurmd sinfo; do
        command -v "$tool" >/dev/null || die "$tool not found: install slurm-wlm and munge (apt-get install -y slurm-wlm munge)"
    done
    if [ -f "$ENV_FILE" ]; then
        die "$ENV_FILE exists: a local cluster is already running (run: $0 stop)"
    fi
    local H R cpus mem started_munged=0
    H=$(hostname -s)
    R=$(mktemp -d /tmp/stokes-slurm.XXXXXX)
    mkdir -p "$R/state" "$R/spool" "$R/log"

    # munge: reuse a running munged, else start one (and stop it again on `stop`).
    if [ ! -f /etc/munge/munge.key ]; then
        mungekey --create --keyfile=/etc/munge/munge.key
        chown munge:munge /etc/munge/munge.key
        chmod 0400 /etc/munge/munge.key
    fi
    if ! alive "$(cat /run/munge/munged.pid 2>/dev/null)"; then
        install -d -o munge -g munge -m 0755 /run/munge
        runuser -u munge -- /usr/sbin/munged
        started_munged=1
    fi
    munge -n | unmunge >/dev/null || die "munge does not work (munge -n | unmunge failed)"

    cpus=$(nproc)
    # 90 % of the memory, in MB: slurmd drains a node that has less than RealMemory.
    mem=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)
    cat > "$R/slurm.conf" <<CONF
ClusterName=stokes-local
SlurmctldHost=$H(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
AuthInfo=cred_expire=10
MailProg=/bin/true
StateSaveLocation=$R/state
SlurmdSpoolDir=$R/spool
SlurmctldPidFile=$R/slurmctld.pid
SlurmdPidFile=$R/slurmd.pid
SlurmctldLogFile=$R/log/slurmctld.log
SlurmdLogFile=$R/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
NodeName=$H NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$H Default=YES MaxTime=INFINITE State=UP
CommunicationParameters=NoInAddrAny,NoCtldInAddrAny
CONF
    {
        echo "export SLURM_CONF=$R/slurm.conf"
        echo "SLURM_LOCAL_DIR=$R"
        echo "SLURM_LOCAL_STARTED_MUNGED=$started_munged"
    } > "$ENV_FILE"
    export SLURM_CONF=$R/slurm.conf
    slurmctld -f "$SLURM_CONF"
    slurmd -f "$SLURM_CONF"
    local state=""
    for _ in $(seq 300); do
        state=$(sinfo -h -n "$H" -o %T 2>/dev/null || true)
        [ "$state" = idle ] && break
        sleep 0.1
    done
    if [ "$state" != idle ]; then
        echo "slurm-local: node $H is '${state:-not answering}' after 30 s, not idle; logs in $R/log" >&2
        tail -n 20 "$R/log/slurmctld.log" "$R/log/slurmd.log" >&2 || true
        stop
        exit 1
    fi
    echo "slurm-local: node $H idle ($cpus CPUs, $mem MB); state and logs in $R" >&2
    echo "export SLURM_CONF=$R/slurm.conf"
}

stop() {
    [ -f "$ENV_FILE" ] || { echo "slurm-local: not running ($ENV_FILE absent)" >&2; return 0; }
    local SLURM_LOCAL_DIR="" SLURM_LOCAL_STARTED_MUNGED=0
    # shellcheck disable=SC1090
    . "$ENV_FILE"
    [ -n "$SLURM_LOCAL_DIR" ] || die "$ENV_FILE names no state directory"
    stop_pidfile "$SLURM_LOCAL_DIR/slurmd.pid" slurmd
    stop_pidfile "$SLURM_LOCAL_DIR/slurmctld.pid" slurmctld
    if [ "$SLURM_LOCAL_STARTED_MUNGED" = 1 ]; then
        stop_pidfile /run/munge/munged.pid munged
    fi
    case $SLURM_LOCAL_DIR in
        /tmp/stokes-slurm.*) rm -rf -- "$SLURM_LOCAL_DIR" ;;
    esac
    rm -f -- "$ENV_FILE"
}

case ${1:-} in
    start) start ;;
    stop) stop ;;
    *) echo "usage: $0 start|stop" >&2; exit 2 ;;
esac
