#!/usr/bin/env bash
# Copied unchanged from the project's ../shared/tools/slurm-local.sh (CI's clean clone may lack ../shared).
# A real single-node SLURM cluster on this machine (Debian bookworm, no systemd as
# PID 1, no usable cgroups), e.g. to test dask_jobqueue.SLURMCluster against it.
# Installs munge + slurmctld/slurmd/slurm-client, writes /etc/slurm/slurm.conf for
# this host only (partition "debug"), starts munged, slurmctld and slurmd as plain
# background daemons and waits until the node is idle. Idempotent; run as root.
#   slurm-local.sh          set up / start; last line: "slurm ready: <sinfo summary>"
#   slurm-local.sh --stop   cancel queued jobs, stop only the daemons this script started
# Logs: /var/log/slurm/slurm{ctld,d}.log, /var/log/munge/munged.log
set -euo pipefail

RUN=/run/slurm-local                # PID files of the daemons *this script* started
CONF=/etc/slurm/slurm.conf
HOST=$(hostname -s)
LOGS="/var/log/slurm/slurmctld.log /var/log/slurm/slurmd.log /var/log/munge/munged.log"

die() { echo "slurm-local: ERROR: $*" >&2; tail -n 5 $LOGS 2>/dev/null >&2; exit 1; }
# running NAME PIDFILE: the PID in PIDFILE is alive and really is daemon NAME.
running() { [ -s "$2" ] && tr '\0' ' ' 2>/dev/null <"/proc/$(cat "$2")/cmdline" | grep -q "$1"; }
ctld_up() { scontrol ping 2>/dev/null | grep -q 'is UP'; }
munge_ok() { munge -n 2>/dev/null | unmunge >/dev/null 2>&1; }

declare -A OWNPID=([munged]=/run/munge/munged.pid [slurmctld]=/run/slurmctld.pid [slurmd]=/run/slurmd.pid)

# record NAME: wait for the daemon's own PID file, then keep a copy as "started by us".
record() {
    for _ in $(seq 50); do running "$1" "${OWNPID[$1]}" && break; sleep 0.2; done
    running "$1" "${OWNPID[$1]}" || die "$1 did not start"
    cp "${OWNPID[$1]}" "$RUN/$1.pid"
}

stop() {
    if [ -f "$RUN/slurmctld.pid" ] && ctld_up; then   # no job steps may outlive slurmd
        squeue -h -o %A | xargs -r scancel
        for _ in $(seq 30); do [ -z "$(squeue -h -o %A)" ] && break; sleep 1; done
    fi
    for d in slurmd slurmctld munged; do
        f=$RUN/$d.pid
        [ -f "$f" ] || continue
        pid=$(cat "$f")
        if running "$d" "$f"; then        # only the PID we recorded, if it still is $d
            kill "$pid"
            for _ in $(seq 40); do kill -0 "$pid" 2>/dev/null || break; sleep 0.25; done
            if kill -0 "$pid" 2>/dev/null; then echo "slurm-local: $d ($pid) still running" >&2
            else echo "slurm-local: stopped $d ($pid)"; fi
        fi
        # slurmctld (as user slurm) cannot remove its own PID file in /run: do it here.
        [ "$(cat "${OWNPID[$d]}" 2>/dev/null)" = "$pid" ] && rm -f "${OWNPID[$d]}"
        rm -f "$f"
    done
}

[ "$(id -u)" = 0 ] || die "must run as root"
case "${1:-}" in
    --stop) stop; exit 0 ;;
    "") ;;
    *) echo "usage: $0 [--stop]" >&2; exit 2 ;;
esac

# 1. Packages (policy-rc.d, where present, keeps postinst from starting services).
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
   || ! command -v sinfo >/dev/null || ! command -v munged >/dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        slurmctld slurmd slurm-client munge >/dev/null || die "apt-get install failed"
fi

# 2. Configuration: one node, no cgroups/systemd (linuxproc + task/none), no accounting.
cpus=$(nproc)
mem=$(free -m | awk '/^Mem:/ {print int($2 * 0.95)}')   # a bit under the total
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm "$RUN"
chown slurm:slurm /var/spool/slurmctld /var/log/slurm
conf="# Written by slurm-local.sh: single-node test cluster.
ClusterName=local
SlurmctldHost=$HOST(127.0.0.1)
SlurmUser=slurm
AuthType=auth/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
MailProg=/bin/true
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
DefMemPerCPU=1024
# Trust the CPU/memory given here over detected topology; node returns to service by itself.
SlurmdParameters=config_overrides
ReturnToService=2
NodeName=$HOST NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$HOST Default=YES MaxTime=INFINITE State=UP"
if [ "$(cat "$CONF" 2>/dev/null)" != "$conf" ]; then
    printf '%s\n' "$conf" > "$CONF"
    # Node definitions need a restart; this only restarts daemons this script started.
    if ctld_up; then echo "slurm-local: $CONF changed, restarting"; stop; fi
fi

# 3. munge: key if missing, then munged (as user munge) unless a working one runs.
if [ ! -s /etc/munge/munge.key ]; then
    mkdir -p /etc/munge
    mungekey --create --keyfile=/etc/munge/munge.key
    chown -R munge:munge /etc/munge && chmod 700 /etc/munge && chmod 400 /etc/munge/munge.key
fi
if ! munge_ok; then
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge
    chmod 755 /run/munge; chmod 700 /var/log/munge
    runuser -u munge -- /usr/sbin/munged || die "munged failed to start"
    record munged
    munge_ok || die "munge credential round-trip failed"
fi

# 4. slurmctld, then slurmd (both daemonize and log to /var/log/slurm).
if ! ctld_up; then
    running slurmctld /run/slurmctld.pid && die "slurmctld running but not answering 'scontrol ping'"
    slurmctld || die "slurmctld failed to start"
    record slurmctld
    for _ in $(seq 30); do ctld_up && break; sleep 1; done
    ctld_up || die "slurmctld not answering 'scontrol ping'"
fi
if ! running slurmd /run/slurmd.pid; then
    slurmd || die "slurmd failed to start"
    record slurmd
fi

# 5. Wait for the node to be usable; resume it if it registered drained/down.
state=
for _ in $(seq 60); do
    state=$(sinfo -h -N -n "$HOST" -o %T 2>/dev/null | head -n 1)
    case "$state" in
        idle|mixed|allocated|completing) break ;;
        drain*|down|fail*) scontrol update nodename="$HOST" state=resume 2>/dev/null || true ;;
    esac
    sleep 1
done
case "$state" in idle|mixed|allocated|completing) ;; *) die "node $HOST not idle after 60 s (state: ${state:-none})" ;; esac
echo "slurm ready: $(sinfo -h -o 'partition=%P avail=%a nodes=%D(%T) %N cpus=%c mem=%mMB timelimit=%l')"
