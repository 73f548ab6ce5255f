#!/usr/bin/env python3
"""Oriented points from the Stanford bunny scan (scanned-meshes/bun_zipper.ply in the shared
data), the real-scan inputs of poisson_open3d.py and scripts/make_poisson_fixture.py.

The vertex normal is the normalised sum of the unit normals of the faces around the vertex;
vertices on no face keep a zero normal, which Open3D and splatkit both drop. Kinds:
  bunny-vertices  the scan's 35,947 vertices with those normals
  bunny-200k      200,000 area-uniform points on the scan's faces (numpy seed 0), normals
                  interpolated from the vertex normals and renormalised

usage: bunny_scan.py BUN_ZIPPER.ply OUT.ply bunny-vertices|bunny-200k   (needs numpy)
"""
import sys
import numpy as np


def load(path):
    """Vertices (float64), faces and vertex normals of the ASCII bun_zipper.ply."""
    lines = open(path).read().split("\n")
    head = lines[:lines.index("end_header")]
    nv = int([l for l in head if l.startswith("element vertex")][0].split()[2])
    nf = int([l for l in head if l.startswith("element face")][0].split()[2])
    body = lines[len(head) + 1:]
    v = np.array([[float(x) for x in l.split()[:3]] for l in body[:nv]])
    f = np.array([[int(x) for x in l.split()[1:4]] for l in body[nv:nv + nf]])
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    ln = np.linalg.norm(fn, axis=1)
    fn = fn / np.where(ln > 0, ln, 1)[:, None]
    vn = np.zeros_like(v)
    for k in range(3):
        np.add.at(vn, f[:, k], fn)
    ln = np.linalg.norm(vn, axis=1)
    return v, f, vn / np.where(ln > 0, ln, 1)[:, None]


def points(path, kind):
    v, f, vn = load(path)
    if kind == "bunny-vertices":
        return v, vn
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    rng = np.random.default_rng(0)
    t = rng.choice(len(f), size=200000, p=area2 / area2.sum())
    r1, r2 = np.sqrt(rng.random(200000))[:, None], rng.random(200000)[:, None]
    w = [1 - r1, r1 * (1 - r2), r1 * r2]
    p = sum(w[k] * v[f[t, k]] for k in range(3))
    n = sum(w[k] * vn[f[t, k]] for k in range(3))
    return p, n / np.linalg.norm(n, axis=1, keepdims=True)


def write_ply(out, p, n):
    rec = np.empty(len(p), dtype=[(k, "<f4") for k in ("x", "y", "z", "nx", "ny", "nz")])
    for i, k in enumerate(("x", "y", "z")):
        rec[k] = p[:, i]
        rec["n" + k] = n[:, i]
    with open(out, "wb") as o:
        o.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % len(p)).encode())
        o.write("".join("property float %s\n" % k for k in rec.dtype.names).encode() + b"end_header\n")
        o.write(rec.tobytes())


if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[3] not in ("bunny-vertices", "bunny-200k"):
        sys.exit(__doc__)
    write_ply(sys.argv[2], *points(sys.argv[1], sys.argv[3]))
