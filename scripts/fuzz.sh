#!/usr/bin/env bash
# Seeded mutation fuzzing of every file reader (examples/fuzz_readers.rs) under a
# 2 GB address-space limit, so a reader that allocates what a hostile header declares
# aborts the run (the input is left in OUT/current-READER.bin) instead of passing.
#
#   scripts/fuzz.sh [CPU_SECONDS_PER_READER] [OUT] [SEED] [READERS]
#       defaults: 60, /dev/shm/splatkit-fuzz (fuzz-out where there is no /dev/shm), 1, all
#       READERS: comma-separated, e.g. ply,gltf (names: see readers() in the example)
#
# The budget is CPU time, so runs sharing the machine still give each reader its share.
# OUT holds the input under test, rewritten every execution: keep it on a tmpfs (a disk
# makes the run about ten times slower).
# BIG_ALLOC (bytes, default 268435456): inputs that make one allocation this large are
# saved as OUT/big-READER-N.bin even where the machine has the memory (an address-space
# abort depends on the core count); `--replay FILE --reader R --big-alloc N` shows where.
# Prints one JSON line per reader (executions, Ok / Err, crashes, big allocations, CPU and wall seconds);
# crashing inputs are saved as OUT/crash-READER-N.bin and replayed with
#   target/release/examples/fuzz_readers --replay FILE --reader READER
# It builds examples/fuzz_readers with cargo (an example, never installed); it runs no splatkit
# command, so SPLATKIT_BIN plays no part. Needs: cargo; no Python.
set -euo pipefail
cd "$(dirname "$0")/.."
default_out=fuzz-out
[ -d /dev/shm ] && default_out=/dev/shm/splatkit-fuzz
secs="${1:-60}"; out="${2:-$default_out}"; seed="${3:-1}"; readers="${4:-}"
cargo build --release -q --example fuzz_readers
ulimit -v $((2 * 1024 * 1024))
args=(--seconds "$secs" --out "$out" --seed "$seed" --big-alloc "${BIG_ALLOC:-268435456}")
[ -n "$readers" ] && args+=(--reader "$readers")
exec target/release/examples/fuzz_readers "${args[@]}"
