#!/usr/bin/env bash
# SuGaR's coarse-mesh recipe on a 3DGS output folder, with splatkit:
#   splat2points (level set 0.3, 10M points, training views)
#   -> poisson --sugar (depth 10, outlier removal 20/20, 10% density trim,
#      foreground/background split from the cameras)
#   -> decimate to the face target -> clean.
# Usage: scripts/sugar_mesh.sh MODEL_DIR OUT_DIR [FACES] [LEVEL] [DEPTH]
#   MODEL_DIR  3DGS output folder (point_cloud/iteration_*/point_cloud.ply, cameras.json)
#   OUT_DIR    where points.ply, poisson.ply, decimated.ply and sugar_coarse_mesh.ply go
#   FACES      decimation target (SuGaR: 1000000 via train.py, 200000 for a light mesh)
#   LEVEL      density level (SuGaR: 0.3)
#   DEPTH      Poisson depth (SuGaR: 10; its README suggests 6-8 for close-up objects)
# environment: SPLATKIT, SPLATKIT_BIN  the splatkit to run [$SPLATKIT, else $SPLATKIT_BIN, else `splatkit`
#   on PATH, else target/release/splatkit built with cargo; scripts/lib/splatkit_bin.sh]. No Python.
# See docs/sugar_mesh.md for what each step does and how it differs from SuGaR.
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '2,/^[^#]/{/^#/p}' "$0" >&2
  exit 2
fi
model=$1
out=$2
faces=${3:-1000000}
level=${4:-0.3}
depth=${5:-10}
if [ ! -f "$model/cameras.json" ]; then
  echo "sugar_mesh.sh: $model/cameras.json not found (is $model a 3DGS output folder?)" >&2
  exit 1
fi
. "$(dirname "$0")/lib/splatkit_bin.sh"
mkdir -p "$out"
"$sk" splat2points "$model" --level "$level" -o "$out/points.ply"
"$sk" poisson "$out/points.ply" --sugar --depth "$depth" \
  --split-by-cameras "$model/cameras.json" -o "$out/poisson.ply"
"$sk" decimate "$out/poisson.ply" --faces "$faces" -o "$out/decimated.ply"
"$sk" clean "$out/decimated.ply" -o "$out/sugar_coarse_mesh.ply"
echo "sugar_mesh.sh: wrote $out/sugar_coarse_mesh.ply" >&2
