#!/usr/bin/env bash
# Benchmark: the speed / size / accuracy trade of `cityatlas build`'s knobs,
# measured and drawn. On a synthetic town (200 buildings, the demo's) and, when
# the team's ../shared is beside the clone, on one real dataset (the Berlin VCS
# export), it builds at the defaults and with one knob changed at a time:
# d_min (x1/4 .. x4 of the chosen value), atlas size (256, 1024), BC quality
# (best), position bits (11, 16 with the per-node error target off); and
# renders each build headless along the default camera path with --wait
# (every frame's ideal set loaded) at 480x270, plus the default build at tau
# 0.5, 2 and 4. Records build time, peak RSS, bytes by kind, the texture
# ratio, image error (PSNR of every frame against the original-texture
# rendering of the same data and parameters built with --originals all,
# `render --mode original`: the atlas tree's own error; the encoders' own
# errors, BC PSNR and position error, come from the build report) and nodes drawn.
# Usage: benchmarks/trade.sh [DATASETS=all|town|berlin] [--docs] [--plot-only]
#   --docs also copies the plots (small PNGs) into docs/ for the README;
#   --plot-only redraws them from the last out/benchmarks/trade.json.
# Writes out/benchmarks/trade.json and out/benchmarks/trade-*.png; the tile
# folders stay under out/benchmarks/trade/ for a look. Installs Debian's
# python3-matplotlib when it is missing (as scripts/setup-deps does).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build > /dev/null
if ! /usr/bin/python3 -c "import matplotlib" 2> /dev/null; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "trade.sh: installing python3-matplotlib (the plots)" >&2
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends python3-matplotlib > /dev/null
fi
exec /usr/bin/python3 benchmarks/trade.py "$@"
