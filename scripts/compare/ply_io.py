#!/usr/bin/env python3
"""Reference timing for 3DGS PLY I/O in Python, to compare with `cargo bench --bench ply_io`.

Reads a 3DGS PLY the way graphdeco's GaussianModel.load_ply does (plyfile + numpy: properties by name,
f_rest sorted by index and reshaped to (N, 3, K)), and writes it back the way save_ply does (one
structured array, PlyData.write). Installs plyfile and numpy with pip if they are missing.

Usage: scripts/compare/ply_io.py FILE.ply [REPS]
       (make FILE.ply with: SPLATKIT_BENCH_KEEP=/tmp/g.ply cargo bench --bench ply_io)
"""
import subprocess
import sys
import tempfile
import time
import os

try:
    import numpy as np
    from plyfile import PlyData, PlyElement
except ImportError:
    subprocess.check_call([sys.executable, "-m", "pip", "install", "-q", "plyfile", "numpy"])
    import numpy as np
    from plyfile import PlyData, PlyElement


def load(path):
    ply = PlyData.read(path)
    v = ply.elements[0]
    xyz = np.stack((v["x"], v["y"], v["z"]), axis=1)
    opacity = np.asarray(v["opacity"])[..., None]
    dc = np.stack([v[f"f_dc_{i}"] for i in range(3)], axis=1)[..., None]
    rest_names = sorted((p.name for p in v.properties if p.name.startswith("f_rest_")),
                        key=lambda n: int(n.split("_")[-1]))
    rest = np.stack([v[n] for n in rest_names], axis=1).reshape(len(xyz), 3, -1)
    scales = np.stack([v[f"scale_{i}"] for i in range(3)], axis=1)
    rots = np.stack([v[f"rot_{i}"] for i in range(4)], axis=1)
    return xyz, dc, rest, opacity, scales, rots


def save(path, xyz, dc, rest, opacity, scales, rots):
    n = len(xyz)
    normals = np.zeros_like(xyz)
    cols = [xyz, normals, dc.reshape(n, -1), rest.reshape(n, -1), opacity, scales, rots]
    names = ["x", "y", "z", "nx", "ny", "nz"] + [f"f_dc_{i}" for i in range(3)] + \
        [f"f_rest_{i}" for i in range(rest.shape[1] * rest.shape[2])] + ["opacity"] + \
        [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)]
    elements = np.empty(n, dtype=[(a, "f4") for a in names])
    elements[:] = list(map(tuple, np.concatenate(cols, axis=1)))
    PlyData([PlyElement.describe(elements, "vertex")]).write(path)


def main():
    path = sys.argv[1]
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    size = os.path.getsize(path) / 1e6
    reads, writes = [], []
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "out.ply")
        for _ in range(reps):
            t = time.perf_counter()
            arrays = load(path)
            reads.append(time.perf_counter() - t)
            t = time.perf_counter()
            save(out, *arrays)
            writes.append(time.perf_counter() - t)
    for what, ts in (("plyfile read (load_ply)", reads), ("plyfile write (save_ply)", writes)):
        ts.sort()
        print(f"{what:<28} best {ts[0]:7.3f} s {size / ts[0]:7.0f} MB/s   median {ts[len(ts) // 2]:7.3f} s")


if __name__ == "__main__":
    main()
