#!/usr/bin/env bash
# Every test, from a fresh machine: set-up, formatting, lints, the no_std
# build of the core and the controller logic for the Cortex-M4F, the firmware (build, lints, size,
# panic and cost checks in QEMU), and all tests (including Octave evaluating
# our exported controller, fuzzylite loading its FCL exports, and the
# firmware's system tests in QEMU).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh --tests

step() { printf '\n\033[1m== %s\033[0m\n' "$*"; }

step "format"
cargo fmt --all --check
(cd firmware && cargo fmt --check)

step "lints"
cargo clippy --workspace --all-targets -q -- -D warnings

step "fuzzy-core docs build without warnings"
RUSTDOCFLAGS="-D warnings" cargo doc -q -p fuzzy-core --no-deps

step "fuzzy-core and controller build for thumbv7em-none-eabihf (no_std, no alloc)"
cargo build -q -p fuzzy-core -p controller --target thumbv7em-none-eabihf --release

# The firmware is its own workspace with its own target dir and triple
# (firmware/.cargo/config.toml); a caller's CARGO_TARGET_DIR must not move it.
fw() { (cd firmware && env -u CARGO_TARGET_DIR "$@"); }

step "firmware: release build for thumbv7em-none-eabihf, lints"
fw cargo build --release -q
fw cargo clippy --release -q -- -D warnings
fw cargo clippy --release -q --no-default-features --features usb -- -D warnings

step "firmware: no reachable panic (panic-never link check)"
python3 firmware/scripts/check.py panic

step "firmware: flash <= 128 KiB, static RAM <= 32 KiB, <= +10 % on firmware/baseline/size.txt"
python3 firmware/scripts/check.py size

step "firmware: instructions per point and per tick in QEMU -icount, <= +10 % on firmware/baseline/cost.txt"
python3 firmware/scripts/check.py cost

step "tests (including the firmware in QEMU: tests/tests/firmware_qemu.rs; cncjs and bCNC: tests/tests/senders.rs)"
FUZZY_REQUIRE_OCTAVE=1 FUZZY_REQUIRE_FUZZYLITE=1 FUZZY_REQUIRE_QEMU=1 FUZZY_REQUIRE_SENDERS=1 \
    cargo test --workspace -q

step "fuzz: every target in fuzz/ for 60 s (cargo-fuzz on stable, --sanitizer none)"
fuzz/run.sh 60
