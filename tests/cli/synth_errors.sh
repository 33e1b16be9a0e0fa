# Bad options and unusable output locations: one clear line, the documented
# exit code, and never a half-written output folder.
source "$(dirname "$0")/lib.sh" "$@"

expect 2 "not a projected CRS" -- synth --crs 4326 -o a
expect 2 "not a CRS known" -- synth --crs 999999 -o a
expect 2 "buildings" -- synth --buildings 0 -o a
expect 2 "lod" -- synth --lod 3 -o a
expect 2 "give one" -- synth --extreme --origin 1,2 -o a
expect 2 "output" -- synth
expect 2 "subcommand" -- frobnicate
for d in a; do [ ! -e "$d" ] || fail "a rejected command created $d"; done
echo "ok: rejected commands created nothing"

mkdir keep && echo precious > keep/file
expect 1 "already exists" -- synth --buildings 2 --texture-size 16 -q -o keep
check_eq "existing folder untouched" "precious" "$(cat keep/file)"
"$CITYATLAS" synth --buildings 2 --texture-size 16 -q --overwrite -o keep > /dev/null
[ -f keep/truth.json ] && [ ! -e keep/file ] || fail "--overwrite did not replace the folder"
echo "ok: --overwrite replaces the folder"

# A place that cannot be written: a path under a regular file.
echo x > plainfile
expect 1 "plainfile" -- synth --buildings 2 --texture-size 16 -q -o plainfile/town
# Unwritable parent (skip when running as a user who can write anywhere, e.g. root).
mkdir ro && chmod 500 ro
if [ ! -w ro ]; then
  expect 1 "ro/town" -- synth --buildings 2 --texture-size 16 -q -o ro/town
fi
chmod 700 ro
ls -A ro plainfile 2>/dev/null | grep -q partial && fail "a .partial folder was left behind"
echo "ok: no half-written folders"

# Capture first: `grep -q` closes the pipe early and pipefail would report the writer's SIGPIPE.
top_help=$("$CITYATLAS" --help)
synth_help=$("$CITYATLAS" synth --help)
version=$("$CITYATLAS" --version)
grep -q synth <<<"$top_help" || fail "--help does not list synth"
grep -q -- "--extreme" <<<"$synth_help" || fail "synth --help lacks --extreme"
grep -q "^cityatlas [0-9]" <<<"$version" || fail "--version"
echo "ok: --help and --version"
