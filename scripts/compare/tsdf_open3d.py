#!/usr/bin/env python3
"""Fuses the same depth maps with Open3D 0.20 (open3d-cpu, the tensor VoxelBlockGrid: its
legacy ScalableTSDFVolume returns empty meshes in that release) and with
`splatkit tsdf-fuse --depth`, and compares them: wall time and peak memory of each (each
tool in its own child process). The time ratio is like for like: Open3D's clock covers
creating the grid, integrating and extracting (the maps are loaded before it starts),
and splatkit's `fuse_seconds` covers integrating and extracting; the ratio against
splatkit's whole process (reading the maps and writing the PLY too) is printed beside it.
Also: vertex and face counts, and the
distance between the two meshes in voxels (area-uniform seeded samples on each mesh,
exact point-to-triangle distance to the other, Open3D RaycastingScene; mean / median /
p95 per direction, symmetric = mean of the two means).

DIR holds cameras.json (3DGS layout: position, rotation = camera-to-world, fx, fy,
width, height; principal point at the image centre) and, per camera image NAME,
NAME_depth.npy (float32 z-depth, 0 = none) and optionally NAME.png (RGB8), which is what
`splatkit render --outputs rgb,depth` writes.

Conventions passed to Open3D: intrinsic cx = W/2 - 0.5 (its pixel centres are
integers), extrinsic = world-to-camera, depth_scale 1, depth_max = --depth-trunc,
trunc_voxel_multiplier = sdf_trunc / voxel, block resolution 16, and a weight threshold
that keeps every observed voxel (the legacy volume's "weight > 0").

The first run creates a virtual environment (~/.cache/splatkit-compare-venv, or
$SPLATKIT_COMPARE_VENV) with open3d-cpu==0.20.0 and numpy; Open3D needs libusb-1.0
(Debian: apt-get install libusb-1.0-0).

usage: tsdf_open3d.py DIR [--voxel 0.004] [--sdf-trunc 0.016] [--depth-trunc 3.0]
         [--threads 2] [--block-count 10000] [--splatkit target/release/splatkit] [--json OUT]
"""
import argparse, json, os, subprocess, sys, tempfile

VENV = os.environ.get("SPLATKIT_COMPARE_VENV", os.path.expanduser("~/.cache/splatkit-compare-venv"))

def ensure_venv():
    py = os.path.join(VENV, "bin", "python")
    if not os.path.exists(py):
        subprocess.check_call([sys.executable, "-m", "venv", VENV])
        subprocess.check_call([py, "-m", "pip", "install", "-q", "open3d-cpu==0.20.0", "numpy", "scipy"])
    return py

CHILD_O3D = r'''
import sys, os, time, resource, json, numpy as np, open3d as o3d, open3d.core as o3c
d, out, voxel, sdf, trunc = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
block_count = int(sys.argv[6])
cams = json.load(open(os.path.join(d, "cameras.json")))
frames = []
for c in cams:
    stem = os.path.splitext(os.path.basename(c["img_name"]))[0]
    depth = np.load(os.path.join(d, stem + "_depth.npy")).astype(np.float32)
    png = os.path.join(d, stem + ".png")
    color = np.asarray(o3d.io.read_image(png)) if os.path.exists(png) else None
    R = np.array(c["rotation"], dtype=np.float64)      # camera-to-world
    C = np.array(c["position"], dtype=np.float64)
    E = np.eye(4); E[:3, :3] = R.T; E[:3, 3] = -R.T @ C
    W, H = c["width"], c["height"]
    K = np.array([[c["fx"], 0, W / 2 - 0.5], [0, c["fy"], H / 2 - 0.5], [0, 0, 1]])
    frames.append((depth, color, K, E))
dev = o3c.Device("CPU:0")
with_color = all(f[1] is not None for f in frames)
names = ("tsdf", "weight", "color") if with_color else ("tsdf", "weight")
dtypes = (o3c.float32,) * len(names)
chans = ((1), (1), (3)) if with_color else ((1), (1))
t = time.time()
vbg = o3d.t.geometry.VoxelBlockGrid(names, dtypes, chans, voxel_size=voxel, block_resolution=16,
                                    block_count=block_count, device=dev)
for depth, color, K, E in frames:
    dimg = o3d.t.geometry.Image(o3c.Tensor(depth))
    Kt = o3c.Tensor(K, o3c.float64); Et = o3c.Tensor(E, o3c.float64)
    blocks = vbg.compute_unique_block_coordinates(dimg, Kt, Et, depth_scale=1.0, depth_max=trunc,
                                                   trunc_voxel_multiplier=sdf / voxel)
    if with_color:
        # a float depth map takes a float colour image (0-1)
        cimg = o3d.t.geometry.Image(o3c.Tensor(np.ascontiguousarray(color[:, :, :3], dtype=np.float32) / 255.0))
        vbg.integrate(blocks, dimg, cimg, Kt, Kt, Et, depth_scale=1.0, depth_max=trunc,
                      trunc_voxel_multiplier=sdf / voxel)
    else:
        vbg.integrate(blocks, dimg, Kt, Et, depth_scale=1.0, depth_max=trunc,
                      trunc_voxel_multiplier=sdf / voxel)
mesh = vbg.extract_triangle_mesh(weight_threshold=0.5).to_legacy()
el = time.time() - t
o3d.io.write_triangle_mesh(out, mesh)
print(json.dumps({"seconds": el, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "vertices": len(mesh.vertices), "faces": len(mesh.triangles)}))
'''

# Runs a command, then prints its wall time and peak resident memory (its own
# children only, so the Open3D run before it does not count).
CHILD_TIME = r'''
import sys, time, resource, subprocess
t = time.time()
p = subprocess.run(sys.argv[1:], capture_output=True)
el = time.time() - t
sys.stderr.buffer.write(p.stderr)
if p.returncode:
    sys.exit(p.returncode)
sys.stdout.buffer.write(p.stdout)
print("\n%f %d" % (el, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))
'''

CHILD_CMP = r'''
import sys, json, numpy as np, open3d as o3d
a, b, voxel = sys.argv[1], sys.argv[2], float(sys.argv[3])
ma = o3d.io.read_triangle_mesh(a)
mb = o3d.io.read_triangle_mesh(b)
def sample(m, n=200000, seed=1):
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
    d = sc.compute_distance(o3d.core.Tensor(pts, dtype=o3d.core.Dtype.Float32)).numpy() / voxel
    return {"mean": float(d.mean()), "median": float(np.median(d)), "p95": float(np.percentile(d, 95))}
s2o, o2s = dist(ma, mb), dist(mb, ma)
print(json.dumps({"splatkit_to_open3d": s2o, "open3d_to_splatkit": o2s,
                  "symmetric_mean_voxels": 0.5 * (s2o["mean"] + o2s["mean"])}))
'''

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--voxel", type=float, default=0.004)
    ap.add_argument("--sdf-trunc", type=float, default=0.016)
    ap.add_argument("--depth-trunc", type=float, default=3.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--block-count", type=int, default=10000,
                    help="Open3D's initial hash-map capacity in 16^3 blocks (it grows when full)")
    ap.add_argument("--splatkit", default="target/release/splatkit")
    ap.add_argument("--json")
    a = ap.parse_args()
    py = ensure_venv()
    env = dict(os.environ, OMP_NUM_THREADS=str(a.threads))
    with tempfile.TemporaryDirectory() as tmp:
        o3d_out = os.path.join(tmp, "open3d.ply")
        sk_out = os.path.join(tmp, "splatkit.ply")
        o3d_res = json.loads(subprocess.check_output(
            [py, "-c", CHILD_O3D, a.dir, o3d_out, str(a.voxel), str(a.sdf_trunc), str(a.depth_trunc),
             str(a.block_count)],
            env=env).decode().strip().splitlines()[-1])
        cmd = [sys.executable, "-c", CHILD_TIME, a.splatkit, "tsdf-fuse", "--depth", a.dir,
               "--cameras", os.path.join(a.dir, "cameras.json"), "-o", sk_out,
               "--voxel", str(a.voxel), "--sdf-trunc", str(a.sdf_trunc),
               "--depth-trunc", str(a.depth_trunc), "--threads", str(a.threads), "--json", "-q"]
        if any(f.endswith(".png") and not f.endswith("_depth.png") for f in os.listdir(a.dir)):
            cmd[cmd.index("--cameras"):cmd.index("--cameras")] = ["--color", a.dir]
        p = subprocess.run(cmd, capture_output=True, check=True)
        lines = p.stdout.decode().strip().splitlines()
        wall, kb = lines[-1].split()
        sk = json.loads("\n".join(lines[:-1]))
        sk_res = {"seconds": float(wall), "fuse_seconds": sk["fuse_seconds"],
                  "peak_mb": int(kb) / 1024, "vertices": sk["vertices"], "faces": sk["faces"]}
        cmp = json.loads(subprocess.check_output(
            [py, "-c", CHILD_CMP, sk_out, o3d_out, str(a.voxel)]).decode().strip().splitlines()[-1])
    res = {"dir": a.dir, "voxel": a.voxel, "sdf_trunc": a.sdf_trunc, "depth_trunc": a.depth_trunc,
           "threads": a.threads, "open3d": o3d_res, "splatkit": sk_res,
           # like for like: both timings cover integration + extraction only
           "time_ratio_open3d_over_splatkit": o3d_res["seconds"] / sk_res["fuse_seconds"],
           # splatkit's whole process (reading the maps, fusing, writing the PLY)
           "time_ratio_open3d_over_splatkit_process": o3d_res["seconds"] / sk_res["seconds"],
           "vertex_ratio": sk_res["vertices"] / max(o3d_res["vertices"], 1), "distance": cmp}
    print(json.dumps(res, indent=1))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)

if __name__ == "__main__":
    main()
