# `cityatlas serve`: files of the folder with their content types and Range
# requests; nothing outside the folder (dot segments, encoded dots, symlinks);
# clear failures for a folder that is not a tile folder and a port in use;
# `render` streams from it; SIGTERM stops it cleanly.
source "$(dirname "$0")/lib.sh" "$@"
"$CITYATLAS" synth --buildings 6 --texture-size 32 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
echo "secret" > secret.txt
ln -s "$PWD/secret.txt" tiles/leak

"$CITYATLAS" serve tiles --port 0 -q > serve.out 2> serve.err &
SERVER=$!
trap 'kill $SERVER 2>/dev/null || true' EXIT
for _ in $(seq 50); do grep -q "serving" serve.out 2>/dev/null && break; sleep 0.1; done
PORT=$(sed -nE 's|.*http://127\.0\.0\.1:([0-9]+)/.*|\1|p' serve.out)
[ -n "$PORT" ] || { cat serve.out serve.err >&2; fail "serve did not say where it listens"; }
URL="http://127.0.0.1:$PORT"

curl -sf -o got.json -D headers.txt "$URL/tileset.json" || fail "GET tileset.json failed"
cmp -s got.json tiles/tileset.json || fail "tileset.json differs from the file"
grep -qi "^content-type: application/json" headers.txt || fail "tileset.json: wrong content type"
grep -qi "^access-control-allow-origin: \*" headers.txt || fail "no CORS header"
glb=$(cd tiles && echo geometry/opaque/0.glb)
curl -sf -o /dev/null -D glb_headers.txt "$URL/$glb" || fail "GET $glb failed"
grep -qi "^content-type: model/gltf-binary" glb_headers.txt || fail "$glb: wrong content type"
code=$(curl -s -o range.bin -w "%{http_code}" -r 100-199 "$URL/tileset.json")
check_eq "Range request status" "206" "$code"
cmp -s range.bin <(tail -c +101 tiles/tileset.json | head -c 100) || fail "Range request: wrong bytes"
check_eq "missing file" "404" "$(curl -s -o /dev/null -w "%{http_code}" "$URL/nothing.json")"
for p in "/../secret.txt" "/%2e%2e/secret.txt" "/geometry/../../secret.txt" "/leak"; do
  body=$(curl -s --path-as-is "$URL$p" || true)
  [ "$body" != "secret" ] || fail "served a file outside the folder through $p"
done
echo "ok: nothing outside the folder is served (dot segments, encoded dots, a symlink out)"

"$CITYATLAS" render "$URL/" --size 160x120 --wait --frames 3 --fps 1 -o frames -q || fail "render from serve failed"
check_eq "render over serve: errors" "0" "$(json frames/report.json "j['summary']['errors']")"

expect 1 "in use|cannot listen" -- serve tiles --port "$PORT"
expect 1 "not a tile folder" -- serve town
expect 1 "no such folder" -- serve nowhere
kill -TERM $SERVER
set +e; wait $SERVER; rc=$?; set -e
trap - EXIT
check_eq "serve exit status after SIGTERM" "0" "$rc"
