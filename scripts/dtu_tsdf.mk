# The DTU meshing recipe of 2DGS and Triangle Splatting for all 15 scans: fuse each trained scene's
# depth (rendered from the 49 training views, median depth) with the DTU TSDF settings, keep the largest
# cluster, cull with the masks and score with `chamfer --protocol dtu`; one JSON per scan and a summary.
#
#   make -f scripts/dtu_tsdf.mk -j4 SCENES=out/scenes DTU_SCENES=/data/dtu DTU_OFFICIAL=/data/DTU OUT=out/dtu
#   make -f scripts/dtu_tsdf.mk SCANS=24 SCENES=out/scenes DTU_SCENES=../shared/data DTU_OFFICIAL=/data/DTU
#
# SCENES holds one trained scene per scan: scan<N>.ply (3DGS / 2DGS Gaussians, or a triangle-soup PLY) or
# scan<N>.pt (Triangle Splatting `point_cloud_state_dict.pt`). DTU_SCENES holds the NeuS/2DGS layout per
# scan (scripts/lib/dtu_layout.mk): scan<N>/ or dtu-scan<N>-neus/ (as ../shared/data/dtu-scan24-neus), each
# with cameras_sphere.npz (or cameras.npz) and mask/. DTU_OFFICIAL holds the official evaluation data
# (Points/stl, ObsMask). Meshes land in OUT/meshes/scan<N>.ply (normalised frame, as 2DGS's fuse_post.ply);
# scores in OUT/scan<N>.json and OUT/summary.tsv.
#
# Views: the cameras at 1/DOWNSCALE of their size (default 2: DTU's 1600x1200 at 800x600, as 2DGS and
# Triangle Splatting train and render DTU with -r 2; the 1600x1200 masks are box-averaged to it).
#
# Variables (defaults in brackets):
#   SCENES, DTU_SCENES, DTU_OFFICIAL [required]  as above
#   OUT          [dtu-tsdf]   output folder       SEED [0]  chamfer's downsampling seed
#   DOWNSCALE    [2]          render size divisor
#   CAMERAS_NAME [empty: cameras_sphere.npz, else cameras.npz, whichever exists in the scan folder]
#   SCANS        [24 37 40 55 63 65 69 83 97 105 106 110 114 118 122]  the scans to mesh and score
#   SPLATKIT     [$SPLATKIT_BIN, else `splatkit` on PATH, else `cargo run` of this checkout;
#                 scripts/lib/splatkit_bin.mk]
# Needs: python3 (standard library only; scripts/dtu_summary.py).

SCRIPTS      := $(dir $(lastword $(MAKEFILE_LIST)))
include $(SCRIPTS)lib/splatkit_bin.mk
include $(SCRIPTS)lib/dtu_layout.mk

SCENES       ?= $(error set SCENES to the folder of trained scenes scan<N>.ply / scan<N>.pt)
DTU_SCENES   ?= $(error set DTU_SCENES to the folder holding scan<N>/cameras_sphere.npz (or cameras.npz) and scan<N>/mask)
DTU_OFFICIAL ?= $(error set DTU_OFFICIAL to the official DTU evaluation data (Points/stl, ObsMask))
OUT          ?= dtu-tsdf
SEED         ?= 0
DOWNSCALE    ?= 2
SCANS        ?= 24 37 40 55 63 65 69 83 97 105 106 110 114 118 122

JSONS := $(foreach s,$(SCANS),$(OUT)/scan$(s).json)

.PHONY: all clean
.SECONDARY:
all: $(OUT)/summary.tsv

# The scene file of scan N: .pt if present, else .ply.
scene_of = $(firstword $(wildcard $(SCENES)/scan$(1).pt) $(SCENES)/scan$(1).ply)

$(OUT)/meshes/scan%.ply:
	@mkdir -p $(OUT)/meshes
	$(SPLATKIT) tsdf-fuse $(call scene_of,$*) --cameras $(call dtu_cameras,$*) \
	    --masks $(call dtu_masks,$*) --downscale $(DOWNSCALE) --dtu --quiet --json=$(OUT)/meshes/scan$*.fuse.json -o $@

$(OUT)/scan%.json: $(OUT)/meshes/scan%.ply
	@mkdir -p $(OUT)/vis
	$(SPLATKIT) chamfer --protocol dtu --scan $* --dataset-dir $(DTU_OFFICIAL) $< --seed $(SEED) \
	    --cull --cameras $(call dtu_cameras,$*) --masks $(call dtu_masks,$*) \
	    --vis-dir $(OUT)/vis --quiet --json=$@

# One row per scan (scan, mean_d2s, mean_s2d, overall) and the mean of each column.
$(OUT)/summary.tsv: $(JSONS)
	python3 $(SCRIPTS)dtu_summary.py $(JSONS) | tee $@

clean:
	rm -rf $(OUT)
