# A city's per-texture columns past their budget (core/paged_column.h: the
# texture table's entries, the plan's distances, counts and first shards, the
# texture index, the merge's blocks) go to scratch files by pages and come
# back through a small cache. CITYATLAS_TABLE_MEMORY_MB=0 gives every column
# the least budget (three pages of 16 records), so a town of a few hundred
# textures pages through all of them:
#  1. the single-process build, and a build of 4+ shards in two worker
#     processes, give the folders of the default budget, byte for byte
#     (build_report.json aside: timings);
#  2. the columns did go to disk: strace sees their scratch files made (the
#     check is skipped where ptrace is not allowed).
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --buildings 150 --seed 7 --texture-size 32 -o town > /dev/null
textures=$(json town/truth.json "j['textures']['count']")
[ "$textures" -ge 150 ] || fail "the town has $textures textures: too few to page (16 a page)"

"$CITYATLAS" build -q town/town.gml -o default > /dev/null || fail "the default build failed"
CITYATLAS_TABLE_MEMORY_MB=0 "$CITYATLAS" build -q town/town.gml -o paged > /dev/null || fail "the paged build failed"
diff -r -q --exclude build_report.json default paged > diff.txt || { head diff.txt >&2; fail "paged columns change the folder"; }
echo "ok: single process, paged columns: the default's folder ($(find paged -type f | wc -l) files, $textures textures)"

"$CITYATLAS" build -q town/town.gml -o sharded_default --shard-triangles 1500 --workers 2 > /dev/null ||
  fail "the default sharded build failed"
CITYATLAS_TABLE_MEMORY_MB=0 "$CITYATLAS" build -q town/town.gml -o sharded --shard-triangles 1500 --workers 2 > /dev/null ||
  fail "the paged sharded build failed"
shards=$(json sharded/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "expected at least 4 shards, got $shards"
diff -r -q --exclude build_report.json sharded_default sharded > diff.txt ||
  { head diff.txt >&2; fail "paged columns change the sharded folder"; }
echo "ok: $shards shards in 2 workers, paged columns: the default's folder"

if strace -f -qq -e trace=none true > /dev/null 2>&1; then
  CITYATLAS_TABLE_MEMORY_MB=0 strace -f -qq -e trace=openat -o trace.txt "$CITYATLAS" build -q town/town.gml -o traced \
    --shard-triangles 1500 --workers 2 > /dev/null || fail "the traced build failed"
  made=$(grep -c 'cityatlas-column-.*O_CREAT' trace.txt || true)
  [ "$made" -ge 3 ] || fail "expected the columns' scratch files (3 or more), strace saw $made"
  diff -r -q --exclude build_report.json sharded_default traced > /dev/null || fail "the traced build differs"
  echo "ok: $made column scratch files made (strace)"
  strace -f -qq -e trace=openat -o trace_default.txt "$CITYATLAS" build -q town/town.gml -o default2 > /dev/null ||
    fail "the traced default build failed"
  check_eq "column scratch files at the default budget" 0 "$(grep -c 'cityatlas-column-.*O_CREAT' trace_default.txt || true)"
else
  echo "SKIPPED part 2: strace cannot trace here"
fi
