#!/usr/bin/env bash
# Every test, from a fresh machine: set-up, formatting, lints, the no_std
# build of the core for the Cortex-M4F, and all tests (including Octave
# evaluating our exported controller).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh

step() { printf '\n\033[1m== %s\033[0m\n' "$*"; }

step "format"
cargo fmt --all --check

step "lints"
cargo clippy --workspace --all-targets -q -- -D warnings

step "fuzzy-core builds for thumbv7em-none-eabihf (no_std, no alloc)"
cargo build -q -p fuzzy-core --target thumbv7em-none-eabihf --release

step "tests"
FUZZY_REQUIRE_OCTAVE=1 cargo test --workspace -q
