#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Runs the GLFW window smoke program under a virtual X server. Usage:
# window_smoke.sh PROGRAM. Exit 77 (skipped) when xvfb-run is not installed.
set -euo pipefail
program=${1:?usage: window_smoke.sh PROGRAM}
if ! command -v xvfb-run >/dev/null 2>&1; then
  echo "xvfb-run not installed: skipped"
  exit 77
fi
exec xvfb-run -a -s "-screen 0 640x480x24" "$program"
