#!/usr/bin/env bash
# Seeded fuzzing of the commands (examples/fuzz_commands.rs): random flag values, mutated
# input sets and hostile output places, each case run as `splatkit COMMAND …` in a fresh work
# folder under a 2 GB address-space limit (RLIMIT_AS) and a wall timeout.
#
#   scripts/fuzz_commands.sh [CPU_SECONDS_PER_COMMAND] [OUT] [SEED] [COMMANDS]
#       defaults: 60, /dev/shm/splatkit-fuzz-commands (fuzz-commands-out where there is
#       no /dev/shm), 1, all
#       COMMANDS: comma-separated, e.g. render,clean (info, prune-triangles, export-off,
#       chamfer, poisson, decimate, clean, splat2points, render, tsdf-fuse, bind-gaussians,
#       refine, bake-texture, train, demo)
#   environment: PROFILE=release|debug (default release: which target/PROFILE/splatkit is
#       fuzzed), TIMEOUT=seconds of wall time before a run counts as a hang (default 60)
#
# The budget is CPU time of the child processes, so runs sharing the machine still give
# each command its share. Prints a table per command (executions, ok, error, each failure
# class, CPU seconds) and the distinct failure kinds, also in OUT/summary.md; each failing
# case is kept in OUT/failures/COMMAND-N/ with cmd.txt, stderr.txt, classes.txt, the
# work folder as it was before the run, and replay.sh (runs it again under the same limits).
# It builds and fuzzes this checkout's target/PROFILE/splatkit on purpose (that build is what it tests), so
# an installed splatkit (SPLATKIT_BIN, PATH) plays no part. Needs: cargo; no Python.
set -euo pipefail
cd "$(dirname "$0")/.."
default_out=fuzz-commands-out
[ -d /dev/shm ] && default_out=/dev/shm/splatkit-fuzz-commands
secs="${1:-60}"; out="${2:-$default_out}"; seed="${3:-1}"; commands="${4:-}"
profile="${PROFILE:-release}"
flag=(); [ "$profile" = release ] && flag=(--release)
cargo build "${flag[@]}" -q --bin splatkit --example fuzz_commands
args=(--bin "target/$profile/splatkit" --seconds "$secs" --out "$out" --seed "$seed"
      --timeout "${TIMEOUT:-60}")
[ -n "$commands" ] && args+=(--command "$commands")
exec "target/$profile/examples/fuzz_commands" "${args[@]}"
