# Sourced by benchmarks that build a synthetic town: `synth_town N PX` sets
# CITYATLAS (./build/cli/cityatlas, built first, unless the caller gave one)
# and TOWN, the folder of the town of N LOD2 buildings with PX px facades
# (seed 1), made once under out/benchmarks/ and not timed.
synth_town() {
  if [ -z "${CITYATLAS:-}" ]; then ./scripts/build > /dev/null; fi
  export CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
  mkdir -p out/benchmarks
  TOWN="out/benchmarks/synth-$1-$2"
  if [ ! -f "$TOWN/truth.json" ]; then
    "$CITYATLAS" synth --buildings "$1" --texture-size "$2" --lod 2 --seed 1 -q --overwrite -o "$TOWN" > /dev/null
  fi
}
