#!/usr/bin/env bash
# Debian's nginx (nginx-light) as a throw-away static server for streaming
# tests: loopback only, on a free port, serving ROOT read-only with the tile
# content types, optionally rate-limited per connection to emulate a slow
# network. It runs as the calling user (one process, no master: root or not)
# and writes only under WORKDIR: config, pid, logs, temp folders.
#
#   nginx_serve.sh start ROOT WORKDIR [RATE]   prints the PORT on stdout
#       RATE: nginx's limit_rate per connection, bytes/s with k or m (2m = 2 MB/s)
#   nginx_serve.sh stop WORKDIR                stops it (no error if not running)
#
# Exit 0 ok, 1 failure (the reason on stderr), 2 usage, 77 nginx not installed.
set -euo pipefail
NGINX="${NGINX:-/usr/sbin/nginx}"
HERE="$(cd "$(dirname "$0")" && pwd)"
PY=/usr/bin/python3
[ -x "$PY" ] || PY=python3

usage() { echo "usage: $0 start ROOT WORKDIR [RATE] | stop WORKDIR" >&2; exit 2; }
die() { echo "nginx_serve.sh: $*" >&2; exit 1; }

free_port() {  # a port free now; nginx may still lose it to someone else, so start retries
  "$PY" -c "import socket; s=socket.socket(); s.bind(('127.0.0.1', 0)); print(s.getsockname()[1]); s.close()"
}

pid_of() {  # the running nginx's pid from WORKDIR, or nothing
  local pid
  pid=$(cat "$1/nginx.pid" 2>/dev/null || true)
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then echo "$pid"; fi
}

start() {
  local root="$1" work="$2" rate="${3:-0}"
  [ -x "$NGINX" ] || { echo "SKIPPED: nginx is not installed (Debian: apt-get install nginx-light)" >&2; exit 77; }
  [[ "$rate" =~ ^[0-9]+[kKmM]?$ ]] || die "RATE '$rate': expected bytes/s like 500k or 2m"
  [ -d "$root" ] || die "$root: no such folder"
  mkdir -p "$work"
  root="$(cd "$root" && pwd -P)"
  work="$(cd "$work" && pwd -P)"
  [ -z "$(pid_of "$work")" ] || die "$work: an nginx from there is running already (stop it first)"
  local attempt port
  for attempt in 1 2 3 4 5; do
    port=$(free_port)
    sed -e "s|@WORK@|$work|g" -e "s|@ROOT@|$root|g" -e "s|@PORT@|$port|g" -e "s|@RATE@|$rate|g" \
        -e "s|^daemon off;|daemon on;|" "$HERE/nginx.conf.in" > "$work/nginx.conf"
    rm -f "$work/nginx.pid"
    # -e: even errors before the config is read go under WORKDIR. The parent
    # returns once the socket is bound; the daemon writes the pid file after.
    if "$NGINX" -p "$work/" -c "$work/nginx.conf" -e "$work/error.log" 2> "$work/start.log"; then
      for _ in $(seq 100); do
        [ -n "$(pid_of "$work")" ] && { echo "$port"; return 0; }
        sleep 0.05
      done
      die "nginx started but wrote no pid file; $work/error.log: $(tail -3 "$work/error.log" 2>/dev/null)"
    fi
    grep -q "Address already in use" "$work/start.log" "$work/error.log" 2>/dev/null || break
  done
  cat "$work/start.log" >&2
  tail -5 "$work/error.log" >&2 2>/dev/null || true
  die "nginx did not start (attempt $attempt)"
}

stop() {
  local work="$1" pid
  pid=$(pid_of "$work")
  [ -n "$pid" ] || return 0
  kill -TERM "$pid"  # fast shutdown: open connections are closed
  for _ in $(seq 100); do
    kill -0 "$pid" 2>/dev/null || { rm -f "$work/nginx.pid"; return 0; }
    sleep 0.05
  done
  kill -KILL "$pid" 2>/dev/null || true
  rm -f "$work/nginx.pid"
  die "nginx (pid $pid) ignored SIGTERM for 5 s; killed"
}

case "${1:-}" in
  start) [ $# -ge 3 ] && [ $# -le 4 ] || usage; start "$2" "$3" "${4:-}" ;;
  stop) [ $# -eq 2 ] || usage; stop "$2" ;;
  *) usage ;;
esac
