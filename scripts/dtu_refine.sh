#!/usr/bin/env bash
# SuGaR's bind + refine on DTU scan 24 (../shared/data/dtu-scan24-neus) with its masks.
# No splats exist for it, so the starting mesh is the visual hull of the 49 masks
# (examples/visual_hull.rs), decimated; Gaussians are bound to it (1 per face, colours from the photos)
# and refined against the photos at 400x300 (--downscale 4 of the 1600x1200 cameras,
# from the 800x600 image_half files), loss inside the masks only. Held-out views: every 8th.
#
# usage: scripts/dtu_refine.sh [OUT] [DATA_DIR]
#   OUT       [dtu-refine]  output folder
#   DATA_DIR  [$SPLATKIT_SHARED_DATA, else ../shared/data beside this checkout]  holds dtu-scan24-neus/
#             (cameras_sphere.npz, image_half/, mask/)
# environment (defaults in brackets):
#   ITERS [2000] refine iterations   FACES [100000] decimation target   DOWNSCALE [4] refine's --downscale
#   SPLATKIT, SPLATKIT_BIN  the splatkit to run [$SPLATKIT, else $SPLATKIT_BIN, else `splatkit` on PATH,
#             else target/release/splatkit built with cargo; scripts/lib/splatkit_bin.sh]
#   VISUAL_HULL  the visual-hull program [target/release/examples/visual_hull, built with cargo: the one
#             cargo call left when splatkit is installed]
# Needs: GNU time (/usr/bin/time); no Python.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
. "$here/scripts/lib/splatkit_bin.sh"
out=${1:-dtu-refine}
data=${2:-${SPLATKIT_SHARED_DATA:-$here/../shared/data}}/dtu-scan24-neus
iters=${ITERS:-2000}
faces=${FACES:-100000}
down=${DOWNSCALE:-4}
hull=${VISUAL_HULL:-}
if [ -z "$hull" ]; then
  (cd "$here" && cargo build --release --example visual_hull -q)
  hull="$here/target/release/examples/visual_hull"
fi
mkdir -p "$out"
"$hull" "$data/cameras_sphere.npz" "$data/mask" "$out/hull.ply" 160 1.1
"$sk" decimate "$out/hull.ply" --faces "$faces" -o "$out/mesh.ply" -q
"$sk" bind-gaussians "$out/mesh.ply" --cameras "$data/cameras_sphere.npz" --images "$data/image_half" \
  --downscale 2 -o "$out/bound.ply" -q
/usr/bin/time -v "$sk" refine "$out/bound.ply" --images "$data/image_half" --masks "$data/mask" \
  --cameras "$data/cameras_sphere.npz" --downscale "$down" --iterations "$iters" --eval-every 500 \
  -o "$out/refined" --json="$out/refine.json" -q 2> "$out/refine.time"
"$sk" render "$out/refined/refined_bound.ply" --cameras "$data/cameras_sphere.npz" --outputs rgb \
  -o "$out/after" -q
echo "dtu_refine.sh: $out/refine.json" >&2
