#!/usr/bin/env python3
"""Write testdata/poisson/open3d_bunny_vertices_d9.json: what Open3D's screened Poisson
reconstruction (create_from_point_cloud_poisson, its defaults, depth 9, one thread) gives
on the Stanford bunny scan's vertices, for the test `bunny_scan_matches_open3d_adaptivity`
(src/geom/meshing/poisson/tests.rs), which rebuilds the same input from ../shared/data.

Input: the 35,947 vertices of scanned-meshes/bun_zipper.ply with face-averaged normals
(scripts/compare/bunny_scan.py, kind bunny-vertices); vertices on no face have a zero normal,
which Open3D drops ("bad data") and so does splatkit.

Written: Open3D's version, vertex and face counts, and every 97th output vertex with its
density (the depth estimate Open3D returns per vertex).

Usage (Open3D needs libusb-1.0; Debian: apt-get install libusb-1.0-0):
    python3 -m venv /tmp/o3dvenv && /tmp/o3dvenv/bin/pip install open3d-cpu==0.20.0 numpy
    /tmp/o3dvenv/bin/python scripts/make_poisson_fixture.py [SHARED_DATA_DIR]
"""
import json, os, sys
import numpy as np
import open3d as o3d

here = os.path.dirname(os.path.abspath(__file__))
shared = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "..", "shared", "data")
sys.path.insert(0, os.path.join(here, "compare"))
from bunny_scan import load  # noqa: E402  (the input recipe shared with poisson_open3d.py)

v, _, vn = load(os.path.join(shared, "scanned-meshes", "bun_zipper.ply"))
nv = len(v)
ln = np.linalg.norm(vn, axis=1)
pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(v))
pc.normals = o3d.utility.Vector3dVector(vn)
mesh, dens = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pc, depth=9, n_threads=1)
mv, d = np.asarray(mesh.vertices), np.asarray(dens)
out = {
    "tool": f"open3d.geometry.TriangleMesh.create_from_point_cloud_poisson (Open3D {o3d.__version__})",
    "depth": 9,
    "input_points": int(nv),
    "zero_normals": int((ln == 0).sum()),
    "vertices": int(len(mv)),
    "faces": int(len(mesh.triangles)),
    "every_97th_vertex_xyz_density": [[float(mv[i, 0]), float(mv[i, 1]), float(mv[i, 2]), float(d[i])]
                                      for i in range(0, len(mv), 97)],
}
dst = os.path.join(here, "..", "testdata", "poisson", "open3d_bunny_vertices_d9.json")
os.makedirs(os.path.dirname(dst), exist_ok=True)
with open(dst, "w") as o:
    json.dump(out, o, indent=0)
print(dst, out["vertices"], out["faces"], out["zero_normals"])
