# Atlases that BC encodes exactly (flat-coloured facades seen from far enough:
# infinite PSNR) once made the writer put `"psnr_db": null` into tileset.json,
# which its own schema refused and the client's reader then rejected.
# Now: null is the documented record of an exact atlas, the folder inspects
# clean, the client opens it, and the build report counts such atlases apart
# from the PSNR statistics.
source "$(dirname "$0")/lib.sh" "$@"
"$CITYATLAS" synth -q --buildings 60 --seed 4 --texture-size 64 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o out --d-min 30 > /dev/null
exact=$(json out/build_report.json "j['errors']['atlas_files_exact']")
[ "$exact" -gt 0 ] || fail "this town is meant to have exactly encoded atlases (got $exact)"
nulls=$(grep -c '"psnr_db": null' out/tileset.json)
check_eq "atlases recorded as exact in tileset.json" "$exact" "$nulls"
"$CITYATLAS" inspect -q out > inspect.txt 2>&1 || { head -5 inspect.txt >&2; fail "inspect refuses the folder"; }
mean=$(json out/build_report.json "j['errors']['atlas_psnr_db_mean']")
"$PY" -c "import sys,math; m=float(sys.argv[1]); sys.exit(0 if math.isfinite(m) and m > 20 else 1)" "$mean" ||
  fail "atlas_psnr_db_mean $mean is not the mean over the inexact atlases"
# The client's reader opens it: one frame from the root.
"$CITYATLAS" render out --size 64x48 -o frame.png -q > render.txt 2>&1 || { cat render.txt >&2; fail "render refuses the folder"; }
echo "ok: $exact exact atlases recorded as null; inspect clean; PSNR mean $mean dB over the others; the client opens it"
