#!/usr/bin/env bash
# The main job, from a fresh machine: the paper-style comparison of
# feed-scheduling methods on Lin et al.'s three shapes (∞, trident,
# butterfly), our CAM programs (tests/data/cam) and the shared real programs
# (../shared/gcode) on the simulated FANUC-like machine: the table of Tables
# 10-12, the fuzzy scheduler vs a constant feed and fuzzy + planner vs our
# planner alone, a Grbl-like and a LinuxCNC-like planner at equal cycle time
# and at equal max contour error, the Pareto sweep, and plots, written to
# results/ (see host-sim/README.md; about a minute on 2 cores).
# With arguments, runs host-sim with them instead, e.g.
#   ./scripts/run.sh schedule tests/data/lemniscate_2001.csv --f-max 5000
#   ./scripts/run.sh compare --machine fanuc-high-accuracy --out-dir results/hi
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
if [ $# -eq 0 ]; then set -- compare --out-dir results; fi
exec cargo run --release -q -p host-sim -- "$@"
