#!/usr/bin/env bash
# Benchmark: the build-time ray caster (issue 19; atlas/raycast.h, Embree 3):
# rays per second and seconds per million surface points of the sky-view
# factor at N cosine-weighted directions, on a synthetic town, at 1 thread
# and at every core; then the sky view as a computed texture on the town's
# atlas tree (seconds per million computed texels through the texel ->
# surface map, on whole leaves until TEXELS; BC4 bytes against photo atlas
# bytes). Not a test: the figures depend on the machine.
# Usage: benchmarks/raycast.sh [BUILDINGS=10000] [DIRECTIONS=256] [POINTS=100000] [TEXELS=1000000]
# Writes out/benchmarks/raycast-<buildings>.json.
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-10000}"; DIRS="${2:-256}"; POINTS="${3:-100000}"; TEXELS="${4:-1000000}"
[ -n "${CITYATLAS_NO_BUILD:-}" ] || ./scripts/build > /dev/null
mkdir -p out/benchmarks
./build/tests/tools/raycast_bench "$N" "$DIRS" "$POINTS" "$TEXELS" "out/benchmarks/raycast-$N.json"
echo "wrote out/benchmarks/raycast-$N.json"
