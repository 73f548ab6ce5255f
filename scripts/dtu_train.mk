# Train both papers' models on DTU scan 24 inside splatkit and mesh them, masks on, 400x300:
#   triangles:  train triangles  -> tsdf-fuse --dtu (masked depth, largest cluster)        -> OUT/triangles_mesh.ply
#   gaussians:  train gaussians --regularize REG -> splat2points | poisson --sugar (foreground)
#               -> clean --keep-largest 1 (the cull)                                        -> OUT/gaussians_mesh.ply
# then renders of held-out views and of both meshes (OUT/pictures) and a summary table (OUT/summary.md) with
# the held-out masked PSNR / SSIM, primitives, wall time and peak memory of every stage.
#
#   make -f scripts/dtu_train.mk                      # reference lengths (30000 / 15000 iterations)
#   make -f scripts/dtu_train.mk TRI_ITERS=3000 GS_ITERS=3000 OUT=out/dtu24-train
#
# DATA is the NeuS layout (cameras_sphere.npz, image_*/, mask/); no DTU ground-truth points ship with the
# shared data, so the meshes are judged by pictures here (and by `chamfer --protocol dtu --cull` where the
# official data is at hand). Peak memory is GNU time's maximum resident set size.
#
# Variables (defaults in brackets):
#   DATA        [$SPLATKIT_SHARED_DATA/dtu-scan24-neus; SPLATKIT_SHARED_DATA: ../shared/data beside this
#               checkout, as the tests read it]  the scan, NeuS layout
#   OUT         [dtu24-train]  output folder       DOWNSCALE [4]  of the 1600x1200 cameras
#   TRI_ITERS   [30000]        train triangles     GS_ITERS  [15000]  train gaussians
#   MAX_SHAPES  [500000]       train triangles --max-shapes
#   REG         [density]      train gaussians --regularize
#   INIT_POINTS [100000]       --init-points       SEED      [0]
#   SPLATKIT    [$SPLATKIT_BIN, else `splatkit` on PATH, else `cargo run` of this checkout;
#                scripts/lib/splatkit_bin.mk]
# Needs: GNU time (/usr/bin/time), python3 with Pillow (pip install pillow) for the pictures
# (scripts/dtu_train_pictures.py); scripts/dtu_train_summary.py needs the standard library only.

SCRIPTS    := $(dir $(lastword $(MAKEFILE_LIST)))
include $(SCRIPTS)lib/splatkit_bin.mk

DATA       ?= $(or $(SPLATKIT_SHARED_DATA),$(abspath $(SPLATKIT_REPO)/../shared/data))/dtu-scan24-neus
OUT        ?= dtu24-train
DOWNSCALE  ?= 4
TRI_ITERS  ?= 30000
GS_ITERS   ?= 15000
MAX_SHAPES ?= 500000
REG        ?= density
INIT_POINTS ?= 100000
SEED       ?= 0
TIME       := /usr/bin/time -f '%e s, %M KiB'

.PHONY: all clean
all: $(OUT)/summary.md

# DTU settings of the reference scripts: indoor-like losses, no dome, vertex lr 0.0015.
$(OUT)/triangles/metrics.json:
	@mkdir -p $(OUT)
	$(TIME) -o $(OUT)/triangles.time $(SPLATKIT) train triangles $(DATA) -o $(OUT)/triangles --indoor \
	    --iterations $(TRI_ITERS) --max-shapes $(MAX_SHAPES) --downscale $(DOWNSCALE) --masks \
	    --init-points $(INIT_POINTS) --seed $(SEED) --quiet

$(OUT)/gaussians/metrics.json:
	@mkdir -p $(OUT)
	$(TIME) -o $(OUT)/gaussians.time $(SPLATKIT) train gaussians $(DATA) -o $(OUT)/gaussians \
	    --regularize $(REG) --iterations $(GS_ITERS) --downscale $(DOWNSCALE) --masks --init-points $(INIT_POINTS) --seed $(SEED) --quiet

$(OUT)/triangles_mesh.ply: $(OUT)/triangles/metrics.json
	$(TIME) -o $(OUT)/triangles_mesh.time $(SPLATKIT) tsdf-fuse \
	    $$(ls -d $(OUT)/triangles/point_cloud/iteration_*/point_cloud_state_dict.pt | tail -1) \
	    --cameras $(DATA)/cameras_sphere.npz --masks $(DATA)/mask --downscale $(DOWNSCALE) --dtu --quiet -o $@

$(OUT)/gaussians_mesh.ply: $(OUT)/gaussians/metrics.json
	$(TIME) -o $(OUT)/gaussians_mesh.time sh -c '$(SPLATKIT) splat2points $(OUT)/gaussians --all-views --quiet -o - \
	    | $(SPLATKIT) poisson - --sugar --split-by-cameras $(OUT)/gaussians/cameras.json --foreground-only --quiet -o - \
	    | $(SPLATKIT) clean - --keep-largest 1 --quiet -o $@'

$(OUT)/pictures/done: $(OUT)/triangles_mesh.ply $(OUT)/gaussians_mesh.ply
	python3 $(SCRIPTS)dtu_train_pictures.py $(OUT) $(DATA) "$(SPLATKIT)"
	@touch $@

$(OUT)/summary.md: $(OUT)/pictures/done
	python3 $(SCRIPTS)dtu_train_summary.py $(OUT) | tee $@

clean:
	rm -rf $(OUT)
