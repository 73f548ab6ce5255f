# The DTU meshing recipe of 2DGS and Triangle Splatting for all 15 scans: fuse each trained scene's
# depth (rendered from the 49 training views, median depth) with the DTU TSDF settings, keep the largest
# cluster, cull with the masks and score with `chamfer --protocol dtu`; one JSON per scan and a summary.
#
#   make -f scripts/dtu_tsdf.mk -j4 SCENES=out/scenes DTU_SCENES=/data/dtu DTU_OFFICIAL=/data/DTU OUT=out/dtu
#
# SCENES holds one trained scene per scan: scan<N>.ply (3DGS / 2DGS Gaussians, or a triangle-soup PLY) or
# scan<N>.pt (Triangle Splatting `point_cloud_state_dict.pt`). DTU_SCENES holds the NeuS/2DGS layout per
# scan: scan<N>/cameras.npz (or cameras_sphere.npz) and scan<N>/mask/. DTU_OFFICIAL holds the official
# evaluation data (Points/stl, ObsMask). Meshes land in OUT/meshes/scan<N>.ply (normalised frame, as 2DGS's
# fuse_post.ply); scores in OUT/scan<N>.json and OUT/summary.tsv.
#
# Views: the cameras at 1/DOWNSCALE of their size (default 2: DTU's 1600x1200 at 800x600, as 2DGS and
# Triangle Splatting train and render DTU with -r 2; the 1600x1200 masks are box-averaged to it).
# SPLATKIT is the binary to use.

SCENES       ?= $(error set SCENES to the folder of trained scenes scan<N>.ply / scan<N>.pt)
DTU_SCENES   ?= $(error set DTU_SCENES to the folder holding scan<N>/cameras.npz and scan<N>/mask)
DTU_OFFICIAL ?= $(error set DTU_OFFICIAL to the official DTU evaluation data (Points/stl, ObsMask))
OUT          ?= dtu-tsdf
SEED         ?= 0
CAMERAS_NAME ?= cameras.npz
DOWNSCALE    ?= 2
SPLATKIT     ?= cargo run --release --quiet --bin splatkit --
SCANS        := 24 37 40 55 63 65 69 83 97 105 106 110 114 118 122

JSONS := $(foreach s,$(SCANS),$(OUT)/scan$(s).json)

.PHONY: all clean
.SECONDARY:
all: $(OUT)/summary.tsv

# The scene file of scan N: .pt if present, else .ply.
scene_of = $(firstword $(wildcard $(SCENES)/scan$(1).pt) $(SCENES)/scan$(1).ply)

$(OUT)/meshes/scan%.ply:
	@mkdir -p $(OUT)/meshes
	$(SPLATKIT) tsdf-fuse $(call scene_of,$*) --cameras $(DTU_SCENES)/scan$*/$(CAMERAS_NAME) \
	    --masks $(DTU_SCENES)/scan$*/mask --downscale $(DOWNSCALE) --dtu --quiet --json=$(OUT)/meshes/scan$*.fuse.json -o $@

$(OUT)/scan%.json: $(OUT)/meshes/scan%.ply
	@mkdir -p $(OUT)/vis
	$(SPLATKIT) chamfer --protocol dtu --scan $* --dataset-dir $(DTU_OFFICIAL) $< --seed $(SEED) \
	    --cull --cameras $(DTU_SCENES)/scan$*/$(CAMERAS_NAME) --masks $(DTU_SCENES)/scan$*/mask \
	    --vis-dir $(OUT)/vis --quiet --json=$@

# One row per scan (scan, mean_d2s, mean_s2d, overall) and the mean of each column.
$(OUT)/summary.tsv: $(JSONS)
	python3 $(dir $(lastword $(MAKEFILE_LIST)))dtu_summary.py $(JSONS) | tee $@

clean:
	rm -rf $(OUT)
