#!/usr/bin/env bash
# PLY I/O benchmark: a generated 1M-Gaussian SH-3 scene (248 MB) read and
# written from/to the page cache on one thread. Figures go to docs/BENCHMARKS.md.
# Usage: scripts/bench_io.sh [N_GAUSSIANS] [REPS]     (defaults 1000000 and 5)
# It runs `cargo bench` of this checkout on purpose (its code is what it measures), so an installed
# splatkit (SPLATKIT_BIN, PATH) plays no part. Needs: cargo; no Python.
set -euo pipefail
cd "$(dirname "$0")/.."
export SPLATKIT_BENCH_N="${1:-1000000}"
export SPLATKIT_BENCH_REPS="${2:-5}"
echo "machine: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
RAYON_NUM_THREADS=1 cargo bench --bench ply_io
