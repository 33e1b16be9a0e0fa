# `serve` under load: 64 concurrent clients on loopback for a few seconds
# (tests/tools/serve_load.py: whole files on keep-alive connections, byte
# ranges, HEAD, half-closed and abandoned sockets, traversal attempts with
# encoded dots, NUL, an 80 kB path and a symlink out). No valid request may
# fail, no hostile one be served, the server's fds must come back to where
# they were and its memory must not grow after warm-up (under 16 MB).
# benchmarks/serve_load.sh runs the same for longer.
source "$(dirname "$0")/lib.sh" "$@"
"$CITYATLAS" synth -q --buildings 20 --seed 5 --texture-size 64 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o out > /dev/null
ln -s /etc/passwd out/leak
"$CITYATLAS" serve -q out --port 0 > serve.txt 2> serve.err &
SERVER=$!
trap 'kill $SERVER 2>/dev/null || true' EXIT
for _ in $(seq 100); do grep -q "serving" serve.txt 2>/dev/null && break; sleep 0.05; done
PORT=$(sed -n 's|.*127.0.0.1:\([0-9]*\)/.*|\1|p' serve.txt)
[ -n "$PORT" ] || fail "serve did not start: $(cat serve.err)"
"$PY" "$SRC/tests/tools/serve_load.py" "http://127.0.0.1:$PORT/" out "$SERVER" --clients 64 --seconds 5 --json load.json \
  > load.txt 2>&1 || { cat load.txt >&2; fail "serve under load failed"; }
"$PY" - <<'PY' || fail "memory grew under load"
import json
j = json.load(open("load.json")); s = j["server"]
growth = s["after"]["rss_mb"] - s["after_warmup"]["rss_mb"]
print(f"ok: {j['valid']} valid requests ({j['idle_closed_retried']} retried after an idle keep-alive close), "
      f"{j['hostile']} hostile refused, {j['half_closed']} half-closed ({j['half_closed_answered']} answered); "
      f"fds {s['before']['fds']} -> {s['mid_load']['fds']} under load -> {s['after']['fds']}; "
      f"RSS {s['after_warmup']['rss_mb']} -> {s['after']['rss_mb']} MB")
assert growth < 16, growth
PY
kill -0 "$SERVER" || fail "the server died under load"
