# `build --slurm` on a one-node Slurm cluster on loopback (tests/tools/slurm/
# cluster.sh: slurmctld, slurmd and munged started here with a config in a
# private folder, stopped by pid):
#  1. the shards as a job array and the merge as a job after it give the same
#     folder, byte for byte (build_report.json aside), as the local build with
#     worker processes; the report says 4+ shards and lists their costs;
#     one shard (the default for a small town) through the jobs gives the
#     single-process build's folder, with --format both its 3D Tiles export too;
#  2. without --wait the build returns at once with the job ids, and the folder
#     appears when the merge job ends;
#  3. a failing shard job: the merge job is cancelled (afterok never holds),
#     `build --wait` exits 1 naming the merge job, no output folder appears.
# Skipped (77) where slurm-wlm or munge is missing.
source "$(dirname "$0")/lib.sh" "$@"
cluster="$SRC/tests/tools/slurm/cluster.sh"
reason=$("$cluster" available) || { echo "SKIPPED: $reason"; exit 77; }

# munged wants short socket paths and every folder above it traversable.
cdir=$(mktemp -d /tmp/ca-slurm.XXXXXX)
chmod 711 "$cdir"
trap '"$cluster" stop "$cdir/c" || true; rm -rf "$cdir"' EXIT
eval "$("$cluster" start "$cdir/c")"
[ -n "${SLURM_CONF:-}" ] || fail "the cluster printed no SLURM_CONF"

"$CITYATLAS" synth -q --buildings 60 --seed 5 --texture-size 64 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o local --shard-triangles 1000 --workers 2 > /dev/null || fail "the local build failed"

# 1. Submitted and waited for.
"$CITYATLAS" build -q town/town.gml -o onslurm --shard-triangles 1000 --slurm --wait > slurm.out 2> slurm.err ||
  { cat slurm.err >&2; cat onslurm.slurm/*.log >&2 || true; fail "build --slurm --wait failed"; }
cat slurm.out
grep -q "^Built onslurm on Slurm: shards job [0-9]* ([0-9]* tasks), merge job [0-9]*" slurm.out || fail "no job ids in the output"
diff -r -q --exclude build_report.json local onslurm > diff.txt || { head diff.txt >&2; fail "the Slurm build differs from the local one"; }
echo "ok: the Slurm build equals the local build ($(find onslurm -type f | wc -l) files)"
shards=$(json onslurm/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "expected at least 4 shards, got $shards"
json onslurm/build_report.json "[s['name'] for s in j['stages']]" | grep -q "'shards', 'merge'" || fail "the report lacks the shards and merge stages"
"$CITYATLAS" inspect -q onslurm > /dev/null || fail "inspect finds defects in the Slurm build"
[ ! -e onslurm.partial ] || fail "the working folder was left behind"

# Jobs that start in another directory (sbatch --chdir=/, as a cluster's
# defaults may): the input, textures and output were named relative to this
# one, and the jobs still find them (plan.json's working_directory).
"$CITYATLAS" build -q town/town.gml -o elsewhere --shard-triangles 1000 --slurm --wait --sbatch=--chdir=/ > /dev/null 2> elsewhere.err ||
  { cat elsewhere.err >&2; cat elsewhere.slurm/*.log >&2 || true; fail "build --slurm with jobs started in / failed"; }
diff -r -q --exclude build_report.json local elsewhere > diff.txt || { head diff.txt >&2; fail "jobs started in / give another folder"; }
[ "$(json elsewhere/build_report.json "j['warnings_total']")" = "$(json local/build_report.json "j['warnings_total']")" ] ||
  fail "jobs started in / warn more than the local build (textures not found?)"
echo "ok: jobs started in / (sbatch --chdir=/) give the local build's folder"

# One shard through the plan, a shard job and the merge is the single-process
# build, its 3D Tiles export included (the merge job exports after the merge).
"$CITYATLAS" build -q town/town.gml -o single --format both > /dev/null || fail "the single-shard build failed"
"$CITYATLAS" build -q town/town.gml -o one_job --format both --slurm --wait > /dev/null || fail "build --slurm --wait with one shard failed"
check_eq "shards of the default build" 1 "$(json one_job/build_report.json "j['shards']['count']")"
[ -f one_job/3dtiles/tileset.json ] || fail "the Slurm merge job wrote no 3D Tiles export"
diff -r -q --exclude build_report.json --exclude .cityatlas-cache single one_job > /dev/null || fail "one shard on Slurm differs from the single-process build"
echo "ok: one shard on Slurm (plan, shard job, merge) equals the single-process build, 3dtiles/ included ($(find one_job/3dtiles -type f | wc -l) files)"

# 2. Submitted without waiting: returns with the job ids; the folder comes later.
"$CITYATLAS" build -q town/town.gml -o later --shard-triangles 1000 --slurm > later.out || fail "build --slurm failed"
grep -q "^Submitted to Slurm: shards job [0-9]*" later.out || { cat later.out >&2; fail "no submission line"; }
merge=$(sed -n 's/.*merge job \([0-9]*\).*/\1/p' later.out)
for _ in $(seq 1 240); do
  [ -e later/tileset.json ] && [ -z "$(squeue -h -j "$merge" 2>/dev/null)" ] && break
  sleep 0.5
done
[ -e later/tileset.json ] || fail "the folder did not appear after the merge job ($merge)"
diff -r -q --exclude build_report.json local later > /dev/null || fail "the unwaited Slurm build differs"
echo "ok: without --wait: $(head -c 60 later.out)...; the folder appeared after job $merge"

# 3. A shard that fails: a texture of one shard's building made unreadable is
# only a warning, so the failure is a plan folder the jobs cannot read: the
# plan's triangles of shard 0 are truncated once the plan exists.
set +e
"$CITYATLAS" build -q town/town.gml -o broken --shard-triangles 1000 --slurm --sbatch=--begin=now+3 --wait \
  > broken.out 2> broken.err &
pid=$!
for _ in $(seq 1 200); do [ -e broken.partial/.plan/plan.json ] && break; sleep 0.05; done
truncate -s 100 broken.partial/.plan/shard-0.tri
wait "$pid"; rc=$?
set -e
check_eq "exit status of a build whose shard job failed" 1 "$rc"
grep -q "merge job [0-9]* did not succeed" broken.err || { cat broken.err >&2; fail "the error does not name the merge job"; }
grep -q "truncated" broken.slurm/shard-0.log || { cat broken.slurm/shard-0.log >&2; fail "the shard log does not say why"; }
[ ! -e broken ] || fail "a failed Slurm build produced an output folder"
echo "ok: a failing shard job: $(cat broken.err); its log: $(grep -m1 truncated broken.slurm/shard-0.log)"
