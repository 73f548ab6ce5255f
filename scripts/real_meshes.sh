#!/usr/bin/env bash
# Meshes the two real 3DGS captures of ../shared/data (biker, guitar) with made-up
# orbit cameras, and renders the splats and the mesh from the same view: the pictures
# docs/images/render_{biker,guitar}.png and docs/images/mesh_{biker,guitar}.png.
#   splat2points (level set 0.3, 2 rings of 24 views at 1024x768, 2M points)
#   -> poisson (depth 9, 10% density trim) -> clean (components under 1% of the area go)
#   -> render splats and mesh from orbit view 0 (480x360, white background)
# Usage: scripts/real_meshes.sh [OUT_DIR] [DATA_DIR]
#   OUT_DIR   default: real-meshes/ ; DATA_DIR default: $SPLATKIT_SHARED_DATA, else ../shared/data
#             beside this checkout
# environment: SPLATKIT, SPLATKIT_BIN  the splatkit to run [$SPLATKIT, else $SPLATKIT_BIN, else `splatkit`
#   on PATH, else target/release/splatkit built with cargo; scripts/lib/splatkit_bin.sh]
# Needs: no Python.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out=${1:-real-meshes}
data=${2:-${SPLATKIT_SHARED_DATA:-$here/../shared/data}}
. "$here/scripts/lib/splatkit_bin.sh"
for name in biker guitar; do
  scene="$data/3dgs-playcanvas-$name/$name.decoded_sh0.ply"
  if [ ! -f "$scene" ]; then
    echo "real_meshes.sh: $scene not found (give DATA_DIR)" >&2
    exit 1
  fi
  d="$out/$name"
  mkdir -p "$d"
  "$sk" render "$scene" --orbit 8 --size 480x360 --background 1,1,1 --outputs rgb -o "$d/splats" -q
  "$sk" splat2points "$scene" --orbit 24 --elevation 30,-25 --size 1024x768 \
    --max-points 2000000 -o "$d/points.ply"
  "$sk" poisson "$d/points.ply" --depth 9 --trim-quantile 0.1 -o "$d/poisson.ply"
  "$sk" clean "$d/poisson.ply" --min-component-area 0.01 -o "$d/mesh.ply"
  "$sk" render "$d/mesh.ply" --cameras "$d/splats/cameras.json" --background 1,1,1 \
    --outputs rgb -o "$d/mesh_view" -q
  echo "real_meshes.sh: $name: $d/mesh.ply, views $d/splats/orbit_000.png and $d/mesh_view/orbit_000.png" >&2
done
