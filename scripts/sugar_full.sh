#!/usr/bin/env bash
# The whole SuGaR pipeline on the CPU, from a 3DGS output folder (or a bare 3DGS PLY):
#   splat2points -> poisson (fg/bg, --sugar) -> decimate -> clean -> bind-gaussians -> refine -> bake-texture
# and a summary table (counts, held-out PSNR / SSIM, seconds per stage).
#
# usage: scripts/sugar_full.sh SCENE_OR_MODEL OUT [IMAGES_DIR]
#   SCENE_OR_MODEL  a 3DGS output folder (point_cloud/iteration_*/point_cloud.ply + cameras.json), or a
#                   3DGS .ply without cameras (then 32 orbit views are made up, as `render --orbit`)
#   IMAGES_DIR      the training photos, named like the cameras; without it, the splats' own renders
#                   from the cameras stand in for the photos (so refinement fits the splats)
# environment: FACES (decimation target, default 200000, SuGaR's low-poly setting), PER_FACE (1),
#   ITERS (2000, SuGaR's --short), DEPTH (Poisson depth, 10), SIZE (photo size for made-up views, 640x480),
#   SPLATKIT, SPLATKIT_BIN (the splatkit to run: $SPLATKIT, else $SPLATKIT_BIN, else `splatkit` on PATH,
#   else target/release/splatkit built with cargo; scripts/lib/splatkit_bin.sh)
# Needs: python3 (standard library only) for the summary.
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '2,/^[^#]/{/^#/p}' "$0" >&2
  exit 2
fi
scene=$1
out=$2
images=${3:-}
faces=${FACES:-200000}
per_face=${PER_FACE:-1}
iters=${ITERS:-2000}
depth=${DEPTH:-10}
size=${SIZE:-640x480}
here="$(cd "$(dirname "$0")/.." && pwd)"
. "$here/scripts/lib/splatkit_bin.sh"
mkdir -p "$out"
declare -a rows
stage() { # name, then the command
  local name=$1; shift
  local t0; t0=$(date +%s.%N)
  "$@"
  rows+=("$(awk -v a="$t0" -v b="$(date +%s.%N)" -v n="$name" 'BEGIN { printf "%-14s %8.1f", n, b - a }')")
}
if [ -d "$scene" ]; then
  cams="$scene/cameras.json"
  [ -f "$cams" ] || { echo "sugar_full.sh: $cams not found (is $scene a 3DGS output folder?)" >&2; exit 1; }
  stage splat2points "$sk" splat2points "$scene" -o "$out/points.ply" -q
  stage poisson "$sk" poisson "$out/points.ply" --sugar --depth "$depth" --split-by-cameras "$cams" \
    -o "$out/poisson.ply" -q
  ply=$(ls -d "$scene"/point_cloud/iteration_* | sort -t_ -k2 -n | tail -1)/point_cloud.ply
  if [ -z "$images" ]; then
    stage photos "$sk" render "$ply" --cameras "$cams" --outputs rgb -o "$out/photos" -q
    images="$out/photos"
  fi
else
  ply=$scene
  stage photos "$sk" render "$ply" --orbit 16 --elevation 30,-25 --size "$size" --outputs rgb \
    -o "$out/photos" -q
  cams="$out/photos/cameras.json"
  images=${images:-$out/photos}
  stage splat2points "$sk" splat2points "$ply" --cameras "$cams" -o "$out/points.ply" -q
  stage poisson "$sk" poisson "$out/points.ply" --sugar --depth "$depth" --split-by-cameras "$cams" \
    -o "$out/poisson.ply" -q
fi
stage decimate "$sk" decimate "$out/poisson.ply" --faces "$faces" -o "$out/decimated.ply" -q
stage clean "$sk" clean "$out/decimated.ply" -o "$out/coarse_mesh.ply" -q
stage bind "$sk" bind-gaussians "$out/coarse_mesh.ply" --per-triangle "$per_face" --cameras "$cams" \
  --colors-from "$ply" -o "$out/bound.ply" -q
stage refine "$sk" refine "$out/bound.ply" --images "$images" --cameras "$cams" --iterations "$iters" \
  -o "$out/refined" --json="$out/refine.json" -q
stage bake-texture "$sk" bake-texture "$out/refined/refined_mesh.ply" "$out/refined/refined_bound.ply" \
  --cameras "$cams" -o "$out/textured.obj" -q
python3 - "$out/refine.json" <<'PY' >&2
import json, sys
d = json.load(open(sys.argv[1]))
e = d.get("evals", [])
print(f"sugar_full.sh: {d['faces']} faces, {d['gaussians']} bound Gaussians, {d['iterations']} iterations")
if e:
    print(f"  held-out PSNR {e[0]['psnr']:.2f} -> {e[-1]['psnr']:.2f} dB, SSIM {e[0]['ssim']:.4f} -> {e[-1]['ssim']:.4f}"
          f" ({d['test_views']} views)")
PY
{
  echo "stage           seconds"
  printf '%s\n' "${rows[@]}"
} >&2
echo "sugar_full.sh: $out/coarse_mesh.ply, $out/refined/, $out/textured.obj" >&2
