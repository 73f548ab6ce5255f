#!/usr/bin/env python3
"""Read export-off's OFF layouts with Open3D and trimesh and check triangle counts and colours.

usage: python3 scripts/compare/open3d_off.py [INPUT] [--bin DIR]
  INPUT  a triangle soup (.pt or soup .ply); default testdata/pt/ts_f32_param.pt
  --bin  folder holding the export-off binary; default target/release, else target/debug
Installs open3d 0.19.0 and trimesh 5.2.0 into a venv under /tmp on first use.

For the default layout (create_off.py's: COFF, colours on the faces) and `--off-layout compatible`
(COFF, `r g b a` on every vertex): open3d.io.read_triangle_mesh and trimesh.load(process=False);
prints the triangle count each reads and, where it reads colours, the largest difference from the
colours export-off wrote (8-bit values, parsed from the file here). The compatible layout must give
Open3D every triangle and every colour exactly; exits non-zero otherwise.
"""
import os
import subprocess
import sys

VENV = "/tmp/splatkit-open3d-venv"
if not os.path.exists(os.path.join(VENV, "bin", "python")):
    subprocess.check_call([sys.executable, "-m", "venv", VENV])
    subprocess.check_call(
        [os.path.join(VENV, "bin", "pip"), "install", "-q", "open3d==0.19.0", "trimesh==5.2.0", "numpy"]
    )
if sys.prefix != VENV:
    os.execv(os.path.join(VENV, "bin", "python"), [os.path.join(VENV, "bin", "python")] + sys.argv)

import tempfile  # noqa: E402

import numpy as np  # noqa: E402
import open3d as o3d  # noqa: E402
import trimesh  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
args = list(sys.argv[1:])
bindir = None
if "--bin" in args:
    i = args.index("--bin")
    bindir = args[i + 1]
    del args[i : i + 2]
inp = args[0] if args else os.path.join(ROOT, "testdata/pt/ts_f32_param.pt")
if bindir is None:
    for b in ("target/release", "target/debug"):
        if os.path.exists(os.path.join(ROOT, b, "export-off")):
            bindir = os.path.join(ROOT, b)
            break
exe = os.path.join(bindir, "export-off")
tmp = tempfile.mkdtemp(prefix="splatkit-open3d-")


def parse_off(path):
    """Vertex colours (or None), face colours (or None) and face count, as written."""
    lines = [l.split() for l in open(path).read().split("\n") if l.strip()]
    nv, nf = int(lines[1][0]), int(lines[1][1])
    v = lines[2 : 2 + nv]
    f = lines[2 + nv : 2 + nv + nf]
    vc = np.array([[int(x) for x in l[3:6]] for l in v]) if len(v[0]) >= 7 else None
    fc = np.array([[int(x) for x in l[4:7]] for l in f]) if len(f[0]) >= 7 else None
    return vc, fc, nf


ok = True
print(f"open3d {o3d.__version__}, trimesh {trimesh.__version__}; input {inp}")
for layout in ("triangle-splatting", "compatible"):
    out = os.path.join(tmp, f"{layout}.off")
    subprocess.check_call([exe, inp, "-o", out, "-q", "--off-layout", layout])
    vc, fc, nf = parse_off(out)
    m = o3d.io.read_triangle_mesh(out)
    n_o3d = len(m.triangles)
    line = f"{layout:>18}: written {nf} faces; Open3D {n_o3d} triangles"
    if m.has_vertex_colors() and vc is not None:
        got = np.asarray(m.vertex_colors) * 255.0
        err = float(np.abs(got - vc).max())
        line += f", vertex colours max |err| {err:.4f}/255"
        if layout == "compatible":
            ok &= n_o3d == nf and err < 1e-3
    else:
        line += ", no colours"
        if layout == "compatible":
            ok = False
    t = trimesh.load(out, process=False, force="mesh")
    kind = t.visual.kind
    line += f"; trimesh {len(t.faces)} triangles, visual kind {kind}"
    ok &= len(t.faces) == nf
    print(line)
print("OK" if ok else "FAIL")
sys.exit(0 if ok else 1)
