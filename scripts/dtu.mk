# Evaluate all 15 DTU scans with `chamfer --protocol dtu`, one JSON per scan and a summary table.
#
#   make -f scripts/dtu.mk -j4 DTU_OFFICIAL=/data/DTU MESHES=out/meshes OUT=out/dtu
#
# MESHES holds one mesh per scan, named scan<N>.ply (already in millimetres), or, with CULL=1, the
# normalised-frame meshes of 2DGS / Triangle Splatting (`fuse_post.ply` renamed scan<N>.ply) together
# with DTU_SCENES=<root> holding scan<N>/cameras.npz and scan<N>/mask/ for the mask-culling step.
# SEED makes the downsampling shuffle reproducible; CHAMFER is the binary to use.

DTU_OFFICIAL ?= $(error set DTU_OFFICIAL to the official DTU evaluation data (Points/stl, ObsMask))
MESHES       ?= $(error set MESHES to the folder holding scan<N>.ply)
OUT          ?= dtu-eval
SEED         ?= 0
CULL         ?= 0
DTU_SCENES   ?=
CHAMFER      ?= cargo run --release --quiet --bin chamfer --
SCANS        := 24 37 40 55 63 65 69 83 97 105 106 110 114 118 122

JSONS := $(foreach s,$(SCANS),$(OUT)/scan$(s).json)

.PHONY: all clean
all: $(OUT)/summary.tsv

ifeq ($(CULL),1)
cull_args = --cull --cameras $(DTU_SCENES)/scan$(1)/cameras.npz --masks $(DTU_SCENES)/scan$(1)/mask
else
cull_args =
endif

$(OUT)/scan%.json: $(MESHES)/scan%.ply
	@mkdir -p $(OUT)/vis
	$(CHAMFER) --protocol dtu --scan $* --dataset-dir $(DTU_OFFICIAL) $< --seed $(SEED) \
	    $(call cull_args,$*) --vis-dir $(OUT)/vis --quiet --json=$@

# One row per scan (scan, mean_d2s, mean_s2d, overall) and the mean of each column.
$(OUT)/summary.tsv: $(JSONS)
	python3 $(dir $(lastword $(MAKEFILE_LIST)))dtu_summary.py $(JSONS) | tee $@

clean:
	rm -rf $(OUT)
