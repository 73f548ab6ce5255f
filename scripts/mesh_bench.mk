# One scene, every extraction, one table: each generated shape is photographed, trained with
# `train gaussians`, meshed three ways from the same trained model, and each mesh is scored three ways:
#
#   sugar  splat2points (SuGaR level-set points) then poisson --sugar (screened Poisson, SuGaR's trimming)
#   tsdf   tsdf-fuse (2DGS's TSDF fusion of rendered median depth, 2DGS's defaults)
#   tetra  tetra-mesh (Gaussian Opacity Fields' marching tetrahedra on the opacity field)
#
#   exact  chamfer against the exact surface (truth.ply): accuracy / completeness means, scene units
#   dtu    chamfer --protocol dtu with 2DGS's mask culling (the scene laid out as DTU scan 1, 100 mm per unit)
#   tnt    chamfer --protocol tnt (the scene laid out as a Tanks-and-Temples scene, tau = TAU scene units)
#
# Each stage's wall time and peak memory are recorded (scripts/timed.py), one picture per method (and the
# ground truth) is rendered from the same camera (normals), and $(OUT)/table.md gathers everything.
#
#   make -f scripts/mesh_bench.mk -j2                        # sphere, torus, bunny into mesh-bench/
#   make -f scripts/mesh_bench.mk -j2 SHAPES=sphere ITERS=1000 OUT=/tmp/mb
#
# Variables (defaults in brackets):
#   SHAPES   [sphere torus bunny]  generated shapes (examples/mesh_bench_scene.rs); bunny reads
#            ../shared/data/scanned-meshes/bun_zipper.ply (or the file in $BUNNY)
#   OUT      [mesh-bench]  output folder      ITERS [3000]  training iterations (train's schedule)
#   VIEWS    [40]  training photos            SIZE  [128]   photo width = height, pixels
#   TAU      [0.01]  TnT threshold, scene units (the shapes have radius 1)
#   THREADS  [empty: all cores]  --threads for every command
#   SPLATKIT [$SPLATKIT_BIN, else `splatkit` on PATH, else target/release/splatkit built here; the rule of
#            scripts/lib/splatkit_bin.mk, with SPLATKIT_FALLBACK set to that binary (built once, not `cargo run`
#            per stage)]
#   SCENEGEN [target/release/examples/mesh_bench_scene, built here]
# Needs: cargo (to build the scene generator, and splatkit when none is installed), python3 (standard
# library only).

SHAPES   ?= sphere torus bunny
OUT      ?= mesh-bench
ITERS    ?= 3000
VIEWS    ?= 40
SIZE     ?= 128
TAU      ?= 0.01
THREADS  ?=
REPO     := $(abspath $(dir $(lastword $(MAKEFILE_LIST)))..)
SPLATKIT_FALLBACK := $(REPO)/target/release/splatkit
include $(REPO)/scripts/lib/splatkit_bin.mk
SCENEGEN ?= $(REPO)/target/release/examples/mesh_bench_scene
TIMED    := python3 $(REPO)/scripts/timed.py
METHODS  := sugar tsdf tetra
J        := $(if $(THREADS),--threads $(THREADS))

.PHONY: all clean
.SECONDARY:
.DELETE_ON_ERROR:
.SECONDEXPANSION:

all: $(OUT)/table.md

# One cargo call builds what is not given (make -j runs it once); none when SPLATKIT and SCENEGEN name
# programs outside target/release.
BUILD := $(if $(filter $(REPO)/target/release/examples/mesh_bench_scene,$(SCENEGEN)),--example mesh_bench_scene) \
         $(if $(filter $(REPO)/target/release/splatkit,$(SPLATKIT)),--bin splatkit)
$(OUT)/.built:
	@mkdir -p $(OUT)
	$(if $(strip $(BUILD)),cd $(REPO) && cargo build --release --quiet $(BUILD),@echo "using $(SPLATKIT) and $(SCENEGEN)")
	@touch $@

$(OUT)/%/scene.done: | $(OUT)/.built
	rm -rf $(OUT)/$*/data $(OUT)/$*/dtu $(OUT)/$*/dtu_scene $(OUT)/$*/tnt
	$(SCENEGEN) photos $* $(OUT)/$* $(VIEWS) $(SIZE)
	@touch $@

# The trained model: $(OUT)/<shape>/gs/point_cloud/iteration_$(ITERS)/point_cloud.ply, cameras.json.
$(OUT)/%/gs.done: $(OUT)/%/scene.done
	@mkdir -p $(OUT)/$*/time
	rm -rf $(OUT)/$*/gs
	$(TIMED) $(OUT)/$*/time/train.json -- $(SPLATKIT) train gaussians $(OUT)/$*/data -o $(OUT)/$*/gs \
	    --iterations $(ITERS) --seed 0 $(J) -q
	@touch $@

model = $(OUT)/$(1)/gs/point_cloud/iteration_$(ITERS)/point_cloud.ply

$(OUT)/%/sugar_points.ply: $(OUT)/%/gs.done
	$(TIMED) $(OUT)/$*/time/sugar_points.json -- $(SPLATKIT) splat2points $(OUT)/$*/gs $(J) -q -o $@

$(OUT)/%/sugar.ply: $(OUT)/%/sugar_points.ply
	$(TIMED) $(OUT)/$*/time/sugar_poisson.json -- $(SPLATKIT) poisson $< --sugar $(J) -q -o $@

$(OUT)/%/tsdf.ply: $(OUT)/%/gs.done
	$(TIMED) $(OUT)/$*/time/tsdf.json -- $(SPLATKIT) tsdf-fuse $(call model,$*) \
	    --cameras $(OUT)/$*/gs/cameras.json $(J) -q -o $@

$(OUT)/%/tetra.ply: $(OUT)/%/gs.done
	$(TIMED) $(OUT)/$*/time/tetra.json -- $(SPLATKIT) tetra-mesh $(OUT)/$*/gs $(J) -q -o $@

# Scores of one mesh: $(OUT)/<shape>/score/<method>.{exact,dtu,tnt}.json
shape_of = $(word 1,$(subst /, ,$(patsubst $(OUT)/%,%,$(1))))

$(OUT)/%.exact.json: $$(dir $$(@D))$$(notdir $$*).ply
	@mkdir -p $(@D)
	$(SPLATKIT) chamfer $< $(OUT)/$(call shape_of,$@)/truth.ply --seed 0 $(J) -q --json=$@

$(OUT)/%.dtu.json: $$(dir $$(@D))$$(notdir $$*).ply
	@mkdir -p $(@D)
	$(SPLATKIT) chamfer --protocol dtu --scan 1 --dataset-dir $(OUT)/$(call shape_of,$@)/dtu $< \
	    --cull --cameras $(OUT)/$(call shape_of,$@)/dtu_scene/cameras.npz \
	    --masks $(OUT)/$(call shape_of,$@)/dtu_scene/mask --seed 0 $(J) -q --json=$@

$(OUT)/%.tnt.json: $$(dir $$(@D))$$(notdir $$*).ply
	@mkdir -p $(@D)
	s=$(call shape_of,$@); S=$$(echo $$s | sed 's/./\U&/'); \
	$(SPLATKIT) chamfer --protocol tnt --scene $$S --gt-dir $(OUT)/$$s/tnt/$$S \
	    --traj $(OUT)/$$s/tnt/traj.log $< --tau $(TAU) --out-dir $(@D)/tnt-$(notdir $*) \
	    --seed 0 $(J) -q --json=$@

# One picture per method and of the ground truth, all from $(OUT)/<shape>/view.json.
$(OUT)/%.png: $$(dir $$(@D))$$(notdir $$*).ply
	@mkdir -p $(@D)
	rm -rf $(@D)/render-$(notdir $*)
	$(SPLATKIT) render $< --cameras $(OUT)/$(call shape_of,$@)/view.json --outputs normal \
	    -q -o $(@D)/render-$(notdir $*)
	cp $(@D)/render-$(notdir $*)/picture_normal.png $@

$(OUT)/%/truth.ply: $(OUT)/%/scene.done ;

SCORES   := $(foreach s,$(SHAPES),$(foreach m,$(METHODS),$(foreach k,exact dtu tnt,$(OUT)/$(s)/score/$(m).$(k).json)))
PICTURES := $(foreach s,$(SHAPES),$(foreach m,$(METHODS) truth,$(OUT)/$(s)/pictures/$(m).png))

$(OUT)/table.md: $(SCORES) $(PICTURES)
	python3 $(REPO)/scripts/mesh_bench_table.py $(OUT) "$(SHAPES)" "$(METHODS)" $(ITERS) > $@.tmp
	mv $@.tmp $@
	@cat $@

clean:
	rm -rf $(OUT)
