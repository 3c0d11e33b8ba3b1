#!/usr/bin/env bash
# One-time set-up of a fresh Debian/Ubuntu machine with rustup (idempotent):
# the Cortex-M4F target, QEMU for the firmware tests (and python3 +
# binutils for the firmware's size/cost/panic checks), GNU Octave with its
# fuzzy-logic-toolkit for the cross-check of the exported controller.
# With --tests (./scripts/test.sh) also fuzzylite, which only a test needs
# (the FCL exports loaded by another tool), and what the real senders'
# tests need (tests/senders/run.sh): node with npm for cncjs, python3's
# venv and tkinter for bCNC; the main job does without them.
set -euo pipefail
for_tests=0
if [ "${1:-}" = "--tests" ]; then for_tests=1; fi

log() { printf '\033[1m[setup]\033[0m %s\n' "$*" >&2; }
as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
    log "rustup target add thumbv7em-none-eabihf"
    rustup target add thumbv7em-none-eabihf
fi
if ! rustup component list --installed 2>/dev/null | grep -q '^llvm-tools'; then
    log "rustup component add llvm-tools (size reports)"
    rustup component add llvm-tools || log "llvm-tools unavailable: size reports use the cargo-installed fallback"
fi

missing=()
command -v qemu-system-arm >/dev/null || missing+=(qemu-system-arm)
# Firmware checks (firmware/scripts/check.py): python3, addr2line.
command -v python3 >/dev/null || missing+=(python3)
command -v addr2line >/dev/null || missing+=(binutils)
command -v octave-cli >/dev/null || missing+=(octave octave-fuzzy-logic-toolkit)
if command -v octave-cli >/dev/null && ! octave-cli --no-gui -q --eval 'pkg load fuzzy-logic-toolkit' >/dev/null 2>&1; then
    missing+=(octave-fuzzy-logic-toolkit)
fi
if [ "$for_tests" = 1 ]; then
    command -v fuzzylite >/dev/null || missing+=(fuzzylite)
    command -v node >/dev/null || missing+=(nodejs)
    command -v npm >/dev/null || missing+=(npm)
    python3 -c 'import ensurepip' 2>/dev/null || missing+=(python3-venv)
    python3 -c 'import tkinter' 2>/dev/null || missing+=(python3-tk)
fi
if [ ${#missing[@]} -gt 0 ]; then
    log "apt-get install ${missing[*]}"
    as_root apt-get update -qq
    DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
log "ready"
