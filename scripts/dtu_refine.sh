#!/usr/bin/env bash
# SuGaR's bind + refine on DTU scan 24 (../shared/data/dtu-scan24-neus) with its masks.
# No splats exist for it, so the starting mesh is the visual hull of the 49 masks
# (examples/visual_hull.rs), decimated; Gaussians are bound to it (1 per face, colours from the photos)
# and refined against the photos at 400x300 (--downscale 4 of the 1600x1200 cameras,
# from the 800x600 image_half files), loss inside the masks only. Held-out views: every 8th.
#
# usage: scripts/dtu_refine.sh [OUT] [DATA_DIR]       (ITERS, FACES, DOWNSCALE override)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out=${1:-dtu-refine}
data=${2:-$here/../shared/data}/dtu-scan24-neus
iters=${ITERS:-2000}
faces=${FACES:-100000}
down=${DOWNSCALE:-4}
sk=${SPLATKIT:-$here/target/release/splatkit}
mkdir -p "$out"
(cd "$here" && cargo build --release --example visual_hull -q)
"$here/target/release/examples/visual_hull" "$data/cameras_sphere.npz" "$data/mask" "$out/hull.ply" 160 1.1
"$sk" decimate "$out/hull.ply" --faces "$faces" -o "$out/mesh.ply" -q
"$sk" bind-gaussians "$out/mesh.ply" --cameras "$data/cameras_sphere.npz" --images "$data/image_half" \
  --downscale 2 -o "$out/bound.ply" -q
/usr/bin/time -v "$sk" refine "$out/bound.ply" --images "$data/image_half" --masks "$data/mask" \
  --cameras "$data/cameras_sphere.npz" --downscale "$down" --iterations "$iters" --eval-every 500 \
  -o "$out/refined" --json="$out/refine.json" -q 2> "$out/refine.time"
"$sk" render "$out/refined/refined_bound.ply" --cameras "$data/cameras_sphere.npz" --outputs rgb \
  -o "$out/after" -q
echo "dtu_refine.sh: $out/refine.json" >&2
