#!/usr/bin/env bash
# Real Grbl senders against `fuzzy-send serve` on the simulated controller:
# cncjs's server run headless and driven over its socket.io API (cncjs.js,
# through the pty), bCNC's Sender and GRBL1 classes without their window
# (bcnc.py, over TCP). Each sender gets a fresh `serve --sim`.
#
#   tests/senders/run.sh [cncjs] [bcnc] [cncjs-qemu]   # default: cncjs and bcnc
#
# cncjs-qemu: the same cncjs steps through `fuzzy-send --unix SOCK serve`
# against the firmware in QEMU (real time, no -icount), its probe input
# tripped through QEMU's USART2 socket ($FUZZY_FIRMWARE: the ELF, default
# firmware/target/thumbv7em-none-eabihf/release/fuzzy-firmware, built
# when missing).
#   tests/senders/run.sh --install        # only install them
#
# Installed into $FUZZY_SENDERS_CACHE (default target/senders/): cncjs by
# `npm ci` from package-lock.json, bCNC into a venv from requirements.txt,
# each again only when that file changes. Needs node >= 18 with npm, and
# python3 with venv and tkinter (scripts/setup.sh --tests installs them).
# $FUZZY_SEND: the fuzzy-send binary (default: built with --release).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
cache=${FUZZY_SENDERS_CACHE:-$root/target/senders}
sim_speed=5
# The simulated probe plate (machine z, mm) and the simulated axes' step.
plate_z=-3.25
# The simulated stock bCNC auto-levels against: z = Z + SX·x + SY·y.
stock=-3.25,0.02,-0.01

log() { printf '[senders] %s\n' "$*" >&2; }

install_cncjs() {
    local dir=$cache/node
    local major
    major=$(node -p 'process.versions.node.split(".")[0]')
    if [ "$major" -lt 18 ]; then
        log "cncjs 1.11 needs node >= 18; this is $(node --version)"
        return 1
    fi
    if cmp -s "$here/package-lock.json" "$dir/.installed-lock"; then return; fi
    log "npm ci (cncjs, socket.io-client) into $dir"
    rm -rf "$dir"
    mkdir -p "$dir"
    cp "$here/package.json" "$here/package-lock.json" "$dir/"
    # No install scripts: serialport's binding is prebuilt in its package.
    (cd "$dir" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error)
    cp "$here/package-lock.json" "$dir/.installed-lock"
}

install_bcnc() {
    local venv=$cache/bcnc-venv
    if cmp -s "$here/requirements.txt" "$venv/.installed-requirements"; then return; fi
    log "pip install bCNC into $venv"
    rm -rf "$venv"
    python3 -m venv "$venv"
    "$venv/bin/pip" install -q --disable-pip-version-check --no-deps -r "$here/requirements.txt"
    cp "$here/requirements.txt" "$venv/.installed-requirements"
}

if [ "${1:-}" = "--install" ]; then
    install_cncjs
    install_bcnc
    exit 0
fi

which=("$@")
if [ ${#which[@]} -eq 0 ]; then which=(cncjs bcnc); fi

if [ -z "${FUZZY_SEND:-}" ]; then
    log "cargo build --release -p sender"
    (cd "$root" && cargo build -q --release -p sender)
    FUZZY_SEND=${CARGO_TARGET_DIR:-$root/target}/release/fuzzy-send
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/fuzzy-senders.XXXXXX")
pids=()
cleanup() {
    # serve on SIGINT removes its pty link; the rest by their ids.
    for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
    for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
    rm -rf "$work"
}
trap cleanup EXIT

# Start `fuzzy-send serve` with these options; wait for its "Grbl 1.1
# front on" lines (its log: $work/serve-$name.log).
serve() {
    local name=$1
    shift
    local out=$work/serve-$name.log
    "$FUZZY_SEND" "${link[@]}" serve "$@" >"$out" 2>&1 &
    pids+=($!)
    for _ in $(seq 300); do
        if grep -q "connect a sender" "$out"; then return; fi
        if ! kill -0 "${pids[-1]}" 2>/dev/null; then break; fi
        sleep 0.1
    done
    log "fuzzy-send serve did not start:"
    cat "$out" >&2
    return 1
}

link=(--sim="$sim_speed")

free_port() {
    python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

failed=0
show_logs() {
    for f in "$work"/*.log; do
        log "---- $(basename "$f")"
        tail -n 40 "$f" >&2
    done
}

# In `f || failed=1`, set -e does not apply inside f: every step checks.
run_cncjs() {
    install_cncjs || return 1
    local pty=$work/ttyFUZZY
    serve cncjs --pty-link "$pty" --sim-probe-z "$plate_z" || return 1
    cncjs_steps "$pty" --plate "$plate_z" --step 0.01
}

# cncjs's server, headless, on a free port; then cncjs.js with ARGS.
cncjs_steps() {
    local pty=$1
    shift
    local http
    http=$(free_port)
    [ -n "$http" ] || return 1
    echo '{}' >"$work/cncrc"
    mkdir -p "$work/home"
    HOME=$work/home "$cache/node/node_modules/.bin/cncjs" -H 127.0.0.1 -p "$http" \
        -c "$work/cncrc" >"$work/cncjs-server.log" 2>&1 &
    pids+=($!)
    NODE_PATH=$cache/node/node_modules timeout 420 node "$here/cncjs.js" \
        --cncjs "http://127.0.0.1:$http" --port "$pty" "$@"
}

run_cncjs_qemu() {
    install_cncjs || return 1
    local elf=${FUZZY_FIRMWARE:-$root/firmware/target/thumbv7em-none-eabihf/release/fuzzy-firmware}
    if [ ! -f "$elf" ]; then
        log "cargo build --release (firmware)"
        (cd "$root/firmware" && cargo build -q --release) || return 1
    fi
    local sock=$work/usart1.sock inputs=$work/inputs.sock
    qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -display none -monitor none \
        -semihosting-config enable=on,target=native \
        -serial "unix:$sock,server=on,wait=off" -serial "unix:$inputs,server=on,wait=off" \
        -kernel "$elf" >"$work/qemu.log" 2>&1 &
    pids+=($!)
    for _ in $(seq 100); do
        if [ -S "$sock" ] && [ -S "$inputs" ]; then break; fi
        sleep 0.1
    done
    link=(--unix "$sock")
    local pty=$work/ttyFUZZY
    serve cncjs-qemu --pty-link "$pty" || return 1
    cncjs_steps "$pty" --trip "$inputs" --deadline 300
}

run_bcnc() {
    install_bcnc || return 1
    serve bcnc --no-pty --grbl-tcp 0 --sim-probe-z "$stock" || return 1
    local port
    port=$(sed -n 's/.*Grbl 1.1 front on tcp 127.0.0.1:\([0-9]*\).*/\1/p' "$work/serve-bcnc.log")
    [ -n "$port" ] || return 1
    mkdir -p "$work/home"
    HOME=$work/home timeout 420 "$cache/bcnc-venv/bin/python" "$here/bcnc.py" \
        --url "socket://127.0.0.1:$port" --plane="$stock" --step 0.01
}

for w in "${which[@]}"; do
    t0=$(date +%s.%N)
    case $w in
        cncjs) run_cncjs || failed=1 ;;
        bcnc) run_bcnc || failed=1 ;;
        cncjs-qemu) run_cncjs_qemu || failed=1 ;;
        *) log "unknown sender $w (cncjs, bcnc, cncjs-qemu)"; exit 2 ;;
    esac
    log "$w took $(python3 -c "import time; print(f'{time.time() - $t0:.1f}')") s"
    if [ "$failed" = 1 ]; then
        show_logs
        exit 1
    fi
done
