# Evaluate all 15 DTU scans with `chamfer --protocol dtu`, one JSON per scan and a summary table.
#
#   make -f scripts/dtu.mk -j4 DTU_OFFICIAL=/data/DTU MESHES=out/meshes OUT=out/dtu
#
# MESHES holds one mesh per scan, named scan<N>.ply (already in millimetres), or, with CULL=1, the
# normalised-frame meshes of 2DGS / Triangle Splatting (`fuse_post.ply` renamed scan<N>.ply) together
# with DTU_SCENES=<root> holding each scan's cameras and mask/ for the mask-culling step
# (scripts/lib/dtu_layout.mk: scan<N>/ or dtu-scan<N>-neus/ as in ../shared/data; cameras_sphere.npz,
# else cameras.npz; CAMERAS_NAME forces one).
#
# Variables (defaults in brackets):
#   DTU_OFFICIAL [required]  the official evaluation data (Points/stl, ObsMask)
#   MESHES       [required]  the folder of scan<N>.ply
#   OUT          [dtu-eval]  output folder          SEED [0]  the downsampling shuffle's seed
#   CULL         [0]         1: cull with the cameras and masks of DTU_SCENES first
#   DTU_SCENES   [empty]     the NeuS / 2DGS scan folders (CULL=1)
#   CAMERAS_NAME [empty: cameras_sphere.npz, else cameras.npz, whichever exists]
#   SCANS        [24 37 40 55 63 65 69 83 97 105 106 110 114 118 122]  the scans to score
#   SPLATKIT     [$SPLATKIT_BIN, else `splatkit` on PATH, else `cargo run` of this checkout;
#                 scripts/lib/splatkit_bin.mk]
#   CHAMFER      [$(SPLATKIT) chamfer]  the chamfer command
# Needs: python3 (standard library only; scripts/dtu_summary.py).

SCRIPTS      := $(dir $(lastword $(MAKEFILE_LIST)))
include $(SCRIPTS)lib/splatkit_bin.mk
include $(SCRIPTS)lib/dtu_layout.mk

DTU_OFFICIAL ?= $(error set DTU_OFFICIAL to the official DTU evaluation data (Points/stl, ObsMask))
MESHES       ?= $(error set MESHES to the folder holding scan<N>.ply)
OUT          ?= dtu-eval
SEED         ?= 0
CULL         ?= 0
DTU_SCENES   ?=
CHAMFER      ?= $(SPLATKIT) chamfer
SCANS        ?= 24 37 40 55 63 65 69 83 97 105 106 110 114 118 122

JSONS := $(foreach s,$(SCANS),$(OUT)/scan$(s).json)

.PHONY: all clean
all: $(OUT)/summary.tsv

ifeq ($(CULL),1)
cull_args = --cull --cameras $(call dtu_cameras,$(1)) --masks $(call dtu_masks,$(1))
else
cull_args =
endif

$(OUT)/scan%.json: $(MESHES)/scan%.ply
	@mkdir -p $(OUT)/vis
	$(CHAMFER) --protocol dtu --scan $* --dataset-dir $(DTU_OFFICIAL) $< --seed $(SEED) \
	    $(call cull_args,$*) --vis-dir $(OUT)/vis --quiet --json=$@

# One row per scan (scan, mean_d2s, mean_s2d, overall) and the mean of each column.
$(OUT)/summary.tsv: $(JSONS)
	python3 $(SCRIPTS)dtu_summary.py $(JSONS) | tee $@

clean:
	rm -rf $(OUT)
