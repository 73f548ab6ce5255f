# shellcheck shell=bash
# The one rule for which `splatkit` the shell scripts in scripts/ run; they source this file
# (`. "$(dirname "$0")/lib/splatkit_bin.sh"`). Its twin for the Makefiles is scripts/lib/splatkit_bin.mk:
# both choose in the same order. It sets `sk` to the first of
#   1. $SPLATKIT      a program path or name: the override these scripts read before SPLATKIT_BIN existed;
#   2. $SPLATKIT_BIN  the installed splatkit to use;
#   3. `splatkit` on PATH (e.g. after `cargo install --path .`);
#   4. REPO/target/release/splatkit, built first with `cargo build --release --bin splatkit` (needs cargo),
# and `sk_source` to the rule that chose it: SPLATKIT, SPLATKIT_BIN, PATH or cargo, and says which on
# stderr. Only rule 4 runs cargo.
# Run rather than sourced (`bash scripts/lib/splatkit_bin.sh`) it builds nothing and prints
# "SOURCE<TAB>PROGRAM", then "build:<TAB>COMMAND" when rule 4 would build.

splatkit_bin_choose() {
    local repo
    repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
    sk_build=()
    if [ -n "${SPLATKIT:-}" ]; then
        sk=$SPLATKIT sk_source=SPLATKIT
    elif [ -n "${SPLATKIT_BIN:-}" ]; then
        sk=$SPLATKIT_BIN sk_source=SPLATKIT_BIN
    elif sk=$(type -P splatkit); then
        sk_source=PATH
    else
        sk="$repo/target/release/splatkit" sk_source=cargo
        sk_build=(cargo build --release --quiet --manifest-path "$repo/Cargo.toml" --bin splatkit)
        return 0
    fi
    if ! type -P "$sk" >/dev/null; then
        echo "splatkit_bin.sh: $sk_source=$sk is not an executable program" >&2
        return 2
    fi
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then
    splatkit_bin_choose || exit
    printf '%s\t%s\n' "$sk_source" "$sk"
    [ ${#sk_build[@]} -eq 0 ] || printf 'build:\t%s\n' "${sk_build[*]}"
else
    splatkit_bin_choose || exit
    echo "$(basename "$0"): splatkit: $sk (from $sk_source)" >&2
    if [ ${#sk_build[@]} -gt 0 ]; then
        "${sk_build[@]}" || exit
    fi
fi
