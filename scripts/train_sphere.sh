#!/usr/bin/env bash
# The generated-scene acceptance run of `train` (docs/train.md): a textured unit sphere rendered by the
# mesh rasteriser from 40 cameras at 128x128 (every 8th held out), then
#   1. train triangles            -> tsdf-fuse                    -> distance to the sphere
#   2. train gaussians            -> splat2points | poisson       -> distance (no regularisation)
#   3. train gaussians --regularize density (SuGaR coarse) -> splat2points | poisson -> distance
# Distances by examples/sphere_distance (area samples of the mesh vs the exact sphere).
#
#   scripts/train_sphere.sh OUT [TRI_ITERS=3000] [GS_ITERS=3000]      (OUT is relative to the checkout)
# environment: SPLATKIT, SPLATKIT_BIN  the splatkit to run [$SPLATKIT, else $SPLATKIT_BIN, else `splatkit`
#   on PATH, else target/release/splatkit built with cargo; scripts/lib/splatkit_bin.sh]. The two examples
#   (sphere_dataset, sphere_distance) are always built here with cargo: they are not installed commands.
# Needs: cargo, GNU time (/usr/bin/time), python3 (standard library only) for the summary.
set -euo pipefail
OUT=${1:?usage: train_sphere.sh OUT [TRI_ITERS] [GS_ITERS]}
TI=${2:-3000}
GI=${3:-3000}
cd "$(dirname "$0")/.."
. scripts/lib/splatkit_bin.sh
cargo build --release --quiet --example sphere_dataset --example sphere_distance
B=$sk
E=target/release/examples
mkdir -p "$OUT"
[ -d "$OUT/data" ] || $E/sphere_dataset "$OUT/data" 40 128 2000
T="/usr/bin/time -f %e_s,%M_KiB"
$T -o "$OUT/tri.time" "$B" train triangles "$OUT/data" -o "$OUT/tri" --iterations "$TI" --max-shapes 30000 \
    --eval-every 500 -q
"$B" tsdf-fuse "$OUT/tri/point_cloud/iteration_$TI/point_cloud_state_dict.pt" --cameras "$OUT/tri/cameras.json" \
    -q -o "$OUT/tri_mesh.ply"
for mode in none density; do
    reg=(); [ "$mode" = none ] || reg=(--regularize "$mode")
    $T -o "$OUT/gs_$mode.time" "$B" train gaussians "$OUT/data" -o "$OUT/gs_$mode" --iterations "$GI" \
        "${reg[@]}" --eval-every 500 -q
    "$B" splat2points "$OUT/gs_$mode" --all-views -q -o - | "$B" poisson - --depth 8 -q -o "$OUT/gs_${mode}_mesh.ply"
done
{
    for r in tri gs_none gs_density; do
        python3 - "$OUT/$r/metrics.json" "$r" "$OUT/$r.time" <<'PY'
import json, sys
m = json.load(open(sys.argv[1])); e0, e1 = m["evals"][0], m["evals"][-1]
t = open(sys.argv[3]).read().strip()
print(json.dumps({"run": sys.argv[2], "iterations": m["iterations"], "primitives": m["primitives"],
                  "psnr": [round(e0["psnr"], 2), round(e1["psnr"], 2)], "ssim": [round(e0["ssim"], 4), round(e1["ssim"], 4)],
                  "it_per_s": round(m["iterations_per_second"], 2), "time": t}))
PY
    done
    for m in tri_mesh gs_none_mesh gs_density_mesh; do $E/sphere_distance "$OUT/$m.ply"; done
} | tee "$OUT/summary.jsonl"
