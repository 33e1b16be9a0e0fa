# `cityatlas serve`, checked with curl against the files themselves: the one
# stdout line; content types; bytes identical to the files (a 3 MB file too,
# streamed in pieces); single byte ranges (a-b, a-, -n, past the end clipped,
# unsatisfiable 416); HEAD; 404 for missing files and folders; 405 for writes;
# CORS; keep-alive; nothing outside the folder (dot segments, encoded dots and
# slashes, NUL, absolute-form targets, a symlink out); request lines on stderr
# unless --quiet; clear failures for a folder that is not a tile folder and a
# port in use; `render` streams from it; SIGTERM and SIGINT stop it, exit 0.
source "$(dirname "$0")/lib.sh" "$@"
"$CITYATLAS" synth --buildings 3 --texture-size 16 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
echo "secret" > secret.txt
ln -s "$PWD/secret.txt" tiles/leak
head -c 3000000 /dev/urandom > tiles/big.bin   # more than one 64 KiB piece

SERVERS=()
cleanup() { for pid in "${SERVERS[@]}"; do kill "$pid" 2> /dev/null || true; done; }
trap cleanup EXIT
# start_serve OUT ERR ARGS...: starts serve in the background (pid in $SERVER),
# waits for its line and sets PORT from it.
start_serve() {
  local out="$1" err="$2"; shift 2
  "$CITYATLAS" serve "$@" > "$out" 2> "$err" &
  SERVER=$!
  SERVERS+=("$SERVER")
  for _ in $(seq 100); do
    grep -q "serving" "$out" 2> /dev/null && break
    kill -0 "$SERVER" 2> /dev/null || { cat "$out" "$err" >&2; fail "serve $* exited before listening"; }
    sleep 0.1
  done
  PORT=$(sed -nE 's|^serving .* at http://127\.0\.0\.1:([0-9]+)/ \(Ctrl-C stops\)$|\1|p' "$out")
  [ -n "$PORT" ] || { cat "$out" "$err" >&2; fail "serve did not print 'serving OUT at http://HOST:PORT/ (Ctrl-C stops)'"; }
}
# stop_serve PID SIGNAL: the server exits 0 on the signal.
stop_serve() {
  kill -"$2" "$1"
  set +e; wait "$1"; local rc=$?; set -e
  check_eq "serve exit status after SIG$2" "0" "$rc"
}
# header FILE NAME: the value of a response header (last one, CR stripped).
header() { sed -nE "s/^$2: *(.*)\r?$/\1/Ip" "$1" | tr -d '\r' | tail -1; }

start_serve serve.out serve.err tiles --port 0
MAIN=$SERVER
URL="http://127.0.0.1:$PORT"
echo "ok: serve listens on port $PORT"

# --- Files, types, bytes.
glb=$(cd tiles && find geometry -name '*.glb' | sort | head -1)
dds=$(cd tiles && find atlas -name '*.dds' | sort | head -1)
[ -n "$glb" ] && [ -n "$dds" ] || fail "the build wrote no .glb or no .dds"
for spec in "tileset.json application/json" "$glb model/gltf-binary" "$dds image/vnd-ms.dds" \
            "textures/0.bin application/octet-stream" "big.bin application/octet-stream"; do
  set -- $spec
  code=$(curl -s -o got.bin -D h.txt -w "%{http_code}" "$URL/$1")
  check_eq "GET $1" "200" "$code"
  check_eq "$1: content type" "$2" "$(header h.txt Content-Type)"
  cmp -s got.bin "tiles/$1" || fail "$1: the bytes differ from the file"
  check_eq "$1: Content-Length" "$(stat -c %s "tiles/$1")" "$(header h.txt Content-Length)"
done
check_eq "CORS header" "*" "$(header h.txt Access-Control-Allow-Origin)"
check_eq "Accept-Ranges" "bytes" "$(header h.txt Accept-Ranges)"

# --- Ranges, against slices of the file's own bytes.
size=$(stat -c %s tiles/big.bin)
# range SPEC FIRST LAST: a 206 with exactly bytes FIRST..LAST of big.bin.
range() {
  local code
  code=$(curl -s -o range.bin -D h.txt -w "%{http_code}" -H "Range: bytes=$1" "$URL/big.bin")
  check_eq "Range $1: status" "206" "$code"
  check_eq "Range $1: Content-Range" "bytes $2-$3/$size" "$(header h.txt Content-Range)"
  "$PY" -c "import sys; d=open('tiles/big.bin','rb').read(); open('expect.bin','wb').write(d[$2:$3 + 1])"
  cmp -s range.bin expect.bin || fail "Range $1: wrong bytes"
}
range "100-199" 100 199
range "1000000-2500000" 1000000 2500000
range "2999000-" 2999000 $((size - 1))
range "-500" $((size - 500)) $((size - 1))
range "$((size - 10))-$((size + 1000))" $((size - 10)) $((size - 1))   # past the end: clipped
range "-$((size * 2))" 0 $((size - 1))                                  # suffix longer than the file
code=$(curl -s -o /dev/null -D h.txt -w "%{http_code}" -H "Range: bytes=$size-" "$URL/big.bin")
check_eq "Range starting at the end: status" "416" "$code"
check_eq "Range starting at the end: Content-Range" "bytes */$size" "$(header h.txt Content-Range)"
code=$(curl -s -o got.bin -w "%{http_code}" -H "Range: bytes=0-1,5-6" "$URL/tileset.json")
check_eq "several ranges: the whole file" "200" "$code"
cmp -s got.bin tiles/tileset.json || fail "several ranges: not the whole file"

# --- HEAD, missing files, folders, methods, keep-alive.
code=$(curl -s -I -o h.txt -w "%{http_code} %{size_download}" "$URL/big.bin")
check_eq "HEAD big.bin: status, body bytes" "200 0" "$code"
check_eq "HEAD big.bin: Content-Length" "$size" "$(header h.txt Content-Length)"
for p in /nothing.json /geometry /geometry/ /; do
  check_eq "GET $p" "404" "$(curl -s -o /dev/null -w "%{http_code}" "$URL$p")"
done
check_eq "POST" "405" "$(curl -s -o /dev/null -w "%{http_code}" -d x "$URL/tileset.json")"
check_eq "DELETE" "405" "$(curl -s -o /dev/null -w "%{http_code}" -X DELETE "$URL/tileset.json")"
code=$(curl -s -o /dev/null -D h.txt -w "%{http_code}" -X OPTIONS "$URL/tileset.json")
check_eq "OPTIONS (CORS preflight)" "204" "$code"
check_eq "preflight allows Range" "Range" "$(header h.txt Access-Control-Allow-Headers)"
connects=$(curl -s -o /dev/null -o /dev/null -w "%{num_connects} " "$URL/tileset.json" "$URL/$glb")
check_eq "two requests, connections opened (keep-alive)" "1 0 " "$connects"

# --- Nothing outside the folder, whatever the spelling.
for p in "/../secret.txt" "/%2e%2e/secret.txt" "/%2E%2E/secret.txt" "/geometry/../../secret.txt" \
         "/geometry/%2e%2e/%2e%2e/secret.txt" "/geometry/..%2f..%2fsecret.txt" "/%2e%2e%2fsecret.txt" \
         "/leak" "/leak%00.json" "//$PWD/secret.txt" "/geometry/../../etc/passwd"; do
  code=$(curl -s --path-as-is -o body.txt -w "%{http_code}" "$URL$p" || true)
  [ "$code" == "403" ] || [ "$code" == "404" ] || fail "$p: status $code, expected 403 or 404"
  ! grep -q "secret" body.txt || fail "served a file outside the folder through $p"
  ! grep -q "root:" body.txt || fail "served /etc/passwd through $p"
done
# Targets curl will not send: absolute form and a relative path, on a raw socket.
"$PY" - "$PORT" <<'PY' || fail "a raw request target reached a file outside the folder"
import socket, sys
for target in (b"http://127.0.0.1/../secret.txt", b"../secret.txt", b"*"):
    s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
    s.sendall(b"GET " + target + b" HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
    data = b""
    while chunk := s.recv(65536):
        data += chunk
    status = data.split(b"\r\n", 1)[0]
    if b"secret" in data or not (b" 403 " in status or b" 404 " in status):
        sys.exit(f"{target!r}: {status!r}")
PY
echo "ok: nothing outside the folder is served (dot segments, encoded dots and slashes, NUL, absolute targets, a symlink out)"

# --- Raw-socket clients: a request on a half-closed socket (RFC 9112 §9.6) gets
# the whole file (cpp-httplib 0.11, serve's server until stop 26, sent
# nothing); an 80 kB request line is refused with 431, not a reset that loses
# the answer; a malformed escape is a 400; pipelined requests are answered in order.
"$PY" - "$PORT" tiles <<'PY' || fail "raw-socket clients"
import socket, sys
port, folder = int(sys.argv[1]), sys.argv[2]
def exchange(data, half_close=True):
    s = socket.create_connection(("127.0.0.1", port), timeout=30)
    s.sendall(data)
    if half_close:
        s.shutdown(socket.SHUT_WR)
    out = b""
    while chunk := s.recv(65536):
        out += chunk
    s.close()
    return out
big = open(f"{folder}/big.bin", "rb").read()
raw = exchange(b"GET /big.bin HTTP/1.1\r\nHost: x\r\n\r\n")
head, _, body = raw.partition(b"\r\n\r\n")
if not head.startswith(b"HTTP/1.1 200") or body != big:
    sys.exit(f"half-closed GET big.bin: {head[:40]!r}, {len(body)} of {len(big)} bytes")
raw = exchange(b"GET /" + b"a/" * 40000 + b"x HTTP/1.1\r\nHost: x\r\n\r\n", half_close=False)
if not raw.startswith(b"HTTP/1.1 431"):
    sys.exit(f"80 kB request line: {raw[:40]!r}")
raw = exchange(b"GET /tileset%zz.json HTTP/1.1\r\nHost: x\r\n\r\n")
if not raw.startswith(b"HTTP/1.1 400"):
    sys.exit(f"malformed escape: {raw[:40]!r}")
tileset = open(f"{folder}/tileset.json", "rb").read()
# A HEAD of a missing file is headers only (its "not found" text would be read
# as the start of the next response), then a GET and a 404 with its text.
raw = exchange(b"HEAD /nothing HTTP/1.1\r\nHost: x\r\n\r\nGET /tileset.json HTTP/1.1\r\nHost: x\r\n\r\n"
               b"GET /nothing HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
def responses(raw, head_first):
    out = []
    while raw:
        head, _, raw = raw.partition(b"\r\n\r\n")
        fields = dict(l.split(b": ", 1) for l in head.split(b"\r\n")[1:])
        n = 0 if (head_first and not out) else int(fields[b"Content-Length"])
        out.append((head.split(b" ")[1], raw[:n]))
        raw = raw[n:]
    return out
got = responses(raw, head_first=True)
if got != [(b"404", b""), (b"200", tileset), (b"404", b"not found\n")]:
    sys.exit(f"pipelined HEAD, GET, GET: {[(c, len(b)) for c, b in got]}")
PY
echo "ok: half-closed GET answered whole (3 MB), 80 kB request line 431, bad escape 400, pipelined HEAD 404 (headers only), GET, GET in order"

# --- The client streams from it.
"$CITYATLAS" render "$URL/" --size 160x120 --wait --frames 3 --fps 1 -o frames -q || fail "render from serve failed"
check_eq "render over serve: errors" "0" "$(json frames/report.json "j['summary']['errors']")"

# --- Failures: one line, exit 1.
expect 1 "cannot listen on 127\.0\.0\.1:$PORT: the port is in use" -- serve tiles --port "$PORT"
expect 1 "^cityatlas serve: error: town: not a tile folder \(no tileset\.json, no 3dtiles/tileset\.json\)$" -- serve town
expect 1 "not a tile folder" -- serve tiles/tileset.json
expect 1 "nowhere: no such folder" -- serve nowhere
expect 1 "not an address of this machine" -- serve tiles --port 0 --host 192.0.2.1
expect 2 "not in range" -- serve tiles --port 70000

# --- Log lines on stderr (the main server), none with --quiet; signals stop cleanly.
start_serve quiet.out quiet.err tiles --port 0 --quiet
curl -sf -o /dev/null "http://127.0.0.1:$PORT/tileset.json" || fail "GET from the --quiet server failed"
stop_serve "$SERVER" INT
check_eq "--quiet: stderr lines" "0" "$(wc -l < quiet.err)"
stop_serve "$MAIN" TERM
log=$(cat serve.err)
[[ "$log" == *"GET /tileset.json 200"* ]] || { echo "$log" | tail -5 >&2; fail "no request line on stderr"; }
[[ "$log" == *"GET /big.bin 206"* ]] || fail "no request line for a range request on stderr"
echo "ok: request lines on stderr, e.g. '$(grep -m1 "GET /tileset.json" serve.err)'"
check_eq "stdout lines" "1" "$(wc -l < serve.out)"
trap - EXIT
