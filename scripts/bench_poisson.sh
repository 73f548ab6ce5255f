#!/usr/bin/env bash
# Poisson / decimate / clean benchmarks (figures in docs/BENCHMARKS.md).
#
#   scripts/bench_poisson.sh            # depths 8-11 on 1M points, 2 threads then 1 thread; scaling 250k-1M
#   scripts/bench_poisson.sh --open3d   # also Open3D 0.20 on the same kind of scene at depths 8 and 10
#                                       # (scripts/compare/poisson_open3d.py; installs open3d-cpu in a venv)
# It builds this checkout's benches and target/release/splatkit with cargo on purpose (they are what it
# measures; poisson_open3d.py runs that binary), so an installed splatkit (SPLATKIT_BIN, PATH) plays no part.
# environment: SPLATKIT_COMPARE_VENV [~/.cache/splatkit-compare-venv]  the virtual environment of --open3d.
# Needs: cargo; with --open3d, python3 with venv and pip: the script installs open3d-cpu 0.20.0, numpy and
# scipy into that venv (scripts/compare/gen_poisson_scene.py needs numpy; poisson_open3d.py runs its Open3D
# side in the venv, and Open3D needs libusb-1.0).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --benches --bin splatkit >/dev/null
echo "## all threads"; cargo bench -q --bench poisson -- depths
echo "## one thread"; RAYON_NUM_THREADS=1 cargo bench -q --bench poisson -- depths
echo "## scaling, one thread"; RAYON_NUM_THREADS=1 cargo bench -q --bench poisson -- scaling
if [[ "${1:-}" == "--open3d" ]]; then
    venv="${SPLATKIT_COMPARE_VENV:-$HOME/.cache/splatkit-compare-venv}"
    [[ -x "$venv/bin/python" ]] || { python3 -m venv "$venv"; "$venv/bin/pip" install -q open3d-cpu==0.20.0 numpy scipy; }
    scene=target/poisson-scene-1m.ply
    [[ -f $scene ]] || "$venv/bin/python" scripts/compare/gen_poisson_scene.py "$scene"
    for d in 8 10; do
        python3 scripts/compare/poisson_open3d.py "$scene" --depth "$d" --threads 1
    done
fi
