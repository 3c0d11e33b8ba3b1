#!/usr/bin/env bash
# Cargo runner (see .cargo/config.toml): runs a firmware ELF in QEMU's
# netduinoplus2 (STM32F405), with semihosting so that the firmware's exit
# status becomes QEMU's.
#
#   FW_TIMEOUT=secs   wall-clock limit (0 = none). Default: none for the
#                     firmware (it serves its link until stopped, Ctrl-C);
#                     600 for the images that end by themselves (`cost`,
#                     `numerics_cost`), where a hang is a failure
#   FW_SERIAL=spec    where USART1 goes (default
#                     tcp:127.0.0.1:7878,server=on,wait=off: connect a
#                     host there to stream a path; loopback only, so that
#                     no other machine can drive the simulated motion)
#   FW_ICOUNT=1       -icount shift=0 (1 instruction = 1 ns, deterministic);
#                     always on for the `cost` benchmark
#
# defmt output (semihosting) is decoded with defmt-print when it is
# installed (`cargo install defmt-print`), else saved raw next to the ELF.
set -euo pipefail
elf=$1
shift
name=$(basename "$elf")
if [ "$name" = fuzzy-firmware ]; then default_timeout_s=0; else default_timeout_s=600; fi
timeout_s=${FW_TIMEOUT:-$default_timeout_s}
serial=${FW_SERIAL:-tcp:127.0.0.1:7878,server=on,wait=off}
args=(-cpu cortex-m4 -machine netduinoplus2 -display none -monitor none
      -semihosting-config enable=on,target=native -serial "$serial")
if [ "${FW_ICOUNT:-0}" = 1 ] || [ "$name" = cost ]; then
    args+=(-icount shift=0)
fi
run() {
    if [ "$timeout_s" = 0 ]; then "$@"; else timeout --foreground -k 5 "$timeout_s" "$@"; fi
}
if [ "$name" = cost ]; then
    # Plain-text report, no defmt stream.
    exec > >(cat) 2>&1
    run qemu-system-arm "${args[@]}" -kernel "$elf" "$@"
    exit $?
fi
echo "[qemu-run] $name: USART1 on ${serial} (send a program with: cargo run --release -p sender -- send FILE --tcp 127.0.0.1:7878)" >&2
if command -v defmt-print >/dev/null; then
    set -o pipefail
    run qemu-system-arm "${args[@]}" -kernel "$elf" "$@" | defmt-print -e "$elf"
else
    echo "[qemu-run] defmt-print not installed: raw defmt log in $elf.defmt (cargo install defmt-print)" >&2
    run qemu-system-arm "${args[@]}" -kernel "$elf" "$@" > "$elf.defmt"
fi
