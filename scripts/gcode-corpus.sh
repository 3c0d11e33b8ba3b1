#!/usr/bin/env bash
# The read rate of the G-code reader over folders of programs: every
# .ngc .nc .gcode .tap .cnc .g file under the folders given is run through
# `host-sim toolpath`; the refusals are grouped by their message (line
# numbers, numbers and quoted text replaced by placeholders) and counted.
#   scripts/gcode-corpus.sh DIR...
# HOST_SIM names another host-sim binary (e.g. one built from an older
# commit); TIMEOUT (seconds, default 60) bounds each file; VERBOSE=1 lists
# each refused file with its message.
set -euo pipefail
if [ $# -eq 0 ]; then
    echo "usage: $0 DIR..." >&2
    exit 2
fi
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${HOST_SIM:-}"
if [ -z "$bin" ]; then
    (cd "$root" && cargo build --release -q -p host-sim)
    bin="$root/target/release/host-sim"
fi
tmo="${TIMEOUT:-60}"
classes="$(mktemp)"
trap 'rm -f "$classes"' EXIT
total=0
read_ok=0
while IFS= read -r -d '' f; do
    total=$((total + 1))
    if err=$(timeout "$tmo" "$bin" toolpath "$f" 2>&1 >/dev/null); then
        read_ok=$((read_ok + 1))
        continue
    fi
    rc=$?
    if [ "$rc" -eq 124 ]; then
        msg="timeout after ${tmo} s"
    else
        # The last line of the error chain without the file prefix; lines,
        # numbers and quoted text as placeholders so that one cause is one
        # class.
        msg=$(printf '%s\n' "$err" | grep -v '^warning' | tail -n 1 |
            sed -E 's/^error: //; s/^in [^:]*: //; s/line [0-9]+/line N/g' |
            sed -E 's/"[^"]*"/"…"/g; s/[-+]?[0-9]+(\.[0-9]+)?/#/g' | cut -c1-110)
    fi
    printf '%s\n' "$msg" >>"$classes"
    if [ "${VERBOSE:-0}" = 1 ]; then
        printf 'refused: %s: %s\n' "$f" "$msg"
    fi
done < <(find "$@" -type f \( -iname '*.ngc' -o -iname '*.nc' -o -iname '*.gcode' \
    -o -iname '*.tap' -o -iname '*.cnc' -o -iname '*.g' \) -print0 | sort -z)
echo "refusals by class:"
sort "$classes" | uniq -c | sort -rn
if [ "$total" -gt 0 ]; then
    # Files without motion (subroutine libraries, included fragments) are
    # not programs to read; the second rate leaves them out.
    still=$(grep -c 'has fewer than two distinct points' "$classes" || true)
    awk -v r="$read_ok" -v t="$total" -v s="$still" 'BEGIN {
        printf "read %d of %d programs (%.1f %%)\n", r, t, 100 * r / t
        if (t > s) printf "read %d of %d programs with motion (%.1f %%)\n", r, t - s, 100 * r / (t - s)
    }'
else
    echo "no G-code programs found"
fi
