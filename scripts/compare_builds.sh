#!/usr/bin/env bash
# Runs one fixed pipeline with two `splatkit` binaries and says whether every output file is
# byte-identical: the "outputs unchanged" check that a change meant to keep results (a refactor,
# a new check, a speed-up) must pass. JSON reports are compared after removing the keys that
# measure time (any key containing "second", "time", "elapsed", "it_per_s" or "threads").
#
#   scripts/compare_builds.sh OLD_BIN NEW_BIN [OUT]      (OUT default: target/compare-builds)
#   e.g. git worktree add ../base 5958810 && (cd ../base && cargo build --release --bin splatkit)
#        scripts/compare_builds.sh ../base/target/release/splatkit target/release/splatkit
#
# The pipeline, on 2 threads with fixed seeds:
#   1. `demo` (triangle tools and SuGaR's Gaussian pipeline: render, splat2points, poisson,
#      decimate, clean, bind-gaussians, refine, prune-triangles, export-off);
#   2. from ../shared/data (skipped with a note when absent): splat2points → poisson → decimate →
#      clean → chamfer on a real 3DGS scene; render of the biker scene from an orbit and tsdf-fuse
#      with those cameras; bind-gaussians; bake-texture of the demo's refined Gaussians; a short `train triangles` and `train gaussians` on the COLMAP
#      capture.
# Exit 0 when all outputs match, 1 when any differs (the differing files are listed), 2 on a
# failed step.
# The two binaries are arguments on purpose (it compares two builds), so SPLATKIT_BIN and a splatkit on
# PATH play no part; it builds nothing itself. Needs: jq, bc; no Python.
set -euo pipefail
old=$(realpath "${1:?usage: $0 OLD_BIN NEW_BIN [OUT]}")
new=$(realpath "${2:?usage: $0 OLD_BIN NEW_BIN [OUT]}")
cd "$(dirname "$0")/.."
out=$(realpath -m "${3:-target/compare-builds}")
shared=$(realpath -m ../shared/data)
rm -rf "$out"
mkdir -p "$out/old" "$out/new"

pipeline() { # BIN DIR
    local b=$1 d=$2
    cd "$d"
    "$b" demo -o demo --seed 3 -j 2 --size 128 --views 8 --refine-iterations 20 -q --json=demo.json
    if [[ ! -d $shared ]]; then
        echo "note: $shared is absent: only the demo is compared" >&2
        return
    fi
    local g=$shared/3dgs-kacytran-iter7000/point_cloud.ply
    local biker=$shared/3dgs-playcanvas-biker/biker.decoded_sh0.ply
    local kun=$shared/colmap-kunkun-figurine
    "$b" splat2points "$g" --orbit 12 --elevation 30,-20 --size 256x192 -j 2 --seed 1 -q -o points.ply
    "$b" poisson points.ply --depth 8 -j 2 -q -o poisson.ply --json=poisson.json
    "$b" decimate poisson.ply --faces 20000 -j 2 -q -o decimated.ply
    "$b" clean decimated.ply -j 2 -q -o cleaned.ply --json=clean.json
    "$b" chamfer cleaned.ply points.ply -j 2 --seed 1 -q --json=chamfer.json
    "$b" render "$biker" --orbit 12 --size 320x240 -j 2 -q -o render --outputs rgb,depth,alpha,normal
    "$b" tsdf-fuse "$biker" --cameras render/cameras.json -j 2 -q -o tsdf.ply --json=tsdf.json
    "$b" bind-gaussians cleaned.ply -j 2 -q -o bound.ply
    "$b" bake-texture demo/mesh.ply demo/refined_bound.ply --cameras demo/cameras.json -j 2 -q \
        -o textured/t.obj --json=bake.json
    "$b" train triangles "$kun" --resolution 120 --iterations 30 --seed 1 -j 2 -q -o train_tri
    "$b" train gaussians "$kun" --resolution 120 --iterations 30 --seed 1 -j 2 -q -o train_gs
}

for side in old new; do
    bin=$old; [[ $side == new ]] && bin=$new
    start=$(date +%s.%N)
    if ! (pipeline "$bin" "$out/$side") >"$out/$side.log" 2>&1; then
        echo "the $side binary failed a step; its log: $out/$side.log" >&2
        tail -5 "$out/$side.log" >&2
        exit 2
    fi
    echo "$side: $(echo "$(date +%s.%N) - $start" | bc) s" >&2
done

strip_json() { jq -S 'walk(if type == "object" then with_entries(select(.key | test("second|time|elapsed|it_per_s|threads") | not)) else . end)' "$1"; }
differ=0 same=0
while IFS= read -r -d '' f; do
    rel=${f#"$out/old/"}
    g="$out/new/$rel"
    if [[ ! -e $g ]]; then
        echo "only in old: $rel"; differ=$((differ + 1)); continue
    fi
    if [[ $f == *.json ]]; then
        if cmp -s <(strip_json "$f") <(strip_json "$g"); then
            same=$((same + 1))
        else
            echo "differs: $rel (old < > new, leaf by leaf):"; differ=$((differ + 1))
            diff <(strip_json "$f" | jq -c 'paths(scalars) as $p | [$p, getpath($p)]') \
                 <(strip_json "$g" | jq -c 'paths(scalars) as $p | [$p, getpath($p)]') |
                grep '^[<>]' | head -20 || true
        fi
    elif cmp -s "$f" "$g"; then
        same=$((same + 1))
    else
        echo "differs: $rel"; differ=$((differ + 1))
    fi
done < <(find "$out/old" -type f -print0 | sort -z)
while IFS= read -r -d '' g; do
    rel=${g#"$out/new/"}
    [[ -e "$out/old/$rel" ]] || { echo "only in new: $rel"; differ=$((differ + 1)); }
done < <(find "$out/new" -type f -print0 | sort -z)
echo "$same files identical, $differ differ"
[[ $differ -eq 0 ]]
