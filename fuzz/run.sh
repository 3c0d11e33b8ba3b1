#!/usr/bin/env bash
# Run every fuzz target for SECONDS (default 60) each, on stable Rust:
# `--sanitizer none` keeps libFuzzer's coverage-guided search without the
# nightly-only sanitizer flags. New inputs go to a temporary directory; the
# committed seed corpus (corpus/<target>/) is read, never written.
# A crash leaves its input in fuzz/artifacts/<target>/ and fails the run.
set -euo pipefail
cd "$(dirname "$0")"
seconds="${1:-60}"
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
for target in $(cargo fuzz list); do
    work="$(mktemp -d)"
    trap 'rm -rf "$work"' EXIT
    echo "fuzz: $target for ${seconds} s"
    cargo fuzz run --sanitizer none "$target" "$work" "corpus/$target" -- \
        -max_total_time="$seconds" -max_len=4096 -print_final_stats=1
    rm -rf "$work"
done
