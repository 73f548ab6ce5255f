#!/usr/bin/env bash
# Training iterations per second + stage profile (benches/train.rs) on 2
# threads. Usage: scripts/bench_train.sh OUT.txt [BENCH ARGS...]
# e.g. scripts/bench_train.sh train.txt triangles/800x600 --iters 10
# (SPLATKIT_BENCH_QUICK=1 or --quick: a tiny smoke run).
# It runs `cargo bench` of this checkout on purpose (its code is what it measures), so an installed
# splatkit (SPLATKIT_BIN, PATH) plays no part. Needs: cargo; no Python.
set -euo pipefail
out=${1:?usage: $0 OUT.txt [--quick] [--iters N] [CASE FILTER...]}
shift
cd "$(dirname "$0")/.."
cargo bench --bench train --no-run
RAYON_NUM_THREADS=2 cargo bench --bench train -- "$@" 2>&1 | tee "$out"
