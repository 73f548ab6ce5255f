#!/usr/bin/env bash
# Seeded mutation fuzzing of every file reader (examples/fuzz_readers.rs) under a
# 2 GB address-space limit, so a reader that allocates what a hostile header declares
# aborts the run (the input is left in OUT/current-READER.bin) instead of passing.
#
#   scripts/fuzz.sh [SECONDS_PER_READER] [OUT] [SEED]     # defaults: 60 fuzz-out 1
#
# Prints one JSON line per reader (executions, Ok / Err, crashes); crashing inputs are
# saved as OUT/crash-READER-N.bin and replayed with
#   target/release/examples/fuzz_readers --replay FILE --reader READER
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-60}"; out="${2:-fuzz-out}"; seed="${3:-1}"
cargo build --release -q --example fuzz_readers
ulimit -v $((2 * 1024 * 1024))
exec target/release/examples/fuzz_readers --seconds "$secs" --out "$out" --seed "$seed"
