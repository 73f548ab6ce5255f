#!/usr/bin/env bash
# Runs every `cargo bench` of this tree and of another checkout (an older commit) alternately on
# the same machine, so that a change is judged against the code before it on the same host and day
# (the host's speed drifts by up to 2x between sessions; see docs/BENCHMARKS.md).
#
#   scripts/bench_ab.sh BASE_DIR [OUT] [BENCH...]
#   e.g. git worktree add ../base 5958810 && (cd ../base && cargo bench --no-run)
#        scripts/bench_ab.sh ../base target/bench-ab
#
# BENCH defaults to all: ply_io chamfer poisson render splat2points tsdf refine bake_texture train.
# Each bench runs base, new, base, new (REPS=2 pairs by default; REPS=1 for one pair) with
# RAYON_NUM_THREADS=2 (ply_io: 1, as scripts/bench_io.sh). Logs: OUT/NAME.{base,new}.N.txt.
# Compare the timing lines by eye and the output lines (counts, metrics) with
# `diff <(grep -v ' s\b' OUT/NAME.base.1.txt) ...`; scripts/compare_builds.sh checks output files.
# Nothing else should run meanwhile (pause other jobs with SIGSTOP).
# environment: REPS [2]  base/new pairs per bench.
# It builds and runs both trees' benches with cargo on purpose (those trees are what it measures), so an
# installed splatkit (SPLATKIT_BIN, PATH) plays no part. Needs: cargo, git, bc; no Python.
set -euo pipefail
base=$(realpath "${1:?usage: $0 BASE_DIR [OUT] [BENCH...]}")
cd "$(dirname "$0")/.."
new=$(pwd)
out=$(realpath -m "${2:-target/bench-ab}")
shift $(( $# >= 2 ? 2 : 1 ))
benches=("$@")
[[ ${#benches[@]} -eq 0 ]] && benches=(ply_io chamfer poisson render splat2points tsdf refine bake_texture train)
reps=${REPS:-2}
mkdir -p "$out"
for dir in "$base" "$new"; do
    (cd "$dir" && cargo bench --no-run -q >/dev/null 2>&1) || { echo "cannot build the benches in $dir" >&2; exit 2; }
done
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); base $(git -C "$base" rev-parse --short HEAD), new $(git rev-parse --short HEAD)$(git diff --quiet || echo '+changes')" | tee "$out/machine.txt"
for b in "${benches[@]}"; do
    args=()
    threads=2
    case $b in
        ply_io) threads=1 ;;
        poisson) args=(depths) ;;
        train) args=(--iters 5) ;;
    esac
    for ((i = 1; i <= reps; i++)); do
        for side in base new; do
            dir=$base; [[ $side == new ]] && dir=$new
            log="$out/$b.$side.$i.txt"
            start=$(date +%s.%N)
            (cd "$dir" && RAYON_NUM_THREADS=$threads cargo bench -q --bench "$b" -- "${args[@]}") >"$log" 2>&1 ||
                { echo "$b ($side) failed: $log" >&2; exit 2; }
            printf '%-13s %-4s run %d: %6.1f s wall\n' "$b" "$side" "$i" "$(echo "$(date +%s.%N) - $start" | bc)"
        done
    done
done
