#!/usr/bin/env bash
# Single-node Slurm check of `bendscope sweep --emit slurm` on this machine: installs
# slurm-wlm and munge when missing (Debian), starts munged, slurmctld and slurmd on
# localhost with a minimal slurm.conf in a temporary folder, submits a 4-point job array
# written by --emit slurm (coarse mesh), waits for it, collects it with `sweep collect`,
# checks designs.csv, and stops the daemons (also on failure).
# Usage: scripts/slurm-check.sh   (BENDSCOPE=/path/to/bendscope to skip the build)
# Needs root (daemons, apt-get). Exit 0 when the 4 points came back ok.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

if [ -z "${BENDSCOPE:-}" ]; then
  # The test profile (opt-level 2) keeps the FEM fast without a release build.
  cargo build --locked --profile test --bin bendscope
  BENDSCOPE="${CARGO_TARGET_DIR:-$root/target}/debug/bendscope"
fi
bin=$(readlink -f "$BENDSCOPE")

need=()
for p in slurm-wlm munge; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  echo "slurm-check: installing ${need[*]}" >&2
  apt-get update -q >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${need[@]}" >/dev/null
fi

tmp=$(mktemp -d /tmp/bendscope-slurm.XXXXXX)
host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/MemTotal/ { printf "%d", $2 / 1024 * 0.8 }' /proc/meminfo)
mkdir -p "$tmp/state" "$tmp/spool" "$tmp/munge" "$tmp/sweep"

# munge: a key of our own and a socket in the temp folder (no system service touched).
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1 count=1024 status=none
chmod 400 "$tmp/munge/munge.key"
sock="$tmp/munge/munge.socket"
/usr/sbin/munged --force --key-file="$tmp/munge/munge.key" --socket="$sock" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" --seed-file="$tmp/munge/seed"

cat > "$tmp/slurm.conf" <<CONF
ClusterName=bendscope-check
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
MpiDefault=none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=check Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$tmp/slurm.conf"

stop() {
  scontrol shutdown >/dev/null 2>&1 || true
  for f in "$tmp/slurmd.pid" "$tmp/slurmctld.pid" "$tmp/munge/munged.pid"; do
    [ -f "$f" ] && kill "$(cat "$f")" 2>/dev/null || true
  done
  sleep 1
}
trap stop EXIT

slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF" -N "$host"
for _ in $(seq 60); do
  state=$(sinfo -h -N -o %t 2>/dev/null | head -1 || true)
  [ "$state" = "idle" ] && break
  sleep 1
done
echo "slurm-check: node $host is ${state:-unreachable} ($(sinfo --version))"
if [ "${state:-}" != "idle" ]; then
  tail -20 "$tmp/slurmctld.log" "$tmp/slurmd.log" >&2 || true
  exit 1
fi

cat > "$tmp/plan.toml" <<'PLAN'
pressures_kpa = [20, 40]
mesh_size_mm = 6
[design]
kind = "factorial"
[[factor]]
name = "geometry.f"
levels = [5, 6]
[[factor]]
name = "geometry.n"
levels = [11, 12]
[cluster]
cpus_per_task = 1
memory_mb = 1000
time_limit = "00:30:00"
PLAN
"$bin" sweep "$tmp/plan.toml" -o "$tmp/sweep" --emit slurm
start=$(date +%s)
sbatch --wait "$tmp/sweep/sweep.sbatch" || echo "slurm-check: sbatch --wait reported a failed task" >&2
echo "slurm-check: array finished in $(( $(date +%s) - start )) s"
sacct >/dev/null 2>&1 || true
"$bin" sweep collect "$tmp/sweep"
ok=$(awk -F, 'NR > 1 && $2 == "ok"' "$tmp/sweep/designs.csv" | wc -l)
echo "slurm-check: $ok of 4 points ok (designs.csv in $tmp/sweep)"
[ "$ok" -eq 4 ]
