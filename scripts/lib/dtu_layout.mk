# Where scan N's cameras and masks lie under DTU_SCENES, for scripts/dtu.mk and scripts/dtu_tsdf.mk (one rule
# for both; the same preference as splatkit's own DTU reader, src/io/dataset.rs).
#   scan folder  DTU_SCENES/scan<N> (2DGS / IDR), else DTU_SCENES/dtu-scan<N>-neus (the layout of ../shared/data)
#   cameras      CAMERAS_NAME [empty: cameras_sphere.npz (NeuS, ../shared/data), else cameras.npz (IDR / 2DGS),
#                whichever exists in the scan folder first]
#   masks        <scan folder>/mask
# So `DTU_SCENES=../shared/data SCANS=24` reads ../shared/data/dtu-scan24-neus/cameras_sphere.npz and mask/.

CAMERAS_NAME ?=

dtu_scan_dir = $(firstword $(wildcard $(DTU_SCENES)/scan$(1) $(DTU_SCENES)/dtu-scan$(1)-neus) $(DTU_SCENES)/scan$(1))
dtu_cameras_in = $(if $(strip $(CAMERAS_NAME)),$(1)/$(strip $(CAMERAS_NAME)),$(firstword \
    $(wildcard $(1)/cameras_sphere.npz $(1)/cameras.npz) $(1)/cameras_sphere.npz))
dtu_cameras = $(call dtu_cameras_in,$(call dtu_scan_dir,$(1)))
dtu_masks = $(call dtu_scan_dir,$(1))/mask
