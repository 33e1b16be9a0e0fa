# The nginx harness for streaming tests (tests/render/nginx/nginx_serve.sh):
# it starts Debian's nginx on a free loopback port and prints it; the tile
# files come back byte-identical with their content types, single ranges are
# 206 with the right bytes, HEAD and 404 work; RATE lands in the config as
# limit_rate (the speed is printed, never asserted); as a normal user it runs
# without writing or even trying to write outside its work folder; stop ends
# it and closes the port; bad arguments are refused. Skipped without nginx.
source "$(dirname "$0")/lib.sh" "$@"
HARNESS="$SRC/tests/render/nginx/nginx_serve.sh"
[ -x /usr/sbin/nginx ] || { echo "SKIPPED: nginx is not installed (Debian: apt-get install nginx-light)"; exit 77; }

"$CITYATLAS" synth --buildings 3 --texture-size 16 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
head -c 3000000 /dev/urandom > tiles/big.bin

WORKDIRS=()
cleanup() { for w in "${WORKDIRS[@]}"; do bash "$HARNESS" stop "$w" || true; done; }
trap cleanup EXIT
# header FILE NAME: the value of a response header (last one, CR stripped).
header() { sed -nE "s/^$2: *(.*)\r?$/\1/Ip" "$1" | tr -d '\r' | tail -1; }

WORKDIRS+=("$PWD/ng")
PORT=$(bash "$HARNESS" start tiles ng)
[[ "$PORT" =~ ^[0-9]+$ ]] || fail "start printed '$PORT', expected a port"
URL="http://127.0.0.1:$PORT"
check_eq "pid file in the work folder names a running process" "0" "$(kill -0 "$(cat ng/nginx.pid)"; echo $?)"
echo "ok: nginx on port $PORT"

glb=$(cd tiles && find geometry -name '*.glb' | sort | head -1)
dds=$(cd tiles && find atlas -name '*.dds' | sort | head -1)
for spec in "tileset.json application/json" "$glb model/gltf-binary" "$dds image/vnd-ms.dds" \
            "textures/0.bin application/octet-stream" "big.bin application/octet-stream"; do
  set -- $spec
  code=$(curl -s -o got.bin -D h.txt -w "%{http_code}" "$URL/$1")
  check_eq "GET $1" "200" "$code"
  check_eq "$1: content type" "$2" "$(header h.txt Content-Type)"
  cmp -s got.bin "tiles/$1" || fail "$1: the bytes differ from the file"
done
size=$(stat -c %s tiles/big.bin)
code=$(curl -s -o range.bin -D h.txt -w "%{http_code}" -H "Range: bytes=1000000-1999999" "$URL/big.bin")
check_eq "Range: status" "206" "$code"
check_eq "Range: Content-Range" "bytes 1000000-1999999/$size" "$(header h.txt Content-Range)"
"$PY" -c "d=open('tiles/big.bin','rb').read(); open('expect.bin','wb').write(d[1000000:2000000])"
cmp -s range.bin expect.bin || fail "Range: wrong bytes"
code=$(curl -s -o range.bin -w "%{http_code}" -H "Range: bytes=-100" "$URL/tileset.json")
check_eq "suffix Range: status" "206" "$code"
cmp -s range.bin <(tail -c 100 tiles/tileset.json) || fail "suffix Range: wrong bytes"
check_eq "HEAD: status, body bytes" "200 0" "$(curl -s -I -o h.txt -w "%{http_code} %{size_download}" "$URL/big.bin")"
check_eq "HEAD: Content-Length" "$size" "$(header h.txt Content-Length)"
check_eq "missing file" "404" "$(curl -s -o /dev/null -w "%{http_code}" "$URL/nothing.json")"
check_eq "two requests, connections opened (keep-alive)" "1 0 " \
  "$(curl -s -o /dev/null -o /dev/null -w "%{num_connects} " "$URL/tileset.json" "$URL/$glb")"
log=$(cat ng/access.log)
[[ "$log" == *"GET /big.bin"* ]] || fail "the access log in the work folder lacks the requests"

# stop: the process ends, the port closes; a second stop is a no-op.
pid=$(cat ng/nginx.pid)
bash "$HARNESS" stop ng || fail "stop failed"
! kill -0 "$pid" 2> /dev/null || fail "nginx (pid $pid) still runs after stop"
check_eq "connecting after stop (curl: couldn't connect)" "7" "$(curl -s -o /dev/null "$URL/tileset.json"; echo $?)"
bash "$HARNESS" stop ng || fail "a second stop failed"
echo "ok: stop ends nginx and closes the port"

# A rate limit: in the config; the download is still exact. Speed printed only.
WORKDIRS+=("$PWD/slow")
PORT=$(bash "$HARNESS" start tiles slow 2m)
conf=$(cat slow/nginx.conf)
[[ "$conf" == *"limit_rate 2m;"* ]] || fail "RATE 2m is not in the config as limit_rate"
[[ "$conf" == *"daemon on;"* ]] || fail "the harness's config does not daemonise"
speed=$(curl -s -o got.bin -w "%{speed_download}" "http://127.0.0.1:$PORT/big.bin")
cmp -s got.bin tiles/big.bin || fail "rate-limited download: the bytes differ"
echo "ok: limit_rate 2m; 3 MB came at $(( ${speed%.*} / 1000 )) kB/s (informational)"
bash "$HARNESS" stop slow

# As a normal user: starts, serves, and nginx reports no failed attempt to
# write elsewhere (default log, pid or temp paths would be denied and logged).
if [ "$(id -u)" = 0 ] && command -v setpriv > /dev/null &&
   setpriv --reuid=nobody --regid=nogroup --clear-groups test -r tiles/tileset.json 2> /dev/null; then
  mkdir -p user && chown nobody:nogroup user
  WORKDIRS+=("$PWD/user")
  AS_NOBODY=(setpriv --reuid=nobody --regid=nogroup --clear-groups)
  PORT=$("${AS_NOBODY[@]}" bash "$HARNESS" start tiles user) || fail "start as nobody failed"
  check_eq "nginx runs as" "nobody" "$(ps -o user= -p "$(cat user/nginx.pid)")"
  check_eq "GET as nobody's nginx" "200" "$(curl -s -o /dev/null -w "%{http_code}" "http://127.0.0.1:$PORT/tileset.json")"
  "${AS_NOBODY[@]}" bash "$HARNESS" stop user || fail "stop as nobody failed"
  startlog=$(cat user/start.log user/error.log)
  [[ "$startlog" != *"[alert]"* && "$startlog" != *"[emerg]"* && "$startlog" != *"[crit]"* ]] ||
    { echo "$startlog" >&2; fail "nginx as nobody logged failures"; }
  echo "ok: as nobody: started, served, stopped, nothing logged"
else
  echo "SKIPPED (part): the run as a normal user needs root, setpriv and a folder nobody can read"
fi

# Bad arguments.
set +e
bash "$HARNESS" start tiles bad fast 2> err.txt; rc=$?
set -e
check_eq "RATE 'fast': exit" "1" "$rc"
set +e; bash "$HARNESS" start tiles 2> err.txt; rc=$?; set -e
check_eq "start without WORKDIR: exit" "2" "$rc"
set +e; NGINX=/nonexistent/nginx bash "$HARNESS" start tiles bad2 2> err.txt; rc=$?; set -e
check_eq "no nginx: exit (skip)" "77" "$rc"
trap - EXIT
cleanup
