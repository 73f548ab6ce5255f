#!/usr/bin/env bash
# Reading speed of the Gaussian-splat formats: splatkit's readers against
# PlayCanvas splat-transform on the same files.
#
#   scripts/bench_splat_formats.sh [WORKDIR]     (default /tmp/splatkit-bench-splats)
#
# 1. Writes a deterministic 1,000,000-Gaussian SH-degree-3 3DGS PLY (numpy, seed 0;
#    248 MB), and converts it with splatkit's `convert --lossy` to .compressed.ply,
#    .splat, .spz and .sog, and with GaussianSplats3D (node) to a level-1 .ksplat
#    (SH degree 2).
# 2. Times, 3 runs each, median wall seconds of the whole process:
#    splatkit: `read_splats FILE` (examples/read_splats.rs: the one loader, what every
#    command does first), and the read time it reports itself;
#    splat-transform: `splat-transform FILE null` (read, no output).
# Needs: cargo, numpy, node/npm (installs @playcanvas/splat-transform 2.7.1 and
# @mkkellogg/gaussian-splats-3d 0.4.7 + three into WORKDIR/npm). Files are read once
# before timing (page cache warm). SKIP_BUILD=1 uses the binaries already in target/release.
# It builds this checkout's `convert` and examples/read_splats on purpose (their readers are what it
# measures), so an installed splatkit (SPLATKIT_BIN, PATH) plays no part.
# environment: SKIP_BUILD [empty: build]. Python: numpy (the generated scene).
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-/tmp/splatkit-bench-splats}"
mkdir -p "$work"
[ -n "${SKIP_BUILD:-}" ] || cargo build --release -q --bin convert --example read_splats
conv=target/release/convert
reader=target/release/examples/read_splats
npmdir="$work/npm"
if [ ! -x "$npmdir/node_modules/.bin/splat-transform" ]; then
  npm install --silent --prefix "$npmdir" @playcanvas/splat-transform@2.7.1 \
    @mkkellogg/gaussian-splats-3d@0.4.7 three@0.180.0
fi
st="$npmdir/node_modules/.bin/splat-transform"

src="$work/bench.ply"
if [ ! -f "$src" ]; then
python3 - "$src" <<'PY'
import sys
import numpy as np
n = 1_000_000
rng = np.random.default_rng(0)
names = ["x", "y", "z", "nx", "ny", "nz"] + [f"f_dc_{i}" for i in range(3)]
names += [f"f_rest_{i}" for i in range(45)] + ["opacity"]
names += [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)]
t = np.zeros((n, len(names)), np.float32)
t[:, 0:3] = rng.normal(scale=2.0, size=(n, 3))
t[:, 6:9] = rng.uniform(-1.5, 1.5, size=(n, 3))
t[:, 9:54] = rng.uniform(-0.4, 0.4, size=(n, 45))
t[:, 54] = rng.uniform(-3, 5, size=n)
t[:, 55:58] = rng.uniform(-6, -1, size=(n, 3))
t[:, 58:62] = rng.normal(size=(n, 4))
head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
head += "".join(f"property float {p}\n" for p in names) + "end_header\n"
with open(sys.argv[1], "wb") as f:
    f.write(head.encode())
    f.write(t.tobytes())
PY
fi
[ -f "$work/bench.compressed.ply" ] || "$conv" "$src" -o "$work/bench.compressed.ply" --lossy --quiet
[ -f "$work/bench.splat" ] || "$conv" "$src" -o "$work/bench.splat" --lossy --quiet
[ -f "$work/bench.spz" ] || "$conv" "$src" -o "$work/bench.spz" --lossy --quiet
[ -f "$work/bench.sog" ] || "$conv" "$src" -o "$work/bench.sog" --lossy --quiet
if [ ! -f "$work/bench.ksplat" ]; then
  cat > "$npmdir/ksplat.mjs" <<'JS'
import * as GS from '@mkkellogg/gaussian-splats-3d';
import * as THREE from 'three';
import * as fs from 'fs';
const [inp, out] = process.argv.slice(2);
const d = fs.readFileSync(inp);
const arr = GS.PlyParser.parseToUncompressedSplatArray(d.buffer.slice(d.byteOffset, d.byteOffset + d.byteLength), 2);
const sb = GS.SplatBufferGenerator.getStandardGenerator(1, 1, 0, new THREE.Vector3(0, 0, 0), 5.0, 256)
  .generateFromUncompressedSplatArray(arr);
fs.writeFileSync(out, Buffer.from(sb.bufferData));
JS
  (cd "$npmdir" && node --max-old-space-size=16384 ksplat.mjs "$src" "$work/bench.ksplat") \
    || echo "GaussianSplats3D could not write the .ksplat; skipping it" >&2
fi

median() { sort -g | sed -n 2p; }
secs() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N); echo "$t1 - $t0" | bc -l; }
printf '| format | file | size | splatkit (process) | splatkit (read) | splat-transform |\n|---|---|---|---|---|---|\n'
for f in bench.ply bench.compressed.ply bench.splat bench.ksplat bench.spz bench.sog; do
  p="$work/$f"; [ -f "$p" ] || continue
  cat "$p" >/dev/null
  ours=$(for i in 1 2 3; do secs "$reader" "$p"; done | median)
  inner=$(for i in 1 2 3; do "$reader" "$p" | sed 's/.*"seconds":\([0-9.]*\).*/\1/'; done | median)
  theirs=$(for i in 1 2 3; do secs "$st" -q "$p" null; done | median)
  size=$(du -h "$p" | cut -f1)
  printf '| %s | %s | %s | %.2f s | %.2f s | %.2f s |\n' "${f#bench.}" "$f" "$size" "$ours" "$inner" "$theirs"
done
