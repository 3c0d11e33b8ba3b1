#!/usr/bin/env bash
# The main job, from a fresh machine: the paper-style comparison of
# feed-scheduling methods on Lin et al.'s three shapes (∞, trident,
# butterfly) on the simulated FANUC-like machine: the table of Tables 10-12,
# the fuzzy scheduler vs a constant feed at equal cycle time and at equal
# max contour error, and plots, written to results/ (see host-sim/README.md).
# With arguments, runs host-sim with them instead, e.g.
#   ./scripts/run.sh schedule tests/data/lemniscate_2001.csv --f-max 5000
#   ./scripts/run.sh compare --machine fanuc-high-accuracy --out-dir results/hi
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
if [ $# -eq 0 ]; then set -- compare --out-dir results; fi
exec cargo run --release -q -p host-sim -- "$@"
