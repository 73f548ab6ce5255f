#!/usr/bin/env bash
# SuGaR's bind + refine on the real biker and guitar captures of ../shared/data.
# The original splats, rendered from orbit views, are the "photos"; the mesh is
# made from the same splats with the existing pipeline (splat2points | poisson |
# clean | decimate); Gaussians are bound to it (1 per face, colours from the
# splats) and refined. Held-out views are every 8th orbit view.
#
# usage: scripts/refine_real.sh [OUT] [DATA_DIR]
#   OUT       [refine-real]  output folder, one subfolder per capture
#   DATA_DIR  [$SPLATKIT_SHARED_DATA, else ../shared/data beside this checkout]  holds
#             3dgs-playcanvas-NAME/NAME.decoded_sh0.ply for each NAME
# environment (defaults in brackets):
#   NAMES [guitar biker]  the captures to run, space-separated (e.g. NAMES=guitar for one)
#   ITERS [2000] refine iterations   SIZE [320x240] photo size   FACES [100000] decimation target
#   SPLATKIT, SPLATKIT_BIN  the splatkit to run [$SPLATKIT, else $SPLATKIT_BIN, else `splatkit` on PATH,
#             else target/release/splatkit built with cargo; scripts/lib/splatkit_bin.sh]
# Needs: GNU time (/usr/bin/time); no Python.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out=${1:-refine-real}
data=${2:-${SPLATKIT_SHARED_DATA:-$here/../shared/data}}
iters=${ITERS:-2000}
size=${SIZE:-320x240}
faces=${FACES:-100000}
names=${NAMES:-guitar biker}
for name in $names; do
  scene="$data/3dgs-playcanvas-$name/$name.decoded_sh0.ply"
  [ -f "$scene" ] || { echo "refine_real.sh: $scene not found (give DATA_DIR, or NAMES)" >&2; exit 1; }
done
. "$here/scripts/lib/splatkit_bin.sh"
for name in $names; do
  scene="$data/3dgs-playcanvas-$name/$name.decoded_sh0.ply"
  d="$out/$name"
  mkdir -p "$d"
  t0=$(date +%s)
  "$sk" render "$scene" --orbit 24 --elevation 30,-25 --size "$size" --outputs rgb -o "$d/photos" -q
  "$sk" splat2points "$scene" --orbit 24 --elevation 30,-25 --size 1024x768 \
    --max-points 2000000 -o "$d/points.ply" -q
  "$sk" poisson "$d/points.ply" --depth 9 --trim-quantile 0.1 -o - -q \
    | "$sk" clean - --min-component-area 0.01 -o - -q \
    | "$sk" decimate - --faces "$faces" -o "$d/mesh.ply" -q
  t1=$(date +%s)
  "$sk" bind-gaussians "$d/mesh.ply" --colors-from "$scene" --cameras "$d/photos/cameras.json" \
    -o "$d/bound.ply" -q
  /usr/bin/time -v "$sk" refine "$d/bound.ply" --images "$d/photos" --cameras "$d/photos/cameras.json" \
    --iterations "$iters" --eval-every 500 -o "$d/refined" --json="$d/refine.json" -q 2> "$d/refine.time"
  t2=$(date +%s)
  # side by side: a held-out photo, the bound Gaussians before and after refinement
  "$sk" render "$d/bound.ply" --cameras "$d/photos/cameras.json" --outputs rgb -o "$d/before" -q
  "$sk" render "$d/refined/refined_bound.ply" --cameras "$d/photos/cameras.json" --outputs rgb -o "$d/after" -q
  echo "refine_real.sh: $name: mesh $((t1 - t0)) s, bind + refine $((t2 - t1)) s; $d/refine.json" >&2
done
