# The one rule for which `splatkit` the Makefiles in scripts/ run; they include this file
# (`include $(SCRIPTS)lib/splatkit_bin.mk`). Its twin for the shell scripts is scripts/lib/splatkit_bin.sh:
# both choose in the same order. SPLATKIT is the first of
#   1. SPLATKIT as given (make SPLATKIT=... or the environment): the override these Makefiles read
#      before SPLATKIT_BIN existed; it may be a whole command (e.g. "cargo run --release --bin splatkit --");
#   2. $(SPLATKIT_BIN), the installed splatkit to use;
#   3. `splatkit` on PATH (e.g. after `cargo install --path .`);
#   4. SPLATKIT_FALLBACK [cargo run --release --quiet --manifest-path REPO/Cargo.toml --bin splatkit --]:
#      builds and runs this checkout (needs cargo). A Makefile may set it before the include.
# SPLATKIT_SOURCE names the rule that chose: SPLATKIT, SPLATKIT_BIN, PATH or fallback.
# `make -n -f scripts/NAME.mk ...` shows the commands without running them.

SPLATKIT_REPO     := $(abspath $(dir $(lastword $(MAKEFILE_LIST)))../..)
SPLATKIT_FALLBACK ?= cargo run --release --quiet --manifest-path $(SPLATKIT_REPO)/Cargo.toml --bin splatkit --

SPLATKIT_ON_PATH  := $(if $(strip $(SPLATKIT)$(SPLATKIT_BIN)),,$(shell command -v splatkit 2>/dev/null))

ifneq ($(strip $(SPLATKIT)),)
SPLATKIT_SOURCE := SPLATKIT
else ifneq ($(strip $(SPLATKIT_BIN)),)
SPLATKIT_SOURCE := SPLATKIT_BIN
SPLATKIT        := $(SPLATKIT_BIN)
else ifneq ($(SPLATKIT_ON_PATH),)
SPLATKIT_SOURCE := PATH
SPLATKIT        := $(SPLATKIT_ON_PATH)
else
SPLATKIT_SOURCE := fallback
SPLATKIT        := $(SPLATKIT_FALLBACK)
endif
