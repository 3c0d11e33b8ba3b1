#!/usr/bin/env bash
# The comparison (host-sim compare) over real public G-code programs that
# are on this machine but not in the repository (their licences and origin
# keep them out of it):
#   - the programs in the folder named by HOST_SIM_GCODE_CORPUS, or else
#   - LinuxCNC's nc_files/, extracted into a temporary folder from a local
#     bare git mirror of LinuxCNC (HOST_SIM_LINUXCNC_GIT, default
#     /work/.mirror/LinuxCNC+linuxcnc/repo).
# Programs host-sim refuses (expressions, O-words, canned cycles, ...) or
# with fewer than 100 points are listed and skipped. Without either source
# it says so and exits 0. Results go to results/real (or $OUT_DIR); extra
# arguments go to `host-sim compare`, e.g.
#   OUT_DIR=/tmp/real ./scripts/real-gcode.sh --no-pareto --no-plots
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p host-sim
bin=target/release/host-sim
src="${HOST_SIM_GCODE_CORPUS:-}"
if [ -z "$src" ]; then
    git_dir="${HOST_SIM_LINUXCNC_GIT:-/work/.mirror/LinuxCNC+linuxcnc/repo}"
    if ! git --git-dir="$git_dir" rev-parse -q --verify HEAD >/dev/null 2>&1; then
        echo "no real programs here (set HOST_SIM_GCODE_CORPUS or HOST_SIM_LINUXCNC_GIT): skipped"
        exit 0
    fi
    src="$(mktemp -d)"
    trap 'rm -rf "$src"' EXIT
    git --git-dir="$git_dir" ls-tree -r --name-only HEAD nc_files/ | grep -E '\.(ngc|nc)$' |
        while read -r f; do
            git --git-dir="$git_dir" show "HEAD:$f" > "$src/$(echo "$f" | tr '/' '_')" 2>/dev/null || true
        done
    echo "LinuxCNC nc_files from $git_dir ($(git --git-dir="$git_dir" rev-parse --short HEAD))"
fi
args=()
for f in "$src"/*; do
    [ -f "$f" ] || continue
    if n=$(timeout 60 "$bin" toolpath "$f" 2>/dev/null | wc -l) && [ "$n" -ge 102 ]; then
        args+=(--path "$f")
    else
        echo "skipped: $(basename "$f")"
    fi
done
if [ ${#args[@]} -eq 0 ]; then
    echo "no program host-sim reads: nothing to compare"
    exit 0
fi
exec "$bin" compare "${args[@]}" --out-dir "${OUT_DIR:-results/real}" "$@"
