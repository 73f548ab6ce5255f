#!/usr/bin/env python3
"""Runs Open3D 0.20 (open3d-cpu) and `splatkit poisson` on the same oriented PLY and
compares them: vertex / face counts, wall time and peak memory of each (each tool in
its own child process), and the distance between the two meshes in finest-cell units
(cell = 1.1 x largest bounding-box extent of the input / 2^depth): area-uniform samples
on each mesh (seeded), exact point-to-triangle distance to the other mesh (Open3D
RaycastingScene), mean / median / p95 per direction, symmetric = mean of the two means.
With --trim-quantile Q both are trimmed SuGaR's way first: splatkit by its own
--trim-quantile, Open3D by removing vertices below numpy.quantile(densities, Q).

The first run creates a virtual environment (~/.cache/splatkit-compare-venv, or
$SPLATKIT_COMPARE_VENV) with open3d-cpu==0.20.0 and numpy; Open3D needs libusb-1.0
(Debian: apt-get install libusb-1.0-0).

Real scans: IN.ply may instead be `bunny-200k` (200,000 area-uniform points on the Stanford
bunny scan `scanned-meshes/bun_zipper.ply`, seed 0, normals interpolated from the mesh's vertex
normals) or `bunny-vertices` (the scan's 35,947 vertices with those normals), written by
bunny_scan.py from $SPLATKIT_SHARED_DATA (default ../shared/data beside the repository) into the
temporary folder.

usage: poisson_open3d.py IN.ply|bunny-200k|bunny-vertices [--depth 8] [--flip-normals] [--threads 1]
         [--splatkit target/release/splatkit] [--trim-quantile Q] [--json OUT]
"""
import argparse, json, os, subprocess, sys, tempfile, time

VENV = os.environ.get("SPLATKIT_COMPARE_VENV", os.path.expanduser("~/.cache/splatkit-compare-venv"))

def ensure_venv():
    py = os.path.join(VENV, "bin", "python")
    if not os.path.exists(py):
        subprocess.check_call([sys.executable, "-m", "venv", VENV])
        subprocess.check_call([py, "-m", "pip", "install", "-q", "open3d-cpu==0.20.0", "numpy", "scipy"])
    return py

CHILD_O3D = r'''
import sys, time, resource, json, numpy as np, open3d as o3d
inp, out, depth, flip, threads = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4] == "1", int(sys.argv[5])
pcd = o3d.io.read_point_cloud(inp)
if flip:
    pcd.normals = o3d.utility.Vector3dVector(-np.asarray(pcd.normals))
t = time.time()
m, d = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=depth, n_threads=threads)
el = time.time() - t
o3d.io.write_triangle_mesh(out, m)
np.save(out + ".density.npy", np.asarray(d))
print(json.dumps({"seconds": el, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
'''

CHILD_CMP = r'''
import sys, json, numpy as np, open3d as o3d
a, b, cell, q, sk_dens = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
ma = o3d.io.read_triangle_mesh(a)
mb = o3d.io.read_triangle_mesh(b)
if q > 0:  # splatkit trimmed itself (--trim-quantile); Open3D the way SuGaR does it
    db = np.load(b + ".density.npy"); mb.remove_vertices_by_mask(db < np.quantile(db, q))
def sample(m, n=200000, seed=1):
    # area-uniform, seeded: triangles by area, then uniform barycentrics
    v = np.asarray(m.vertices); f = np.asarray(m.triangles)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    rng = np.random.default_rng(seed)
    t = rng.choice(len(f), size=n, p=area / area.sum())
    r1, r2 = np.sqrt(rng.random(n))[:, None], rng.random(n)[:, None]
    return (1 - r1) * a[t] + r1 * (1 - r2) * b[t] + r1 * r2 * c[t]
def dist(src, dst):
    pts = sample(src)
    sc = o3d.t.geometry.RaycastingScene(); sc.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(dst))
    d = sc.compute_distance(o3d.core.Tensor(pts, dtype=o3d.core.Dtype.Float32)).numpy() / cell
    return {"mean": float(d.mean()), "median": float(np.median(d)), "p95": float(np.percentile(d, 95))}
print(json.dumps({"splatkit_to_open3d": dist(ma, mb), "open3d_to_splatkit": dist(mb, ma)}))
'''

CHILD_DENSITY = r'''
import sys, numpy as np
# splatkit writes binary little-endian PLY with the vertex element first.
types = {"char": "i1", "uchar": "u1", "short": "<i2", "ushort": "<u2", "int": "<i4",
         "uint": "<u4", "float": "<f4", "double": "<f8"}
data = open(sys.argv[1], "rb").read()
end = data.index(b"end_header\n") + len(b"end_header\n")
props, count, in_vertex = [], 0, False
for line in data[:end].decode().splitlines():
    w = line.split()
    if w[:2] == ["element", "vertex"]:
        count, in_vertex = int(w[2]), True
    elif w and w[0] == "element":
        in_vertex = False
    elif in_vertex and w[0] == "property":
        props.append((w[2], types[w[1]]))
v = np.frombuffer(data, dtype=np.dtype(props), count=count, offset=end)
np.save(sys.argv[2], v["density"].astype(np.float64))
'''

def timed(cmd):
    t = time.time()
    r = subprocess.run(["/usr/bin/time", "-f", "__PEAK_KB %M"] + cmd, capture_output=True, text=True)
    el = time.time() - t
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    peak = [l for l in r.stderr.splitlines() if l.startswith("__PEAK_KB")]
    return r, el, int(peak[-1].split()[1]) / 1024 if peak else float("nan")

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("input")
    ap.add_argument("--depth", type=int, default=8)
    ap.add_argument("--flip-normals", action="store_true")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--splatkit", default="target/release/splatkit")
    ap.add_argument("--trim-quantile", type=float, default=0.0)
    ap.add_argument("--json")
    a = ap.parse_args()
    py = ensure_venv()
    tmp = tempfile.mkdtemp(prefix="poisson-cmp-")
    if a.input in ("bunny-200k", "bunny-vertices"):
        here = os.path.dirname(os.path.abspath(__file__))
        shared = os.environ.get("SPLATKIT_SHARED_DATA", os.path.join(here, "..", "..", "..", "shared", "data"))
        gen = os.path.join(tmp, a.input + ".ply")
        subprocess.check_call([py, os.path.join(here, "bunny_scan.py"),
                               os.path.join(shared, "scanned-meshes", "bun_zipper.ply"), gen, a.input])
        a.input = gen
    o3d_out, sk_out = os.path.join(tmp, "open3d.ply"), os.path.join(tmp, "splatkit.ply")
    r, _, o3d_peak = timed([py, "-c", CHILD_O3D, a.input, o3d_out, str(a.depth), "1" if a.flip_normals else "0", str(a.threads)])
    o3d_stats = json.loads(r.stdout.strip().splitlines()[-1])
    cmd = [a.splatkit, "poisson", a.input, "--depth", str(a.depth), "--threads", str(a.threads), "-q",
           "--json=" + sk_out + ".json", "-o", sk_out]
    if a.flip_normals:
        cmd.append("--flip-normals")
    if a.trim_quantile > 0:
        cmd += ["--trim-quantile", str(a.trim_quantile)]
    _, sk_time, sk_peak = timed(cmd)
    sk = json.load(open(sk_out + ".json"))
    cell = sk["parts"][0]["poisson"]["cell_size"]
    # the density of splatkit's mesh, for SuGaR-style trimming of both
    subprocess.check_call([py, "-c", CHILD_DENSITY, sk_out, sk_out + ".density.npy"])
    r = subprocess.run([py, "-c", CHILD_CMP, sk_out, o3d_out, str(cell), str(a.trim_quantile), sk_out + ".density.npy"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(r.stderr)
    d = json.loads(r.stdout.strip().splitlines()[-1])
    counts = subprocess.run([py, "-c", "import sys,open3d as o3d\nfor p in sys.argv[1:]:\n m=o3d.io.read_triangle_mesh(p); print(len(m.vertices), len(m.triangles))",
                             sk_out, o3d_out], capture_output=True, text=True).stdout.split()
    res = {
        "input": a.input, "depth": a.depth, "threads": a.threads, "cell": cell, "trim_quantile": a.trim_quantile,
        "splatkit": {"seconds_total": sk_time, "seconds_stages": sk["parts"][0]["poisson"]["seconds"], "peak_mb": sk_peak,
                     "vertices": int(counts[0]), "faces": int(counts[1])},
        "open3d": {"seconds_poisson": o3d_stats["seconds"], "peak_mb": o3d_peak, "vertices": int(counts[2]), "faces": int(counts[3])},
        "distance_cells": d,
        "symmetric_mean_cells": 0.5 * (d["splatkit_to_open3d"]["mean"] + d["open3d_to_splatkit"]["mean"]),
    }
    print(f"{'':12}{'time s':>10}{'peak MB':>10}{'vertices':>11}{'faces':>11}")
    print(f"{'splatkit':12}{sk_time:>10.2f}{sk_peak:>10.0f}{res['splatkit']['vertices']:>11}{res['splatkit']['faces']:>11}")
    print(f"{'open3d':12}{o3d_stats['seconds']:>10.2f}{o3d_peak:>10.0f}{res['open3d']['vertices']:>11}{res['open3d']['faces']:>11}")
    for k, v in d.items():
        print(f"{k}: mean {v['mean']:.3f} median {v['median']:.3f} p95 {v['p95']:.3f} cells")
    print(f"symmetric mean distance: {res['symmetric_mean_cells']:.3f} cells (cell = {cell:.5g})")
    if a.json:
        json.dump(res, open(a.json, "w"), indent=1)

if __name__ == "__main__":
    main()
