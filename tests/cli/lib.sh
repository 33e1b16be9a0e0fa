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
# XPath count over a CityGML file, namespace-agnostic
xcount() { xmllint --xpath "count($2)" "$1"; }
