#!/usr/bin/env bash
# Regenerate the sample videos and their truth files (run from anywhere).
# Each command is exactly what made the files next to this script.
set -euo pipefail
cd "$(dirname "$0")/.."
PENDTRACK="${PENDTRACK:-.venv/bin/pendtrack}"
OUT=sample_videos

# 12na1: 12 cm tile, not launched, alley, trial 1 -- released near the top, 10 s
"$PENDTRACK" render --out "$OUT" --name-by-run-code --force -q --seconds 10 --tile 12 --alley --theta0 3.1 --seed 1
# 00ln1: no tile, launched (theta0 > pi, omega0 < 0: over the top once, as in the paper), no alley, trial 1 -- 4 s
"$PENDTRACK" render --out "$OUT" --name-by-run-code --force -q --seconds 4 --theta0 3.3 --omega0 -1.5 --seed 2
# 24nn1: 24 cm tile, not launched, no alley, trial 1 -- 4 s
"$PENDTRACK" render --out "$OUT" --name-by-run-code --force -q --seconds 4 --tile 24 --theta0 3.1 --seed 3

chmod a+r "$OUT"/*.truth.parquet  # atomic writes create owner-only files
