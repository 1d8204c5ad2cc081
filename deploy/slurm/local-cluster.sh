#!/bin/bash
# A single-node Slurm cluster on this machine, to try the job files here
# (and for CI). Needs root and Debian's packages (installed if missing).
#
#   bash deploy/slurm/local-cluster.sh start   # up in seconds; `sinfo` shows the node idle
#   bash deploy/slurm/local-cluster.sh stop
#
# One partition (`local`) with one node: this host, all its CPUs.
set -euo pipefail

conf=/etc/slurm/slurm.conf
node="$(hostname)"
cpus="$(nproc)"
# The first line of the slurm.conf this script writes: a configuration
# without it is someone else's and is left alone.
marker="# impactmc local cluster (deploy/slurm/local-cluster.sh)"

ours() {
    [ ! -e "$conf" ] || [ "$(head -n 1 "$conf")" = "$marker" ]
}

start() {
    if ! ours; then
        echo "$conf exists and was not written by this script; not touching it" >&2
        return 1
    fi
    if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
    fi
    # Authentication: a munge key, and munged as the munge user.
    mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
    if [ ! -s /etc/munge/munge.key ]; then
        dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
    fi
    chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
    chmod 0400 /etc/munge/munge.key
    pgrep -x munged >/dev/null || runuser -u munge -- munged

    mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
    if ! pgrep -x slurmctld >/dev/null; then
        # A fresh cluster: no jobs left from an earlier start.
        rm -rf /var/spool/slurmctld/* /var/spool/slurmd/*
    fi
    cat >"$conf" <<EOF
$marker
ClusterName=impactmc-local
SlurmctldHost=$node
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
ReturnToService=2
MinJobAge=300
NodeName=$node CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
    pgrep -x slurmctld >/dev/null || slurmctld
    pgrep -x slurmd >/dev/null || slurmd
    # Up within a minute, or a failure (each sinfo bounded: it waits for its
    # message timeout while slurmctld is not answering).
    local deadline=$((SECONDS + 60))
    while [ "$SECONDS" -lt "$deadline" ]; do
        if timeout 5 sinfo -h -o '%T' 2>/dev/null | grep -qx idle; then
            sinfo
            return 0
        fi
        sleep 0.5
    done
    echo "slurm did not come up; see /var/log/slurm/" >&2
    sinfo >&2 || true
    return 1
}

stop() {
    ours || return 0
    local d
    for d in slurmd slurmctld munged; do
        pkill -x "$d" || true
    done
    # Gone before a new start binds the same ports.
    for _ in $(seq 1 40); do
        if ! pgrep -x slurmd >/dev/null && ! pgrep -x slurmctld >/dev/null \
            && ! pgrep -x munged >/dev/null; then
            return 0
        fi
        sleep 0.25
    done
    echo "slurm daemons still running after 10 s" >&2
    return 1
}

case "${1:-}" in
    start) start ;;
    stop) stop ;;
    *)
        echo "usage: $0 start|stop" >&2
        exit 2
        ;;
esac
