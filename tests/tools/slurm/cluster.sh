#!/usr/bin/env bash
# A throwaway one-node Slurm cluster on loopback, for tests.
#
#   cluster.sh available    exit 0 if slurmctld/slurmd/munged/... exist, else 77
#                           with a one-line reason (a test uses it to skip)
#   cluster.sh start DIR    make DIR (private state folder), start munged,
#                           slurmctld and slurmd inside it, wait until the node
#                           is idle, print `export X=Y` lines for the clients
#   cluster.sh env DIR      print those `export` lines again
#   cluster.sh stop DIR     cancel the cluster's jobs, stop its daemons by the
#                           pids in DIR's pidfiles (TERM, 10 s, KILL)
#
# Everything (munge key, socket, logs, slurm.conf, spool, state) lives in DIR;
# the system's munge and /etc/slurm are neither read nor touched. Daemons run as
# the calling user (root in CI). Needs Debian 12's `slurm-wlm` and `munge`.
#
# Environment (optional):
#   CITYATLAS_SLURM_CTLD_PORT, CITYATLAS_SLURM_SLURMD_PORT  fixed ports
#       (default: a free random pair in 20000-29999, checked against
#       /proc/net/tcp*)
#   CITYATLAS_SLURM_START_TIMEOUT  seconds to wait for an idle node (60)
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
prog=cluster.sh
node_name=localhost

die() { echo "$prog: $*" >&2; exit 1; }

usage() {
    echo "usage: $prog available | start DIR | env DIR | stop DIR" >&2
    exit 2
}

# --- available ---------------------------------------------------------------

find_missing() {
    local b
    for b in munged mungekey munge unmunge slurmctld slurmd sbatch squeue sinfo scontrol scancel; do
        if ! command -v "$b" >/dev/null 2>&1; then
            # munged/slurmd/slurmctld live in /usr/sbin, which a non-root PATH
            # may lack.
            if [[ -x /usr/sbin/$b ]]; then continue; fi
            echo "$b"
            return
        fi
    done
    if [[ ! -e /usr/lib/x86_64-linux-gnu/slurm-wlm/select_cons_tres.so &&
          -z "$(find /usr/lib* -name select_cons_tres.so -print -quit 2>/dev/null)" ]]; then
        echo "slurm plugin select_cons_tres.so"
    fi
}

cmd_available() {
    local m
    m=$(find_missing)
    if [[ -n $m ]]; then
        echo "$prog: $m not found (apt-get install -y slurm-wlm munge)"
        exit 77
    fi
    exit 0
}

# --- helpers -----------------------------------------------------------------

PATH=$PATH:/usr/sbin:/sbin

abs_dir() {  # DIR -> absolute path (DIR need not exist)
    local d=$1
    [[ $d == /* ]] || d=$PWD/$d
    # Drop trailing slashes and "./" parts; keep it simple (no realpath -m on
    # purpose: symlinks are fine).
    while [[ $d == */ && $d != / ]]; do d=${d%/}; done
    d=${d//\/.\//\/}
    printf '%s\n' "$d"
}

# Is TCP port $1 in use (listening or bound) on any address?
port_busy() {
    local hex
    hex=$(printf '%04X' "$1")
    awk -v p=":$hex" 'NR > 1 && substr($2, length($2) - 4) == p { found = 1 } END { exit !found }' \
        /proc/net/tcp /proc/net/tcp6 2>/dev/null
}

pick_ports() {
    if [[ -n ${CITYATLAS_SLURM_CTLD_PORT:-} || -n ${CITYATLAS_SLURM_SLURMD_PORT:-} ]]; then
        ctld_port=${CITYATLAS_SLURM_CTLD_PORT:?set both CITYATLAS_SLURM_CTLD_PORT and CITYATLAS_SLURM_SLURMD_PORT}
        slurmd_port=${CITYATLAS_SLURM_SLURMD_PORT:?set both CITYATLAS_SLURM_CTLD_PORT and CITYATLAS_SLURM_SLURMD_PORT}
        port_busy "$ctld_port" && die "port $ctld_port (CITYATLAS_SLURM_CTLD_PORT) is in use"
        port_busy "$slurmd_port" && die "port $slurmd_port (CITYATLAS_SLURM_SLURMD_PORT) is in use"
        return 0
    fi
    local i p
    for ((i = 0; i < 100; i++)); do
        # Below the Linux ephemeral range (32768+), above the well-known ones.
        p=$((20000 + (RANDOM % 5000) * 2))
        if ! port_busy "$p" && ! port_busy $((p + 1)); then
            ctld_port=$p
            slurmd_port=$((p + 1))
            return 0
        fi
    done
    die "no free port pair found in 20000-29999"
}

# sed replacement text: escape \ & and the | delimiter.
sed_escape() { printf '%s' "$1" | sed -e 's/[\\&|]/\\&/g'; }

render() {  # TEMPLATE OUT NAME=VALUE...
    local in=$1 out=$2 kv args=()
    shift 2
    for kv in "$@"; do
        args+=(-e "s|@${kv%%=*}@|$(sed_escape "${kv#*=}")|g")
    done
    sed "${args[@]}" "$in" >"$out.tmp"
    if grep -q '@[A-Z_]*@' "$out.tmp"; then
        die "unsubstituted placeholder in $out: $(grep -o '@[A-Z_]*@' "$out.tmp" | head -1)"
    fi
    mv "$out.tmp" "$out"
}

print_env() {  # DIR
    printf 'export SLURM_CONF=%q\n' "$1/slurm.conf"
}

# Is pid $1 alive and a process of this cluster (its command line names DIR)?
# Guards against a recycled pid from a stale pidfile.
ours() {  # PID DIR
    local pid=$1 dir=$2 cmdline
    [[ $pid =~ ^[0-9]+$ ]] || return 1
    [[ -r /proc/$pid/cmdline ]] || return 1
    cmdline=$(tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null) || return 1
    [[ $cmdline == *"$dir/"* ]]
}

# Pids of processes (slurmstepd of our jobs) holding a unix socket under DIR/spool.
spool_socket_pids() {  # DIR
    local dir=$1 inodes pid fd link
    inodes=$(awk -v d="$dir/spool/" 'NR > 1 && index($8, d) == 1 { print $7 }' /proc/net/unix 2>/dev/null | sort -u)
    [[ -n $inodes ]] || return 0
    declare -A want=()
    local i
    for i in $inodes; do want[$i]=1; done
    for pid in /proc/[0-9]*; do
        pid=${pid#/proc/}
        [[ $pid == "$$" ]] && continue
        for fd in "/proc/$pid/fd"/*; do
            link=$(readlink "$fd" 2>/dev/null) || continue
            if [[ $link == socket:\[*\] ]]; then
                link=${link#socket:[}
                link=${link%]}
                if [[ -n ${want[$link]:-} ]]; then
                    echo "$pid"
                    break
                fi
            fi
        done
    done
}

# Pids of processes in the sessions led by the given pids (each daemon is
# started by setsid, so this is the daemon and the helpers it forked, such as
# slurmctld's slurmscriptd; slurmstepd makes a session of its own).
session_pids() {  # SID...
    [[ $# -gt 0 ]] || return 0
    local f rest sid
    declare -A want=()
    for sid in "$@"; do want[$sid]=1; done
    for f in /proc/[0-9]*/stat; do
        rest=$(<"$f") 2>/dev/null || continue
        rest=${rest##*) }   # after "pid (comm) ": state ppid pgrp session ...
        read -r _ _ _ sid _ <<<"$rest"
        if [[ -n ${want[$sid]:-} ]]; then
            f=${f#/proc/}
            echo "${f%/stat}"
        fi
    done
}

# TERM the given pids, wait up to 10 s, then KILL the survivors.
terminate() {  # NAME PID...
    local name=$1 pid alive i
    shift
    [[ $# -gt 0 ]] || return 0
    kill -TERM "$@" 2>/dev/null || true
    for ((i = 0; i < 100; i++)); do
        alive=()
        for pid in "$@"; do
            if kill -0 "$pid" 2>/dev/null && [[ $(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null) != Z ]]; then
                alive+=("$pid")
            fi
        done
        [[ ${#alive[@]} -gt 0 ]] || return 0
        sleep 0.1
    done
    echo "$prog: $name (pid ${alive[*]}) did not stop within 10 s of SIGTERM; sending SIGKILL" >&2
    kill -KILL "${alive[@]}" 2>/dev/null || true
}

# --- start -------------------------------------------------------------------

log_tail() {  # FILE
    [[ -s $1 ]] || return 0
    echo "--- last lines of $1:" >&2
    tail -n 15 "$1" | sed 's/^/    /' >&2
}

start_failed() {  # MESSAGE LOGFILE (the daemon's stdio is in LOGFILE's .out twin)
    local out=${2%.log}.out
    if [[ -s $out ]]; then
        echo "$prog: $1; see $2 and $out" >&2
    else
        echo "$prog: $1; see $2" >&2
    fi
    # With -D the daemons log to both; show the stdio copy only when the log
    # file is empty (the daemon died before opening it).
    if [[ -s $2 ]]; then log_tail "$2"; else log_tail "$out"; fi
    "$0" stop "$dir" >/dev/null 2>&1 || true
    exit 1
}

# Launch a daemon in its foreground mode, in a session of its own and detached
# from our stdio (so that $(cluster.sh start DIR) returns), and record its pid.
# Its stdout/stderr (early errors, e.g. a bad slurm.conf, before it opens its
# log file) go to DIR/log/NAME.out.
launch() {  # NAME CMD...
    local name=$1
    shift
    setsid "$@" </dev/null >>"$dir/log/$name.out" 2>&1 &
    echo $! >"$dir/run/$name.launch.pid"
}

cmd_start() {
    local m
    m=$(find_missing)
    [[ -z $m ]] || { echo "$prog: $m not found (apt-get install -y slurm-wlm munge)" >&2; exit 77; }

    dir=$(abs_dir "$1")
    if [[ -e $dir/slurm.conf ]]; then
        die "$dir already holds a cluster (stop it and use a fresh folder)"
    fi
    if [[ -d $dir && -n $(ls -A "$dir") ]]; then
        die "$dir is not empty (give a new or empty folder)"
    fi
    mkdir -p "$dir"
    # munged refuses a socket below a folder that others cannot traverse.
    local up=${dir%/*} perm
    while [[ -n $up ]]; do
        perm=$(stat -L -c '%A' "$up")
        if [[ ${perm:9:1} != [xt] ]]; then
            die "munged needs execute permission for all on $up (above $dir); chmod o+x it or use another folder"
        fi
        up=${up%/*}
    done
    # 711: munged requires execute-for-all on every folder above its socket.
    chmod 711 "$dir"
    mkdir -m 700 "$dir/state" "$dir/spool" "$dir/run" "$dir/log"
    # munged wants execute-for-all on its socket folder (clients must reach it).
    mkdir -m 711 "$dir/munge"

    local user sock
    user=$(id -un)
    sock=$dir/munge/munge.socket
    # Unix socket paths are limited to 107 bytes: munge's socket, and slurmd's
    # step sockets (spool/NODE_JOBID.STEPID, ~30 bytes more than the folder).
    if (( ${#sock} > 100 || ${#dir} + 45 > 107 )); then
        die "folder path too long for unix sockets (${#dir} bytes): $dir; use a shorter one, e.g. mktemp -d"
    fi

    # munge key: private to this cluster, owned by us, read-only.
    local key=$dir/munge/munge.key
    if ! mungekey --create --keyfile="$key" --bits=1024 >/dev/null 2>&1; then
        rm -f "$key"
        dd if=/dev/urandom of="$key" bs=128 count=1 status=none
    fi
    chmod 400 "$key"

    # Node size from the machine.
    local cpus mem_kb mem_mb
    cpus=$(nproc)
    mem_kb=$(awk '/^MemTotal:/ { print $2 }' /proc/meminfo)
    mem_mb=$((mem_kb / 1024))
    (( mem_mb > 1 )) || mem_mb=1

    pick_ports
    local name
    name=ca$(printf '%05d' $((RANDOM % 100000)))

    render "$here/slurm.conf.in" "$dir/slurm.conf" \
        DIR="$dir" CLUSTER_NAME="$name" NODE_NAME="$node_name" \
        CTLD_PORT="$ctld_port" SLURMD_PORT="$slurmd_port" \
        SLURM_USER="$user" SLURMD_USER="$user" MUNGE_SOCKET="$sock" \
        CPUS="$cpus" REAL_MEMORY="$mem_mb"
    render "$here/cgroup.conf.in" "$dir/cgroup.conf" DIR="$dir"
    : >"$dir/plugstack.conf"
    chmod 644 "$dir/slurm.conf" "$dir/cgroup.conf" "$dir/plugstack.conf"

    local t0=$SECONDS timeout=${CITYATLAS_SLURM_START_TIMEOUT:-60} i tstart
    tstart=$(date +%s.%N)

    # munged: foreground (-F) under our control; every path inside DIR.
    local mlog=$dir/log/munged.log
    launch munged munged -F \
        --socket="$sock" --key-file="$key" --pid-file="$dir/run/munged.pid" \
        --log-file="$mlog" --seed-file="$dir/munge/munged.seed"
    for ((i = 0; ; i++)); do
        if [[ -S $sock ]] && munge -n -S "$sock" 2>/dev/null | unmunge -S "$sock" >/dev/null 2>&1; then
            break
        fi
        kill -0 "$(cat "$dir/run/munged.launch.pid")" 2>/dev/null ||
            start_failed "munged exited during startup" "$mlog"
        (( i < 100 )) || start_failed "munged did not answer on $sock within 10 s" "$mlog"
        sleep 0.1
    done

    export SLURM_CONF=$dir/slurm.conf

    local clog=$dir/log/slurmctld.log dlog=$dir/log/slurmd.log
    # -i: ignore (absent) state files; -D: foreground.
    launch slurmctld slurmctld -D -i -f "$dir/slurm.conf"
    for ((i = 0; ; i++)); do
        if scontrol ping 2>/dev/null | grep -q 'is UP'; then break; fi
        kill -0 "$(cat "$dir/run/slurmctld.launch.pid")" 2>/dev/null ||
            start_failed "slurmctld exited during startup" "$clog"
        (( SECONDS - t0 < timeout )) || start_failed "slurmctld did not answer within ${timeout} s" "$clog"
        sleep 0.2
    done

    launch slurmd slurmd -D -f "$dir/slurm.conf" -N "$node_name"
    local state=
    for ((i = 0; ; i++)); do
        state=$(sinfo -h -n "$node_name" -o '%T' 2>/dev/null | head -1) || true
        [[ $state == idle ]] && break
        kill -0 "$(cat "$dir/run/slurmd.launch.pid")" 2>/dev/null ||
            start_failed "slurmd exited during startup" "$dlog"
        kill -0 "$(cat "$dir/run/slurmctld.launch.pid")" 2>/dev/null ||
            start_failed "slurmctld exited during startup" "$clog"
        if [[ $state == drain* || $state == down* || $state == fail* ]] && (( SECONDS - t0 > 10 )); then
            start_failed "node $node_name is $state ($(sinfo -h -n "$node_name" -o '%E' 2>/dev/null))" "$dlog"
        fi
        (( SECONDS - t0 < timeout )) ||
            start_failed "node $node_name not idle within ${timeout} s (state: ${state:-none})" "$dlog"
        sleep 0.2
    done

    echo "$prog: cluster $name up in $(awk -v a="$tstart" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }') s (ctld port $ctld_port, slurmd port $slurmd_port, $cpus CPUs, $mem_mb MB) in $dir" >&2
    print_env "$dir"
}

# --- stop --------------------------------------------------------------------

pids_of() {  # NAME -> pids from DIR/run/NAME.pid and NAME.launch.pid that are ours
    local name=$1 f pid
    for f in "$dir/run/$name.pid" "$dir/run/$name.launch.pid"; do
        [[ -r $f ]] || continue
        pid=$(tr -dc '0-9' <"$f")
        if ours "$pid" "$dir"; then echo "$pid"; fi
    done | sort -u
}

cmd_stop() {
    dir=$(abs_dir "$1")
    [[ -d $dir/run ]] || { echo "$prog: no cluster in $dir (nothing to stop)" >&2; return 0; }

    local ctld slurmd munged steps
    ctld=$(pids_of slurmctld)
    # Cancel the cluster's jobs first so slurmstepd and job processes go away
    # with it (they are not children of slurmd).
    if [[ -n $ctld && -r $dir/slurm.conf ]]; then
        local jobs i
        jobs=$(SLURM_CONF=$dir/slurm.conf timeout 10 squeue -h -o '%A' 2>/dev/null | sort -u | tr '\n' ' ') || true
        if [[ -n ${jobs// /} ]]; then
            # shellcheck disable=SC2086
            SLURM_CONF=$dir/slurm.conf timeout 10 scancel $jobs 2>/dev/null || true
            for ((i = 0; i < 50; i++)); do
                [[ -z $(spool_socket_pids "$dir") ]] && break
                sleep 0.2
            done
        fi
    fi

    slurmd=$(pids_of slurmd)
    # shellcheck disable=SC2086
    terminate slurmd $slurmd
    # shellcheck disable=SC2086
    terminate slurmctld $ctld
    steps=$(spool_socket_pids "$dir")
    # shellcheck disable=SC2086
    terminate slurmstepd $steps
    munged=$(pids_of munged)
    # shellcheck disable=SC2086
    terminate munged $munged
    # Whatever the daemons left behind in their sessions (only after a KILL).
    local left
    # shellcheck disable=SC2086
    left=$(session_pids $slurmd $ctld $munged)
    # shellcheck disable=SC2086
    terminate "leftover processes of $dir" $left
    return 0
}

# --- main --------------------------------------------------------------------

[[ $# -ge 1 ]] || usage
case $1 in
available) [[ $# -eq 1 ]] || usage; cmd_available ;;
start) [[ $# -eq 2 ]] || usage; cmd_start "$2" ;;
env) [[ $# -eq 2 ]] || usage; print_env "$(abs_dir "$2")" ;;
stop) [[ $# -eq 2 ]] || usage; cmd_stop "$2" ;;
*) usage ;;
esac
