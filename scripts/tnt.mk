# Tanks-and-Temples meshing and scoring as 2DGS and its successors run it: fuse each trained scene's rendered
# depth (median, training views) with the unbounded TSDF, keep the largest cluster, and evaluate with
# `chamfer --protocol tnt` given the toolbox's own flags; one JSON per scene and a summary.
#
#   make -f scripts/tnt.mk -j2 SCENES=out/scenes TNT_DATA=/data/tnt TNT_GT=/data/tnt_gt OUT=out/tnt
#
# SCENES holds one trained scene per TnT scene: <Scene>.ply (Gaussians or triangle soup) or <Scene>.pt.
# TNT_DATA holds the training data per scene: <Scene>/sparse/0 (or a cameras.json), and the reference
# trajectory <Scene>/<Scene>_COLMAP_SfM.log that 2DGS passes as --traj-path. TNT_GT holds the toolbox's
# ground truth per scene: <Scene>/<Scene>.ply, .json, _trans.txt, _COLMAP_SfM.log (and
# _mapping_reference.txt for full-video logs).
#
# FUSE_FLAGS replaces the fusion settings: the default is the unbounded TSDF at --mesh-res 1024;
# 2DGS's released TnT script instead uses the bounded one, e.g.
#   FUSE_FLAGS="--voxel 0.004 --sdf-trunc 0.016 --depth-trunc 3.0"   (Barn, Caterpillar, Ignatius, Truck)
#   FUSE_FLAGS="--voxel 0.006 --sdf-trunc 0.024 --depth-trunc 4.5"   (Meetingroom, Courthouse)
# DOWNSCALE is the render size divisor (2DGS trains TnT at -r 2).
#
# Variables (defaults in brackets):
#   SCENES, TNT_DATA, TNT_GT [required]  as above
#   OUT        [tnt-eval]  output folder          SEED [0]  chamfer's seed
#   DOWNSCALE  [2]         MESH_RES [1024]  the unbounded TSDF's --mesh-res
#   FUSE_FLAGS [--unbounded --mesh-res $(MESH_RES)]
#   TNT_SCENES [Barn Caterpillar Ignatius Truck Meetingroom Courthouse]
#   SPLATKIT   [$SPLATKIT_BIN, else `splatkit` on PATH, else `cargo run` of this checkout;
#               scripts/lib/splatkit_bin.mk]
# Needs: python3 (standard library only) for the summary.

SCRIPTS    := $(dir $(lastword $(MAKEFILE_LIST)))
include $(SCRIPTS)lib/splatkit_bin.mk

SCENES     ?= $(error set SCENES to the folder of trained scenes <Scene>.ply / <Scene>.pt)
TNT_DATA   ?= $(error set TNT_DATA to the folder holding <Scene>/sparse/0 and <Scene>/<Scene>_COLMAP_SfM.log)
TNT_GT     ?= $(error set TNT_GT to the toolbox ground truth folder holding <Scene>/<Scene>.ply, ...)
OUT        ?= tnt-eval
SEED       ?= 0
DOWNSCALE  ?= 2
MESH_RES   ?= 1024
FUSE_FLAGS ?= --unbounded --mesh-res $(MESH_RES)
TNT_SCENES ?= Barn Caterpillar Ignatius Truck Meetingroom Courthouse

JSONS := $(foreach s,$(TNT_SCENES),$(OUT)/$(s).json)

.PHONY: all clean
.SECONDARY:
all: $(OUT)/summary.tsv

scene_of = $(firstword $(wildcard $(SCENES)/$(1).pt) $(SCENES)/$(1).ply)
cams_of = $(firstword $(wildcard $(TNT_DATA)/$(1)/sparse/0) $(TNT_DATA)/$(1)/cameras.json)

$(OUT)/meshes/%.ply:
	@mkdir -p $(OUT)/meshes
	$(SPLATKIT) tsdf-fuse $(call scene_of,$*) --cameras $(call cams_of,$*) --downscale $(DOWNSCALE) \
	    $(FUSE_FLAGS) --keep-clusters 1 --quiet --json=$(OUT)/meshes/$*.fuse.json -o $@

# The toolbox's command line; its outputs land in $(OUT)/meshes/evaluation/ as the toolbox puts them.
$(OUT)/%.json: $(OUT)/meshes/%.ply
	$(SPLATKIT) chamfer --protocol tnt --dataset-dir $(TNT_GT)/$* \
	    --traj-path $(TNT_DATA)/$*/$*_COLMAP_SfM.log --ply-path $< --seed $(SEED) --quiet --json=$@

# One row per scene: scene, precision, recall, f-score, and the mean F.
$(OUT)/summary.tsv: $(JSONS)
	@python3 -c 'import json,sys; rows=[json.load(open(f)) for f in sys.argv[1:]]; \
	print("scene\tprecision\trecall\tfscore"); \
	[print("%s\t%.4f\t%.4f\t%.4f" % (r["scene"], r["precision"], r["recall"], r["fscore"])) for r in rows]; \
	print("mean\t\t\t%.4f" % (sum(r["fscore"] for r in rows) / len(rows)))' $(JSONS) | tee $@

clean:
	rm -rf $(OUT)
