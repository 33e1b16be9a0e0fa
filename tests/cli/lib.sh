# Shared helpers for the CLI tests. Usage: source lib.sh "$@"
set -euo pipefail
CITYATLAS="$1"; WORK="$2"; SRC="$3"
rm -rf "$WORK"; mkdir -p "$WORK"; cd "$WORK"
PY=/usr/bin/python3   # Debian's python (with python3-jsonschema), not a pyenv one

fail() { echo "FAIL: $*" >&2; exit 1; }
check_eq() {  # check_eq WHAT EXPECTED ACTUAL
  [ "$2" == "$3" ] || fail "$1: expected '$2', got '$3'"
  echo "ok: $1 = $3"
}
# json FILE EXPR: evaluates a Python expression over the parsed file as j
json() { "$PY" -c "import json,sys; j=json.load(open(sys.argv[1])); print($2)" "$1"; }
# validate_json FILE SCHEMA: FILE matches the JSON Schema (draft 2020-12)
validate_json() {
  "$PY" -c "import json,jsonschema,sys; jsonschema.validate(json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), cls=jsonschema.Draft202012Validator)" \
    "$1" "$2" || fail "$1 does not match $(basename "$2")"
}
# XPath count over a CityGML file, namespace-agnostic
xcount() { xmllint --xpath "count($2)" "$1"; }

# Makes the Khronos glTF validator (npm gltf-validator, pinned in
# tests/tools/gltf/package-lock.json) available; exits 77 (skipped) without
# node >= 18. The first run installs it with `npm ci` (needs the npm registry).
# gltf_validate FILE: runs the Khronos validator (after ensure_gltf_validator),
# leaves its output in validate.txt and returns its exit status.
gltf_validate() {
  set +e
  node "$GLTF_TOOLS/validate.mjs" --all "$1" > validate.txt 2>&1
  local rc=$?
  set -e
  return $rc
}
# expect_invalid FILE PATTERN WHAT: the validator rejects FILE (exit 1) and says PATTERN.
expect_invalid() {  # expect_invalid FILE PATTERN WHAT
  local rc=0
  gltf_validate "$1" || rc=$?
  [ $rc -eq 1 ] || { cat validate.txt >&2; fail "$3: validator exit $rc, expected 1"; }
  grep -q -- "$2" validate.txt || { cat validate.txt >&2; fail "$3: output lacks '$2'"; }
  echo "ok: $3 is rejected: $(grep -m1 -- "$2" validate.txt | sed 's/^ *//')"
}
# glb_json FILE EXPR: a Python expression over the glb's JSON chunk as j.
glb_json() {
  "$PY" -c "import json,struct,sys; b=open(sys.argv[1],'rb').read(); n=struct.unpack_from('<I',b,12)[0]; j=json.loads(b[20:20+n]); print($2)" "$1"
}

ensure_gltf_validator() {
  GLTF_TOOLS="$SRC/tests/tools/gltf"
  command -v node > /dev/null || { echo "SKIPPED: node is not installed (Debian: apt-get install nodejs npm)"; exit 77; }
  node -e 'process.exit(parseInt(process.versions.node) >= 18 ? 0 : 1)' ||
    { echo "SKIPPED: node $(node --version) is too old for the glTF validator (needs >= 18)"; exit 77; }
  if [ ! -f "$GLTF_TOOLS/node_modules/gltf-validator/package.json" ]; then
    command -v npm > /dev/null || { echo "SKIPPED: npm is not installed (Debian: apt-get install npm)"; exit 77; }
    echo "installing the glTF validator: npm ci --prefix $GLTF_TOOLS"
    npm ci --prefix "$GLTF_TOOLS" --no-audit --no-fund --loglevel=error > npm.log 2>&1 ||
      { tail -20 npm.log >&2; fail "npm ci in $GLTF_TOOLS failed (the first run needs the npm registry)"; }
  fi
}

# expect CODE PATTERN -- ARGS...: the command exits CODE and its stderr matches
# the extended regex PATTERN (case-insensitive); stdout/stderr in out.txt/err.txt.
expect() {
  local code="$1" pattern="$2"; shift 3
  set +e
  "$CITYATLAS" "$@" > out.txt 2> err.txt
  local rc=$?
  set -e
  [ $rc -eq "$code" ] || { cat err.txt >&2; fail "'$*': exit $rc, expected $code"; }
  grep -Eqi -- "$pattern" err.txt || { cat err.txt >&2; fail "'$*': stderr lacks '$pattern'"; }
  echo "ok: '$*' -> exit $rc: $(head -1 err.txt)"
}

# ensure_browser: Debian's chromium, node >= 18 and the npm packages of the web
# viewer (web/: three.js, 3DTilesRendererJS) and of the browser tests
# (tests/tools/browser: puppeteer-core, CesiumJS), installed with `npm ci` on
# first use. Skips (77) when chromium or node is missing: scripts/setup-deps
# installs both.
ensure_browser() {
  BROWSER_TOOLS="$SRC/tests/tools/browser"
  [ -x "${CHROMIUM:-/usr/bin/chromium}" ] || { echo "SKIPPED: chromium is not installed (Debian: apt-get install chromium; scripts/setup-deps does)"; exit 77; }
  command -v node > /dev/null || { echo "SKIPPED: node is not installed (Debian: apt-get install nodejs npm)"; exit 77; }
  node -e 'process.exit(parseInt(process.versions.node) >= 18 ? 0 : 1)' ||
    { echo "SKIPPED: node $(node --version) is too old for puppeteer-core 24 (needs >= 18)"; exit 77; }
  ensure_npm "$SRC/web"
  ensure_npm "$BROWSER_TOOLS"
}

# ensure_npm DIR: `npm ci` in DIR unless its node_modules is installed.
ensure_npm() {
  [ -f "$1/node_modules/.package-lock.json" ] && return 0
  command -v npm > /dev/null || { echo "SKIPPED: npm is not installed (Debian: apt-get install npm)"; exit 77; }
  echo "installing npm packages: npm ci --prefix $1"
  PUPPETEER_SKIP_DOWNLOAD=1 npm ci --prefix "$1" --no-audit --no-fund --loglevel=error > npm.log 2>&1 ||
    { tail -20 npm.log >&2; fail "npm ci in $1 failed (the first run needs the npm registry)"; }
}

# validate_export FOLDER WHAT: FOLDER/3dtiles/tileset.json against the official
# 3D Tiles 1.1 schemas (tests/tools/validate_3dtiles.py) and every GLB against
# the glTF validator (ensure_gltf_validator first): no error, no warning.
validate_export() {  # validate_export FOLDER WHAT
  "$PY" "$SRC/tests/tools/validate_3dtiles.py" "$1/3dtiles/tileset.json" > schema.txt 2>&1 || { head -20 schema.txt >&2; fail "$2: tileset.json is not valid 3D Tiles 1.1"; }
  local glbs
  glbs=$(find "$1/3dtiles/tiles" -name '*.glb' | wc -l)
  [ "$glbs" -gt 0 ] || fail "$2: no GLB written"
  set +e
  find "$1/3dtiles/tiles" -name '*.glb' -print0 | xargs -0 node "$GLTF_TOOLS/validate.mjs" --all > validate.txt 2>&1
  local rc=$?
  set -e
  # The validator (2.0.0-dev.3.10) does not know KHR_texture_basisu: exactly two
  # warnings per KTX2 image are expected (../shared/INTEROP.md), nothing else.
  "$PY" - validate.txt <<'PY' || { head -30 validate.txt >&2; fail "$2: the glTF validator reports errors or unexpected warnings"; }
import re, sys
bad, expected = [], 0
for line in open(sys.argv[1]):
    m = re.match(r"^(\S.*): (\d+) errors, (\d+) warnings", line)
    if m and int(m.group(2)):
        bad.append(line.strip())
    w = re.match(r"^\s+warning (\S+) (\S+): (.*)", line)
    if w:
        ktx2 = (w.group(1) == "VALUE_NOT_IN_LIST" and "'image/ktx2'" in w.group(3)) or w.group(1) == "IMAGE_UNRECOGNIZED_FORMAT"
        if ktx2: expected += 1
        else: bad.append(line.strip())
    e = re.match(r"^\s+error ", line)
    if e: bad.append(line.strip())
print("\n".join(bad[:20]), file=sys.stderr)
sys.exit(1 if bad else 0)
PY
  [ "$rc" -eq 0 ] || { head -30 validate.txt >&2; fail "$2: the glTF validator exits $rc"; }
  echo "ok: $2: $(tail -1 schema.txt | sed 's/.*: valid/valid/'); $glbs GLBs with 0 errors, 0 warnings (but the KTX2 ones expected: $(grep -c -E 'warning (VALUE_NOT_IN_LIST .*image/ktx2|IMAGE_UNRECOGNIZED_FORMAT)' validate.txt || true))"
}


# shared_inputs: the inputs of ../shared/data one build each, in $INPUTS (the
# FZK-Haus examples mix a local engineering CRS with EPSG:25832 files: one
# file at a time, without LOD0, 3 and 4, which have nothing we draw).
shared_inputs() {
  INPUTS=()
  local d f
  for d in "$1"/*/; do
    case "$(basename "$d")" in
      citygml2_fzk_haus_official_examples)
        for f in "$d"*.gml; do case "$f" in *LOD[034]*) ;; *) INPUTS+=("$f") ;; esac; done ;;
      *) INPUTS+=("$d") ;;
    esac
  done
}
