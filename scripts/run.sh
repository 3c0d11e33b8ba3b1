#!/usr/bin/env bash
# The main job, from a fresh machine: schedule the feed along a path with the
# fixed-point scheduler and show the result (see README for the options).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
if [ $# -eq 0 ]; then set -- schedule tests/data/lemniscate_2001.csv; fi
exec cargo run --release -q -p host-sim -- "$@"
