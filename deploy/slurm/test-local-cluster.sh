#!/usr/bin/env bash
# Runs luz on a real, throwaway, single-node Slurm cluster: installs Debian's
# slurm-wlm and munge when missing, starts munged, slurmctld and slurmd bound
# to 127.0.0.1 with a configuration generated in a temporary directory,
# renders a scene as an array job (render.sbatch) followed by a dependent
# merge job (merge.sbatch), and checks the merged image against a
# single-process render. Every daemon it started is stopped on exit, by the
# PID in its pid file, whatever happened; nothing is left running or on disk.
#
#   deploy/slurm/test-local-cluster.sh
#
# Environment: LUZ (the luz binary; default: built with cargo in debug, at
# the path cargo reports, so CARGO_TARGET_DIR is honoured),
# SCENE (scenes/cornell-area.toml), RESOLUTION (64x64), SPP (64), TASKS (4),
# SLURM_PORTS (where to look for two free TCP ports; default 16817).
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
scene=${SCENE:-$repo/scenes/cornell-area.toml}
resolution=${RESOLUTION:-64x64}
spp=${SPP:-64}
tasks=${TASKS:-4}
ctld_port=${SLURM_PORTS:-16817}

say() { echo "test-local-cluster: $*" >&2; }

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null ||
    ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
    say "installing slurm-wlm and munge"
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
        --no-install-recommends slurm-wlm munge >/dev/null
fi

# The binary's path comes from cargo itself (the `executable` of the luz bin
# artifact in its JSON messages), so CARGO_TARGET_DIR, build.target-dir and
# CARGO_BUILD_TARGET are honoured. Plain grep and sed: no jq needed.
luz_from_cargo() {
    local messages path
    messages=$(cd "$repo" && cargo build --quiet --bin luz \
        --message-format=json-render-diagnostics) || {
        say "cargo build failed"
        return 1
    }
    path=$(printf '%s\n' "$messages" | grep '"reason":"compiler-artifact"' |
        grep '"kind":\["bin"\]' | grep '"name":"luz"' |
        sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)
    case $path in
    "" | *\\*)
        # Empty, or JSON-escaped (a backslash): not a path to use as is.
        say "cannot find the luz binary in cargo's build messages; set LUZ"
        return 1
        ;;
    esac
    if [ ! -x "$path" ]; then
        say "cargo reported $path as the luz binary, but it is not executable"
        return 1
    fi
    printf '%s\n' "$path"
}

if [ -z "${LUZ:-}" ]; then
    LUZ=$(luz_from_cargo)
    say "luz: $LUZ"
fi
export LUZ

# Another run (a second checkout's test.sh) may hold the ports: take the
# first free pair.
in_use() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
for _ in $(seq 50); do
    in_use "$ctld_port" || in_use "$((ctld_port + 1))" || break
    ctld_port=$((ctld_port + 2))
done
slurmd_port=$((ctld_port + 1))

tmp=$(mktemp -d "${TMPDIR:-/tmp}/luz-slurm.XXXXXX")
# munged refuses a socket directory others cannot enter.
chmod 0755 "$tmp"

# A process is gone when /proc has no entry or only a zombie: PID 1 here
# reaps zombies slowly, so `kill -0` would report them alive.
alive() {
    local state
    state=$(awk '/^State:/ {print $2}' "/proc/$1/status" 2>/dev/null) || return 1
    [ -n "$state" ] && [ "$state" != Z ]
}

stop_daemon() {
    local pidfile=$1 pid
    [ -s "$pidfile" ] || return 0
    pid=$(cat "$pidfile")
    alive "$pid" || return 0
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 100); do
        alive "$pid" || return 0
        sleep 0.1
    done
    say "$(basename "$pidfile" .pid) (PID $pid) ignored SIGTERM; killing it"
    kill -KILL "$pid" 2>/dev/null || true
}

cleanup() {
    local status=$?
    # Jobs first, so slurmd has no children left when it stops.
    if [ -s "$tmp/slurmctld.pid" ] && alive "$(cat "$tmp/slurmctld.pid")"; then
        scancel --quiet --user="$(id -un)" 2>/dev/null || true
    fi
    stop_daemon "$tmp/slurmd.pid"
    stop_daemon "$tmp/slurmctld.pid"
    stop_daemon "$tmp/munged.pid"
    if [ "$status" -ne 0 ]; then
        for log in "$tmp"/*.log "$tmp"/work/*.log; do
            [ -f "$log" ] || continue
            say "--- $log (last lines)"
            tail -n 20 "$log" >&2
        done
    fi
    rm -rf "$tmp"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

user=$(id -un)
mkdir -p "$tmp/munge" "$tmp/state" "$tmp/spool" "$tmp/work"
chmod 0755 "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 0400 "$tmp/munge/munge.key"
: >"$tmp/plugstack.conf"
cat >"$tmp/slurm.conf" <<EOF
ClusterName=luztest
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
CommunicationParameters=NoInAddrAny,NoCtldInAddrAny
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.socket
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
PlugStackConfig=$tmp/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=5
SchedulerParameters=batch_sched_delay=0
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$tmp/slurm.conf

say "starting munged, slurmctld and slurmd in $tmp"
munged --socket="$tmp/munge/munge.socket" --key-file="$tmp/munge/munge.key" \
    --pid-file="$tmp/munged.pid" --log-file="$tmp/munged.log" \
    --seed-file="$tmp/munge/munged.seed" --force
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF" -N localhost

for _ in $(seq 300); do
    state=$(sinfo --noheader --nodes=localhost --format=%T 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.1
done
if [ "$state" != idle ]; then
    say "the node did not come up (state: ${state:-unknown})"
    exit 1
fi

cd "$tmp/work"
render_args=(--resolution "$resolution" --spp "$spp")
start=$(date +%s%N)
array=$(sbatch --parsable --array=0-$((tasks - 1)) "$repo/deploy/slurm/render.sbatch" \
    "$scene" parts "${render_args[@]}")
sbatch --wait --quiet --dependency=afterok:"$array" --kill-on-invalid-dep=yes \
    "$repo/deploy/slurm/merge.sbatch" parts merged.exr
cluster_ms=$((($(date +%s%N) - start) / 1000000))

start=$(date +%s%N)
"$LUZ" render "$scene" "${render_args[@]}" --quiet -o single.exr
single_ms=$((($(date +%s%N) - start) / 1000000))

"$LUZ" compare merged.exr single.exr --fail-above 1e-6 >&2
say "wall time: $tasks-task array job + merge ${cluster_ms} ms, single process ${single_ms} ms ($(nproc) CPUs)"
say "passed"
