#!/usr/bin/env bash
# Stand up a one-node SLURM on this machine, run a small ball-mill study through
# profiles/slurm exactly as shipped (only partition and account set on the command line, as a
# site would), run the same study locally, and compare the aggregates variable by variable.
#
#   tools/slurm_localhost.sh [--install] [WORKDIR]
#
# Needs root (slurmctld, slurmd and munged run as root here) and Debian's slurm-wlm and munge
# (`--install` apt-installs them). Exit codes: 0 aggregates identical, 1 they differ or a stage
# failed, 77 SLURM cannot start here (tests/test_slurm_localhost.py then skips). Takes ~3-5 min
# on 2 cores, most of it compiling the ball-mill kernels once per job.
set -euo pipefail

REPO=$(cd "$(dirname "$0")/.." && pwd)
INSTALL=0
if [[ "${1:-}" == "--install" ]]; then
    INSTALL=1
    shift
fi
WORK=${1:-$(mktemp -d /tmp/millsim-slurm.XXXXXX)}
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)
export PATH="$REPO/.venv/bin:$PATH"

cannot_start() {
    echo "slurm_localhost: SLURM cannot start here: $*" >&2
    exit 77
}

[[ $(id -u) -eq 0 ]] || cannot_start "needs root to run slurmctld, slurmd and munged"
if [[ $INSTALL -eq 1 ]] && ! command -v slurmctld >/dev/null; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >"$WORK/apt.log" 2>&1 ||
        cannot_start "apt-get install slurm-wlm munge failed (see $WORK/apt.log)"
fi
for tool in slurmctld slurmd munged sbatch squeue sinfo; do
    command -v "$tool" >/dev/null || cannot_start "$tool not found (Debian: slurm-wlm munge; or --install)"
done
python -c "import snakemake_executor_plugin_slurm" 2>/dev/null ||
    cannot_start "snakemake-executor-plugin-slurm is not installed in $REPO/.venv"

# --- munge: the authentication SLURM's daemons and clients share -------------------------------
MUNGE="$WORK/munge"
mkdir -p "$MUNGE"
chmod 700 "$MUNGE"
if [[ ! -f /etc/munge/munge.key ]]; then
    mkdir -p /etc/munge
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
    chmod 400 /etc/munge/munge.key
fi
mkdir -p /run/munge
munged --force --key-file=/etc/munge/munge.key --socket="$MUNGE/munge.socket" \
    --pid-file="$MUNGE/munged.pid" --log-file="$MUNGE/munged.log" --seed-file="$MUNGE/seed" ||
    cannot_start "munged did not start ($MUNGE/munged.log)"

# --- slurm.conf: one node with this machine's cores and memory, no accounting database ---------
HOST=$(hostname -s)
CPUS=$(nproc)
MEM_MB=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
SPOOL="$WORK/spool"
mkdir -p "$SPOOL/ctld" "$SPOOL/d"
export SLURM_CONF="$WORK/slurm.conf"
cat >"$SLURM_CONF" <<EOF
ClusterName=millsim-local
SlurmctldHost=$HOST
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$MUNGE/munge.socket
CredType=cred/munge
SlurmctldPort=16817
SlurmdPort=16818
StateSaveLocation=$SPOOL/ctld
SlurmdSpoolDir=$SPOOL/d
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/slurmctld.log
SlurmdLogFile=$WORK/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
# no slurmdbd: the cluster the profile's slurm-status-command comment is about
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
ReturnToService=2
MpiDefault=none
NodeName=$HOST CPUs=$CPUS RealMemory=$MEM_MB State=UNKNOWN
PartitionName=compute Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF

# The jobs' inner `srun` reads the default /etc/slurm/slurm.conf: the jobstep executor plugin
# (0.6.1) drops SLURM_CONF from the job's environment. A real cluster's file is never overwritten.
ETC_CONF=/etc/slurm/slurm.conf
MARK="# written by millsim tools/slurm_localhost.sh"
if [[ -f $ETC_CONF ]] && ! grep -qF "$MARK" "$ETC_CONF"; then
    cannot_start "$ETC_CONF exists and is not this script's: not touching a real cluster's configuration"
fi
mkdir -p /etc/slurm
{ echo "$MARK"; cat "$SLURM_CONF"; } >"$ETC_CONF"

cleanup() {
    grep -qF "$MARK" "$ETC_CONF" 2>/dev/null && rm -f "$ETC_CONF"
    for pidfile in "$WORK/slurmd.pid" "$WORK/slurmctld.pid" "$MUNGE/munged.pid"; do
        [[ -f $pidfile ]] && kill "$(cat "$pidfile")" 2>/dev/null || true
    done
}
trap cleanup EXIT

slurmctld -i || cannot_start "slurmctld did not start ($WORK/slurmctld.log)"
slurmd || cannot_start "slurmd did not start ($WORK/slurmd.log)"
for _ in $(seq 60); do
    state=$(sinfo -h -n "$HOST" -o %t 2>/dev/null || true)
    [[ $state == idle* ]] && break
    sleep 1
done
[[ ${state:-} == idle* ]] || cannot_start "node $HOST is '${state:-unknown}', not idle, after 60 s ($WORK/slurmd.log)"
echo "slurm_localhost: one-node SLURM up ($HOST, $CPUS CPUs, $MEM_MB MB), $WORK"

# --- the same small study, through SLURM and locally --------------------------------------------
# A ball-mill sweep of three speeds, short runs: the config overrides config/config.yaml's
# ballmill block (lists replace lists); only the aggregate is asked for.
cat >"$WORK/study.yaml" <<EOF
ballmill:
  parameters:
    n_over_nc: [0.5, 1.0, 1.5]
    duration: 0.3
    transient: 0.1
EOF
TARGET=results/aggregate/ballmill.nc
for where in slurm local; do
    mkdir -p "$WORK/$where"
    ln -sfn "$REPO/config" "$WORK/$where/config"
    ln -sfn "$REPO/workflow" "$WORK/$where/workflow"
done
(
    cd "$WORK/slurm"
    # the shipped profile; only the site settings (partition, account) are given here
    snakemake -s "$REPO/Snakefile" --workflow-profile "$REPO/profiles/slurm" \
        --configfile "$WORK/study.yaml" \
        -- "$TARGET"
) >"$WORK/slurm.log" 2>&1 || {
    echo "slurm_localhost: the study through SLURM failed; last lines of $WORK/slurm.log:" >&2
    tail -20 "$WORK/slurm.log" >&2
    exit 1
}
echo "slurm_localhost: through SLURM: $(grep -c 'has been submitted with SLURM jobid' "$WORK/slurm.log" || true) SLURM jobs, all completed"
(
    cd "$WORK/local"
    snakemake -s "$REPO/Snakefile" --cores "$CPUS" --configfile "$WORK/study.yaml" -- "$TARGET"
) >"$WORK/local.log" 2>&1 || {
    echo "slurm_localhost: the local study failed; see $WORK/local.log" >&2
    exit 1
}
python "$REPO/tools/compare_cases.py" "$WORK/local/results/aggregate" "$WORK/slurm/results/aggregate"
python "$REPO/tools/compare_cases.py" --quiet "$WORK/local/results/cases" "$WORK/slurm/results/cases"
