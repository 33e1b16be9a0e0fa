# Builds that are interrupted or run out of disk leave the previous complete
# folder or none, never a partial one, and the next run cleans up and succeeds:
#  1. what a kill in the swap gap leaves (<out>.old without <out>, a stale
#     <out>.partial) is undone by the next run, which finds the build up to date;
#  2. SIGKILL at random moments (3 here; benchmarks/kill_build.sh runs 20+);
#  3. a plan folder copied elsewhere is not merged (its build.json names the
#     folders the merge writes and removes: the original's): one error line,
#     exit 2, the original plan untouched and still merged where it is; and
#     a texture plan cut short is one error line naming it, exit 1;
#  4. a full disk (a 3 MB tmpfs; skipped where mounting is not allowed): one
#     error line, exit 1, the previous folder intact, no working folder left.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --buildings 30 --seed 2 --texture-size 64 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o out > /dev/null || fail "the first build failed"
hash0=$(json out/tileset.json "j['asset']['tilesetVersion']")

complete() {  # complete FOLDER: inspect passes on it
  "$CITYATLAS" inspect -q "$1" > inspect.txt 2>&1 || { cat inspect.txt >&2; fail "$1 is not a complete tile folder"; }
}
no_leftovers() {
  for s in .partial .old; do [ ! -e "out$s" ] || fail "out$s left behind"; done
}

# 1. The swap gap: the previous folder moved aside, the new one not yet in place.
mv out out.old
mkdir -p out.partial/geometry && echo junk > out.partial/geometry/half.glb
"$CITYATLAS" build -q town/town.gml -o out > rerun.txt || fail "the run after an interrupted swap failed"
grep -q "up to date" rerun.txt || fail "the restored build was not found up to date: $(cat rerun.txt)"
complete out
no_leftovers
check_eq "tilesetVersion after recovery" "$hash0" "$(json out/tileset.json "j['asset']['tilesetVersion']")"

# 2. SIGKILL at random moments of a rebuild (--force), then a clean rerun.
for trial in 1 2 3; do
  "$CITYATLAS" build -q --force town/town.gml -o out > /dev/null 2>&1 &
  pid=$!
  sleep "0.$((RANDOM % 9 + 1))"
  kill -9 "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  if [ -e out ]; then complete out; fi
  [ -e out ] || [ -e out.old ] || fail "trial $trial: neither out nor out.old after the kill"
  "$CITYATLAS" build -q town/town.gml -o out > /dev/null || fail "trial $trial: the run after the kill failed"
  complete out
  no_leftovers
  echo "ok: kill trial $trial: complete folder, clean rerun"
done

# 3. A copied plan folder. `build --slurm` with an sbatch that only answers a
# job id leaves the plan for jobs that never run.
mkdir -p stub && printf '#!/bin/sh\necho 7\n' > stub/sbatch && chmod +x stub/sbatch
PATH="$PWD/stub:$PATH" "$CITYATLAS" build -q town/town.gml -o planned --shard-triangles 1000 --slurm > /dev/null ||
  fail "build --slurm with a stub sbatch failed"
[ -f planned.partial/.plan/build.json ] || fail "no plan folder to copy"
cp -r planned.partial/.plan copied_plan
before=$(find planned.partial | sort | md5sum)
set +e
"$CITYATLAS" merge --run-shards -q copied_plan > copied.out 2> copied.err
rc=$?
set -e
check_eq "exit status of a merge of a copied plan" 2 "$rc"
check_eq "stderr lines of a merge of a copied plan" 1 "$(wc -l < copied.err)"
grep -q "^cityatlas merge: error: .*copied_plan: not the plan folder its build.json names" copied.err || fail "the error does not say why: $(cat copied.err)"
check_eq "the original plan after the refused merge" "$before" "$(find planned.partial | sort | md5sum)"
[ ! -e planned ] || fail "the refused merge wrote the original's output"
# A texture plan cut short (a copy that stopped): the merge reads the
# city's texture index from it and skips its promotions; both must be whole.
plan=planned.partial/.plan
for k in $(seq 0 $(( $(ls $plan/shard-*.tri | wc -l) - 1 ))); do
  "$CITYATLAS" shard -q --index "$k" $plan > /dev/null || fail "shard $k of the original plan failed"
done
cp $plan/texture_plan.bin texture_plan.whole
truncate -s -1 $plan/texture_plan.bin
set +e
"$CITYATLAS" merge -q $plan > cut.out 2> cut.err
rc=$?
set -e
check_eq "exit status of a merge of a cut texture plan" 1 "$rc"
check_eq "stderr lines of a merge of a cut texture plan" 1 "$(wc -l < cut.err)"
grep -q "texture_plan.bin: truncated" cut.err || fail "the error does not name the texture plan: $(cat cut.err)"
[ ! -e planned ] || fail "a merge of a cut texture plan wrote the output"
cp texture_plan.whole $plan/texture_plan.bin
echo "ok: a cut texture plan is refused: $(cat cut.err)"
"$CITYATLAS" merge --run-shards -q planned.partial/.plan > /dev/null || fail "the original plan no longer merges"
complete planned
echo "ok: a copied plan is refused: $(cat copied.err)"

# 4. A full disk.
mkdir -p small
if ! mount -t tmpfs -o size=3m tmpfs small 2> mount.txt; then
  echo "SKIPPED part 3: cannot mount a tmpfs here ($(head -1 mount.txt))"
  exit 0
fi
trap 'umount small 2>/dev/null || true' EXIT
"$CITYATLAS" synth -q --buildings 2 --seed 1 --texture-size 16 -o tiny > /dev/null
"$CITYATLAS" build -q tiny/town.gml -o small/out > /dev/null || fail "a tiny build does not fit 3 MB"
complete small/out
tiny_hash=$(json small/out/tileset.json "j['asset']['tilesetVersion']")
"$CITYATLAS" synth -q --buildings 60 --seed 3 --texture-size 256 -o big > /dev/null
set +e
"$CITYATLAS" build -q big/town.gml -o small/out > full.out 2> full.err
rc=$?
set -e
check_eq "exit status on a full disk" 1 "$rc"
check_eq "stderr lines on a full disk" 1 "$(wc -l < full.err)"
grep -qiE "no space left|disk full" full.err || fail "the error does not say the disk is full: $(cat full.err)"
grep -q "^cityatlas build: error: " full.err || fail "not the error format: $(cat full.err)"
complete small/out
check_eq "the previous folder survives a full disk" "$tiny_hash" "$(json small/out/tileset.json "j['asset']['tilesetVersion']")"
[ ! -e small/out.partial ] || fail "the working folder is left on the full disk"
echo "ok: full disk: $(cat full.err)"
