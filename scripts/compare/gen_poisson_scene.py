#!/usr/bin/env python3
"""Generates an oriented point cloud (binary little-endian PLY, float x y z nx ny nz)
for Poisson benchmarks and comparisons, the scene of benches/poisson.rs:
area-proportional samples on a unit sphere (centre (0,0,1.5)), a torus (R=2, r=0.5,
centre z=0.6) and, unless --closed-only, an open 9.5 x 8 plane patch at z=0;
Gaussian position noise along the normal (sigma --noise, default 0.002); outward
normals. Writes a JSON sidecar (<out>.json) with the shape parameters.

usage: gen_poisson_scene.py OUT.ply [--n 1000000] [--seed 0] [--noise 0.002] [--closed-only]
"""
import argparse, json
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--n", type=int, default=1_000_000)
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("--noise", type=float, default=0.002)
ap.add_argument("--closed-only", action="store_true")
a = ap.parse_args()
rng = np.random.default_rng(a.seed)
R, r = 2.0, 0.5
areas = {"sphere": 4 * np.pi, "torus": 4 * np.pi**2 * R * r, "plane": 0.0 if a.closed_only else 9.5 * 8}
tot = sum(areas.values())
ns = int(a.n * areas["sphere"] / tot)
nt = int(a.n * areas["torus"] / tot)
npl = a.n - ns - nt
z = rng.uniform(-1, 1, ns)
ph = rng.uniform(0, 2 * np.pi, ns)
s = np.sqrt(1 - z * z)
ds = np.stack([s * np.cos(ph), s * np.sin(ph), z], 1)
ps = ds + np.array([0, 0, 1.5])
u, v = [], []
while sum(len(x) for x in u) < nt:  # area element R + r cos v: rejection
    uu = rng.uniform(0, 2 * np.pi, nt)
    vv = rng.uniform(0, 2 * np.pi, nt)
    keep = rng.uniform(0, R + r, nt) < R + r * np.cos(vv)
    u.append(uu[keep]); v.append(vv[keep])
u = np.concatenate(u)[:nt]; v = np.concatenate(v)[:nt]
dt = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], 1)
pt = np.stack([R * np.cos(u), R * np.sin(u), 0 * u], 1) + r * dt + np.array([0, 0, 0.6])
pp = np.stack([rng.uniform(-4.75, 4.75, npl), rng.uniform(-4, 4, npl), np.zeros(npl)], 1)
dp = np.tile([0.0, 0.0, 1.0], (npl, 1))
P = np.concatenate([ps, pt, pp]); N = np.concatenate([ds, dt, dp])
P = P + rng.normal(0, a.noise, (len(P), 1)) * N
arr = np.concatenate([P, N], 1).astype("<f4")
with open(a.out, "wb") as f:
    f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % len(arr)
             + "".join("property float %s\n" % c for c in ["x", "y", "z", "nx", "ny", "nz"])
             + "end_header\n").encode())
    f.write(arr.tobytes())
with open(a.out + ".json", "w") as f:
    json.dump({"n": len(arr), "seed": a.seed, "noise": a.noise,
               "sphere": {"center": [0, 0, 1.5], "radius": 1.0},
               "torus": {"center": [0, 0, 0.6], "R": R, "r": r},
               "plane": None if a.closed_only else {"z": 0, "x": [-4.75, 4.75], "y": [-4, 4]}}, f, indent=1)
print(f"wrote {a.out}: {len(arr)} points")
