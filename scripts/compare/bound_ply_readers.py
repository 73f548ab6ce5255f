#!/usr/bin/env python3
"""Open a bound-Gaussians PLY (bind-gaussians / refine) the way 3DGS tools do.

usage: python3 scripts/compare/bound_ply_readers.py BOUND.ply
Installs plyfile into a venv under /tmp on first use (the reader graphdeco's 3DGS code uses).

1. graphdeco's GaussianModel.load_ply: plydata.elements[0], properties looked up by name (x y z,
   f_dc_*, f_rest_* sorted by suffix and counted against the SH degree, opacity, scale_*, rot*);
   done here the same way with plyfile, no torch.
2. The PlayCanvas engine's PLY parser (SuperSplat): its header rules, applied to the header text: every
   `property` line must name a scalar type (it throws on `property list`), the format must be binary.
Prints what each reader gets and exits non-zero if either would fail.
"""
import os
import subprocess
import sys

VENV = "/tmp/splatkit-plyfile-venv"
if not os.path.exists(os.path.join(VENV, "bin", "python")):
    subprocess.check_call([sys.executable, "-m", "venv", VENV])
    subprocess.check_call([os.path.join(VENV, "bin", "pip"), "install", "-q", "plyfile", "numpy"])
if sys.prefix != VENV:
    os.execv(os.path.join(VENV, "bin", "python"), [os.path.join(VENV, "bin", "python")] + sys.argv)

import numpy as np  # noqa: E402
from plyfile import PlyData  # noqa: E402

path = sys.argv[1]
ply = PlyData.read(path)
el = ply.elements[0]
names = [p.name for p in el.properties]
xyz = np.stack([np.asarray(el["x"]), np.asarray(el["y"]), np.asarray(el["z"])], axis=1)
dc = np.stack([np.asarray(el[f"f_dc_{i}"]) for i in range(3)], axis=1)
rest = sorted([n for n in names if n.startswith("f_rest_")], key=lambda n: int(n.split("_")[-1]))
assert len(rest) == 3 * 15, f"expected 45 f_rest (SH degree 3), got {len(rest)}"
opacity = np.asarray(el["opacity"])
scales = sorted([n for n in names if n.startswith("scale_")], key=lambda n: int(n.split("_")[-1]))
rots = sorted([n for n in names if n.startswith("rot")], key=lambda n: int(n.split("_")[-1]))
scale = np.stack([np.asarray(el[n]) for n in scales], axis=1)
rot = np.stack([np.asarray(el[n]) for n in rots], axis=1)
print(f"graphdeco load_ply (plyfile): element '{el.name}' with {len(xyz)} Gaussians, "
      f"{len(rest)} f_rest, scales {scale.shape}, rotations {rot.shape}, "
      f"|q| in [{np.linalg.norm(rot, axis=1).min():.6f}, {np.linalg.norm(rot, axis=1).max():.6f}], "
      f"other elements: {[e.name + ' ' + str(e.count) for e in ply.elements[1:]]}")

with open(path, "rb") as f:
    head = f.read(1 << 20)
header = head[: head.index(b"end_header\n")].decode("ascii")
scalar = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"}
bad = [line for line in header.splitlines() if line.startswith("property ") and line.split()[1] not in scalar]
fmt = [line for line in header.splitlines() if line.startswith("format ")][0].split()[1]
ok = not bad and fmt in ("binary_little_endian", "binary_big_endian")
print(f"PlayCanvas/SuperSplat header rules: format {fmt}, non-scalar properties {bad or 'none'} -> "
      f"{'accepted' if ok else 'REFUSED'}")
sys.exit(0 if ok else 1)
