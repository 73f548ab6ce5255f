#!/usr/bin/env python3
"""NumPy/SciPy reference of Gaussian Opacity Fields' tetrahedral mesh extraction
(`extract_mesh.py` of autonomousvision/gaussian-opacity-fields, commit 5245b20),
written from the rules collected in docs/gof_extraction.md (each rule there has
its source file and line numbers). Used to check splatkit's CPU implementation.

Usage (from the repository root):

    python3 scripts/compare/gof_reference.py SCENE.ply CAMERAS.json -o MESH.ply \
        [--filter-mesh] [--texture-mesh] [--near 0.02] [--far 1e6] \
        [--kernel-size 0] [--white-background] [--json OUT.json] [--sphere-radius R] [--cgal]
    python3 scripts/compare/gof_reference.py --make-test-scene DIR
    python3 scripts/compare/gof_reference.py --self-test

Needs numpy, scipy and plyfile (`pip install numpy scipy plyfile`; the script
installs them with pip when they are missing).

SCENE is a 3DGS PLY (x, y, z, f_dc_*, f_rest_*, opacity logit, scale_* (log),
rot_* (w, x, y, z)); a `filter_3D` column (GOF / Mip-Splatting) is applied as
GOF does (scales sqrt(s^2 + f^2), opacity times sqrt(prod s^2 / prod(s^2 + f^2))).
Without it the filter is 0 (GOF itself requires the column).
CAMERAS is a 3DGS `cameras.json`: a list of {width, height, position (camera
centre), rotation (3x3 camera-to-world, columns = camera x right, y down,
z forward in world), fx, fy}; the principal point is the image centre, as in GOF.
Every camera is used (GOF uses the training cameras).

What it does (see docs/gof_extraction.md for the exact rules):
1. tetra points: per Gaussian the 8 corners of its box at +-3 sigma (filtered
   scales) and its centre; per-point scale = 3 * max filtered scale; points kept
   when some camera sees them at depth in [near, far] and pixel coordinates in
   [0, W-1] x [0, H-1] (W, H of the first camera).
2. cells: Delaunay tetrahedra of the kept points. GOF uses CGAL (exact
   predicates, symbolic perturbation for co-spherical points, exact duplicate
   points merged) and keeps every finite cell, positively oriented. Here
   scipy.spatial.Delaunay (Qhull, options "Qbb Qc Qz Q12", floating point
   predicates) is used and each cell is re-oriented to positive orientation
   (two vertices swapped when the signed volume is negative). Where the input
   is degenerate -- the 8 box corners of one Gaussian are co-spherical,
   duplicates, flat configurations -- Qhull may choose a different (equally
   Delaunay) set of cells than CGAL, may leave near-duplicates out as
   "coplanar" points, and may keep zero-volume slivers; so cell counts, face
   order and a few faces can differ from GOF while the surface agrees.
   `--cgal` uses CGAL's own Python bindings instead (`pip install cgal`): the
   same cells as GOF (cell and face order may still differ). On the sphere test
   scene both give the same 69,400 cells.
3. opacity of each point: for every view, the kernel's rules are replayed
   pixel by pixel (preprocessing, 16x16 tiles, depth order, the per-pixel pass
   with the centre ray and 4 corner rays, the 1/255 and T < 1e-4 rules, the 0.99
   cap, the contributor list and its cap of 1024, the point -> pixel assignment
   with the half-open footprint, the per-point pass with t clamped at the point
   depth); points outside every pixel keep 1.0. alpha = 1 - min over views.
4. sdf = alpha - 0.5, marching tetrahedra (kaolin's tables, GOF's copy), then 8
   bisection steps on each crossing edge, vertices = final mid-points.
5. --filter-mesh keeps vertices whose edge length <= sum of the two end scales;
   --texture-mesh adds vertex colours (the rendered pixel colour of the view
   where the point's opacity is lowest).

Arithmetic: the kernel's float32 quantities are float32 here; a few values the
kernel computes in double (S^-2, the ray's minimum of the quadratic, the 2-D
filter coefficient) are computed in float64 and rounded where the kernel stores
a float. CUDA's expf / FMA contraction are not reproduced bit for bit.

Not a fast implementation: fine for <= a few thousand Gaussians and a few
small views (minutes at most).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

try:
    import numpy as np
    import scipy.spatial
    from plyfile import PlyData, PlyElement
except ImportError:
    subprocess.check_call([sys.executable, "-m", "pip", "install", "-q", "numpy", "scipy", "plyfile"])
    import numpy as np
    import scipy.spatial
    from plyfile import PlyData, PlyElement

F32 = np.float32

# Kernel constants (auxiliary.h, config.h of GOF's diff-gaussian-rasterization).
BLOCK = 16
NEAR_PLANE = 0.2
MAX_CONTRIBUTORS = 256 * 4
ALPHA_MIN = F32(1.0) / F32(255.0)
T_MIN = F32(0.0001)
ALPHA_MAX = F32(0.99)
# Corner-ray offsets in pixels: centre first (forward.cu integrateCUDA).
OFF_X = (0.0, -0.5, 0.5, -0.5, 0.5)
OFF_Y = (0.0, -0.5, -0.5, 0.5, 0.5)

SH_C0 = 0.28209479177387814
SH_C1 = 0.4886025119029199
SH_C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792, 0.5462742152960396)
SH_C3 = (-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
         -0.4570457994644658, 1.445305721320277, -0.5900435899266435)

# Marching-tetrahedra tables (GOF utils/tetmesh.py, from kaolin).
TRIANGLE_TABLE = np.array([
    [-1, -1, -1, -1, -1, -1], [1, 0, 2, -1, -1, -1], [4, 0, 3, -1, -1, -1], [1, 4, 2, 1, 3, 4],
    [3, 1, 5, -1, -1, -1], [2, 3, 0, 2, 5, 3], [1, 4, 0, 1, 5, 4], [4, 2, 5, -1, -1, -1],
    [4, 5, 2, -1, -1, -1], [4, 1, 0, 4, 5, 1], [3, 2, 0, 3, 5, 2], [1, 3, 5, -1, -1, -1],
    [4, 1, 2, 4, 3, 1], [3, 0, 4, -1, -1, -1], [2, 0, 1, -1, -1, -1], [-1, -1, -1, -1, -1, -1],
], dtype=np.int64)
NUM_TRIANGLES = np.array([0, 1, 1, 2, 1, 2, 2, 1, 1, 2, 2, 1, 2, 1, 1, 0], dtype=np.int64)
TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)


# ----------------------------------------------------------------------------- input

def load_scene(path):
    """3DGS PLY -> dict of float32 arrays (activated values where GOF activates)."""
    v = PlyData.read(path).elements[0]
    names = [p.name for p in v.properties]
    need = ["x", "y", "z", "opacity", "f_dc_0", "f_dc_1", "f_dc_2",
            "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    missing = [n for n in need if n not in names]
    if missing:
        sys.exit(f"{path}: missing vertex properties {missing}")
    col = lambda n: np.asarray(v[n], dtype=np.float64)
    xyz = np.stack([col("x"), col("y"), col("z")], 1).astype(F32)
    n = len(xyz)
    rest = sorted((p for p in names if p.startswith("f_rest_")), key=lambda s: int(s.split("_")[-1]))
    k = len(rest) // 3 + 1
    if 3 * (k - 1) != len(rest) or int(round(math.sqrt(k))) ** 2 != k:
        sys.exit(f"{path}: {len(rest)} f_rest_* properties is not 3 * ((d+1)^2 - 1)")
    sh = np.zeros((n, k, 3), F32)
    sh[:, 0, :] = np.stack([col(f"f_dc_{i}") for i in range(3)], 1)
    if rest:
        r = np.stack([col(s) for s in rest], 1).reshape(n, 3, k - 1)  # channel-major as in 3DGS
        sh[:, 1:, :] = r.transpose(0, 2, 1)
    scale = np.exp(np.stack([col(f"scale_{i}") for i in range(3)], 1)).astype(F32)
    q = np.stack([col(f"rot_{i}") for i in range(4)], 1).astype(F32)
    q = q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), F32(1e-12))  # F.normalize
    op = (1.0 / (1.0 + np.exp(-col("opacity")))).astype(F32)
    filt = col("filter_3D").astype(F32) if "filter_3D" in names else np.zeros(n, F32)
    s2 = scale * scale
    s2f = s2 + (filt * filt)[:, None]
    scale_f = np.sqrt(s2f).astype(F32)                          # get_scaling_with_3D_filter
    coef = np.sqrt(np.prod(s2, 1) / np.prod(s2f, 1)).astype(F32)
    opacity_f = (op * coef).astype(F32)                         # get_opacity_with_3D_filter
    for name, a in (("position", xyz), ("scale", scale_f), ("rotation", q), ("opacity", opacity_f)):
        if not np.all(np.isfinite(a)):
            sys.exit(f"{path}: non-finite {name} in vertex {int(np.argwhere(~np.isfinite(a))[0][0])}")
    return dict(xyz=xyz, sh=sh, sh_degree=int(round(math.sqrt(k))) - 1, scale=scale_f,
                rot=q, opacity=opacity_f, has_filter=("filter_3D" in names))


def quat_to_rot(q):
    """(N,4) w,x,y,z -> (N,3,3) rotation (build_rotation, general_utils.py)."""
    r, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    R = np.empty((len(q), 3, 3), q.dtype)
    R[:, 0, 0] = 1 - 2 * (y * y + z * z); R[:, 0, 1] = 2 * (x * y - r * z); R[:, 0, 2] = 2 * (x * z + r * y)
    R[:, 1, 0] = 2 * (x * y + r * z); R[:, 1, 1] = 1 - 2 * (x * x + z * z); R[:, 1, 2] = 2 * (y * z - r * x)
    R[:, 2, 0] = 2 * (x * z - r * y); R[:, 2, 1] = 2 * (y * z + r * x); R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return R


class Camera:
    """One view: W, H, fx, fy, world->view (float32 4x4) and full projection."""

    def __init__(self, d, where):
        try:
            self.W, self.H = int(d["width"]), int(d["height"])
            fx, fy = float(d["fx"]), float(d["fy"])
            R = np.asarray(d["rotation"], np.float64).reshape(3, 3)
            C = np.asarray(d["position"], np.float64).reshape(3)
        except (KeyError, TypeError, ValueError) as e:
            sys.exit(f"{where}: bad camera entry ({e})")
        if self.W <= 0 or self.H <= 0 or not (fx > 0 and fy > 0):
            sys.exit(f"{where}: width/height/fx/fy must be positive")
        # Camera(): FoV from focal, focal_x = W / (2 tan(FoVx / 2)) (cameras.py 61-64).
        self.fovx = 2 * math.atan(self.W / (2 * fx))
        self.fovy = 2 * math.atan(self.H / (2 * fy))
        self.fx = self.W / (2 * math.tan(self.fovx / 2))
        self.fy = self.H / (2 * math.tan(self.fovy / 2))
        w2v = np.eye(4)
        w2v[:3, :3] = R.T
        w2v[:3, 3] = -R.T @ C
        self.w2v = w2v.astype(F32)                          # getWorld2View2 -> float32
        self.campos = np.linalg.inv(self.w2v.astype(np.float64))[:3, 3].astype(F32)
        tx, ty = math.tan(self.fovx / 2), math.tan(self.fovy / 2)
        zn, zf = 0.01, 100.0
        P = np.zeros((4, 4), F32)                           # getProjectionMatrix
        P[0, 0] = 1 / tx; P[1, 1] = 1 / ty
        P[3, 2] = 1.0; P[2, 2] = zf / (zf - zn); P[2, 3] = -(zf * zn) / (zf - zn)
        self.full = (P @ self.w2v).astype(F32)
        self.fx32 = F32(self.W / (2.0 * F32(math.tan(self.fovx * 0.5))))  # rasterizer_impl.cu 566-567
        self.fy32 = F32(self.H / (2.0 * F32(math.tan(self.fovy * 0.5))))
        self.tanx, self.tany = F32(tx), F32(ty)


def load_cameras(path):
    with open(path) as f:
        data = json.load(f)
    if not isinstance(data, list) or not data:
        sys.exit(f"{path}: expected a non-empty JSON list of cameras")
    return [Camera(d, f"{path}: camera {i}") for i, d in enumerate(data)]


# ----------------------------------------------------------------------------- tetra points

def tetra_points(g, cams, near, far):
    """Box corners (+-3 sigma) and centres, their scales, filtered by the frustum mask."""
    corners = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], F32)  # trimesh box * 2
    R = quat_to_rot(g["rot"])
    s3 = g["scale"] * F32(3.0)
    local = corners[None, :, :] * s3[:, None, :]                 # (N, 8, 3)
    world = np.einsum("nij,nkj->nki", R, local) + g["xyz"][:, None, :]
    pts = np.concatenate([world.reshape(-1, 3), g["xyz"]], 0).astype(F32)
    smax = s3.max(1)
    pscale = np.concatenate([np.repeat(smax, 8), smax]).astype(F32)
    W, H = cams[0].W, cams[0].H                                  # first camera's size for all
    keep = np.zeros(len(pts), bool)
    hom = np.concatenate([pts, np.ones((len(pts), 1), F32)], 1)
    for c in cams:
        v = (hom @ c.w2v.T)[:, :3]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (c.fx * v[:, 0] + W / 2 * v[:, 2]) / v[:, 2]
            w = (c.fy * v[:, 1] + H / 2 * v[:, 2]) / v[:, 2]
        z = v[:, 2]
        keep |= (z >= near) & (z <= far) & (u >= 0) & (u <= W - 1) & (w >= 0) & (w <= H - 1)
    return pts[keep], pscale[keep]


def triangulate_cgal(points):
    """GOF's triangulation through CGAL's own Python bindings (`pip install cgal`):
    Delaunay_triangulation_3 (exact predicates), every finite cell in CGAL's vertex order.
    Cells come back as coordinates and are mapped to the first point index with them."""
    try:
        from CGAL.CGAL_Kernel import Point_3
        from CGAL.CGAL_Triangulation_3 import Delaunay_triangulation_3
    except ImportError:
        sys.exit("--cgal needs CGAL's Python bindings: pip install cgal")
    p64 = points.astype(np.float64)
    dt = Delaunay_triangulation_3()
    dt.insert([Point_3(float(x), float(y), float(z)) for x, y, z in p64])
    if not dt.is_valid():
        sys.exit("CGAL: triangulation failed")
    index = {}
    for i, q in enumerate(map(tuple, p64.tolist())):
        index.setdefault(q, i)
    cells = []
    for c in dt.finite_cells():
        row = []
        for j in range(4):
            q = c.vertex(j).point()
            row.append(index[(q.x(), q.y(), q.z())])
        cells.append(row)
    cells = np.array(cells, np.int64).reshape(-1, 4)
    dropped = len(points) - len(np.unique(cells))
    return cells, 0, dropped


def triangulate(points):
    """Delaunay cells, each positively oriented (CGAL's convention)."""
    tri = scipy.spatial.Delaunay(points.astype(np.float64))
    cells = tri.simplices.astype(np.int64)
    p = points.astype(np.float64)[cells]
    vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    neg = vol < 0
    cells[neg] = cells[neg][:, [0, 1, 3, 2]]
    return cells, int(np.sum(vol == 0)), len(tri.coplanar)


# ----------------------------------------------------------------------------- rasteriser

def sh_colour(g, cam):
    """computeColorFromSH: degree from the PLY, clamped at 0."""
    d = g["xyz"] - cam.campos[None, :]
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    x, y, z = d[:, 0:1], d[:, 1:2], d[:, 2:3]
    sh = g["sh"]
    res = SH_C0 * sh[:, 0]
    deg = g["sh_degree"]
    if deg > 0:
        res = res - SH_C1 * y * sh[:, 1] + SH_C1 * z * sh[:, 2] - SH_C1 * x * sh[:, 3]
        if deg > 1:
            xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
            res = (res + SH_C2[0] * xy * sh[:, 4] + SH_C2[1] * yz * sh[:, 5]
                   + SH_C2[2] * (2 * zz - xx - yy) * sh[:, 6] + SH_C2[3] * xz * sh[:, 7]
                   + SH_C2[4] * (xx - yy) * sh[:, 8])
            if deg > 2:
                res = (res + SH_C3[0] * y * (3 * xx - yy) * sh[:, 9] + SH_C3[1] * xy * z * sh[:, 10]
                       + SH_C3[2] * y * (4 * zz - xx - yy) * sh[:, 11]
                       + SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy) * sh[:, 12]
                       + SH_C3[4] * x * (4 * zz - xx - yy) * sh[:, 13]
                       + SH_C3[5] * z * (xx - yy) * sh[:, 14] + SH_C3[6] * x * (xx - 3 * yy) * sh[:, 15])
    return np.maximum(res + 0.5, 0).astype(F32)


def quad_coeffs(v2g, rx, ry):
    """AA, BB, CC of the ray (rx, ry, 1) for Gaussians v2g (... ,10); float32."""
    s = [v2g[..., i] for i in range(10)]
    n0 = s[0] * rx + s[1] * ry + s[2]
    n1 = s[1] * rx + s[3] * ry + s[4]
    n2 = s[2] * rx + s[4] * ry + s[5]
    AA = rx * n0 + ry * n1 + n2
    BB = F32(2) * (s[6] * rx + s[7] * ry + s[8])
    return AA.astype(F32), BB.astype(F32), s[9].astype(F32)


class ViewRaster:
    """Per-view preprocessing and the per-pixel pass (independent of the points)."""

    def __init__(self, g, cam, kernel_size, bg):
        self.cam = cam
        W, H = cam.W, cam.H
        self.gx, self.gy = (W + BLOCK - 1) // BLOCK, (H + BLOCK - 1) // BLOCK
        self._preprocess(g, cam, F32(kernel_size))
        self._bin()
        self.bg = np.asarray(bg, F32)
        self._pixel_pass()

    # preprocessCUDA (forward.cu 284-404), computeCov2D (74-124), computeView2Gaussian (168-279)
    def _preprocess(self, g, cam, ks):
        n = len(g["xyz"])
        hom = np.concatenate([g["xyz"], np.ones((n, 1), F32)], 1)
        pv = (hom @ cam.w2v.T)[:, :3].astype(F32)
        ph = (hom @ cam.full.T).astype(F32)
        ok = pv[:, 2] > F32(0.2)                                  # in_frustum
        pw = F32(1) / (ph[:, 3] + F32(1e-7))
        px, py = ph[:, 0] * pw, ph[:, 1] * pw
        mx = (((px.astype(np.float64) + 1.0) * cam.W - 1.0) * 0.5).astype(F32)   # ndc2Pix
        my = (((py.astype(np.float64) + 1.0) * cam.H - 1.0) * 0.5).astype(F32)
        R = quat_to_rot(g["rot"])                                 # Gaussian -> world (columns = axes)
        S = g["scale"]
        cov3 = np.einsum("nij,nj,nkj->nik", R, S * S, R).astype(F32)
        Rw = cam.w2v[:3, :3]
        t = pv.copy()
        tz = np.where(ok, t[:, 2], F32(1))
        limx, limy = F32(1.3) * cam.tanx, F32(1.3) * cam.tany
        t[:, 0] = np.clip(t[:, 0] / tz, -limx, limx) * tz
        t[:, 1] = np.clip(t[:, 1] / tz, -limy, limy) * tz
        J = np.zeros((n, 2, 3), F32)
        J[:, 0, 0] = cam.fx32 / tz; J[:, 0, 2] = -(cam.fx32 * t[:, 0]) / (tz * tz)
        J[:, 1, 1] = cam.fy32 / tz; J[:, 1, 2] = -(cam.fy32 * t[:, 1]) / (tz * tz)
        T = np.einsum("nij,jk->nik", J, Rw)
        cov = np.einsum("nij,njk,nlk->nil", T, cov3, T).astype(F32)
        a, b, c = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
        det0 = np.maximum(1e-6, a.astype(np.float64) * c - b.astype(np.float64) * b).astype(F32)
        det1 = np.maximum(1e-6, (a + ks).astype(np.float64) * (c + ks) - b.astype(np.float64) * b).astype(F32)
        coef = np.sqrt(det0.astype(np.float64) / (det1.astype(np.float64) + 1e-6) + 1e-6).astype(F32)
        coef = np.where((det0 <= 1e-6) | (det1 <= 1e-6), F32(0), coef)
        a, c = a + ks, c + ks
        det = a * c - b * b
        ok &= det != 0
        mid = F32(0.5) * (a + c)
        lam1 = mid + np.sqrt(np.maximum(F32(0.1), mid * mid - det))
        lam2 = mid - np.sqrt(np.maximum(F32(0.1), mid * mid - det))
        radius = np.ceil(F32(3) * np.sqrt(np.maximum(lam1, lam2)))
        radius = np.where(ok & np.isfinite(radius), radius, 0)
        # getRect (auxiliary.h 64-74): C int conversion truncates towards zero, then clamp.
        def tr(v, hi):
            v = np.where(np.isfinite(v), v, 0)
            return np.clip(np.trunc(np.clip(v, -1e9, 1e9)), 0, hi).astype(np.int64)
        self.rx0 = tr((mx - radius) / F32(BLOCK), self.gx)
        self.ry0 = tr((my - radius) / F32(BLOCK), self.gy)
        self.rx1 = tr((mx + radius + F32(BLOCK - 1)) / F32(BLOCK), self.gx)
        self.ry1 = tr((my + radius + F32(BLOCK - 1)) / F32(BLOCK), self.gy)
        ok &= (self.rx1 - self.rx0) * (self.ry1 - self.ry0) != 0
        self.visible = ok
        self.depth = pv[:, 2]
        self.opacity = (g["opacity"] * coef).astype(F32)          # conic_opacity.w
        self.rgb = sh_colour(g, cam)
        # view2gaussian: G2V = W2V * G2W; Rg = rotation of G2V, t2 = -Rg^T t = camera in Gaussian frame.
        Rg = np.einsum("ij,njk->nik", Rw.astype(np.float64), R.astype(np.float64))
        t2 = -np.einsum("nji,nj->ni", Rg, pv.astype(np.float64))
        Sinv = 1.0 / (S.astype(np.float64) ** 2 + 1e-7)
        Sig = np.einsum("nij,nj,nkj->nik", Rg, Sinv, Rg)          # Rg diag(S^-2) Rg^T
        B = np.einsum("nij,nj,nj->ni", Rg, Sinv, t2)              # Rg diag(S^-2) t2
        C = np.einsum("ni,ni,ni->n", t2, Sinv, t2)
        self.v2g = np.stack([Sig[:, 0, 0], Sig[:, 0, 1], Sig[:, 0, 2], Sig[:, 1, 1], Sig[:, 1, 2],
                             Sig[:, 2, 2], B[:, 0], B[:, 1], B[:, 2], C], 1).astype(F32)

    # duplicateWithKeys + radix sort by (tile, depth bits), stable -> ties by index
    def _bin(self):
        tiles, gids = [], []
        for i in np.nonzero(self.visible)[0]:
            ys, xs = np.meshgrid(np.arange(self.ry0[i], self.ry1[i]), np.arange(self.rx0[i], self.rx1[i]),
                                 indexing="ij")
            t = (ys * self.gx + xs).ravel()
            tiles.append(t)
            gids.append(np.full(len(t), i))
        ntile = self.gx * self.gy
        if tiles:
            tiles, gids = np.concatenate(tiles), np.concatenate(gids)
            order = np.lexsort((gids, self.depth[gids].view(np.uint32), tiles))
            tiles, gids = tiles[order], gids[order]
        else:
            tiles = gids = np.zeros(0, np.int64)
        counts = np.bincount(tiles, minlength=ntile)
        self.lmax = int(counts.max()) if ntile else 0
        self.lists = np.full((ntile, max(self.lmax, 1)), -1, np.int64)
        start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        pos = np.arange(len(tiles)) - start[tiles]
        self.lists[tiles, pos] = gids
        self.counts = counts

    # integrateCUDA first part (forward.cu 831-1008): 5 rays per pixel
    def _pixel_pass(self):
        cam = self.cam
        W, H = cam.W, cam.H
        py, px = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
        px, py = px.ravel(), py.ravel()
        self.pix_tile = (py // BLOCK) * self.gx + px // BLOCK
        npix = W * H
        fxs = [(px.astype(F32) + F32(0.5)).astype(np.float64), (py.astype(F32) + F32(0.5)).astype(np.float64)]
        rx = np.stack([((fxs[0] + o) - W / 2.0) / float(cam.fx32) for o in OFF_X], 1).astype(F32)  # (npix,5)
        ry = np.stack([((fxs[1] + o) - H / 2.0) / float(cam.fy32) for o in OFF_Y], 1).astype(F32)
        Ts = np.ones((npix, 5), F32)
        Cc = np.zeros((npix, 3), F32)
        ncontrib = np.zeros(npix, np.int64)
        last = np.zeros(npix, np.int64)
        used_mat = np.zeros((npix, max(self.lmax, 1)), bool)
        for j in range(self.lmax):
            gid = self.lists[self.pix_tile, j]
            sel = np.nonzero((gid >= 0) & (ncontrib < MAX_CONTRIBUTORS))[0]
            if len(sel) == 0:
                continue
            gs = gid[sel]
            v = self.v2g[gs][:, None, :]                          # (m,1,10)
            AA, BB, CC = quad_coeffs(v, rx[sel], ry[sel])
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                t = -BB / (F32(2) * AA)
                minv = -(BB / AA).astype(np.float64) * (BB.astype(np.float64) / 4.0) + CC.astype(np.float64)
                power = (-0.5 * minv).astype(F32)
                power = np.where(power > 0, F32(0), power)
                alpha = np.fmin(ALPHA_MAX, self.opacity[gs][:, None] * np.exp(power)).astype(F32)  # fminf
            T = Ts[sel]
            testT = (T * (F32(1) - alpha)).astype(F32)
            # NaN comparisons are false in C: a NaN t or alpha is not skipped by these tests.
            skip = (t <= F32(NEAR_PLANE)) | (alpha < ALPHA_MIN) | (testT < T_MIN)
            acc = ~skip
            c0 = acc[:, 0]
            w = (alpha[:, 0] * T[:, 0]).astype(F32)
            Cc[sel[c0]] += self.rgb[gs[c0]] * w[c0][:, None]
            Ts[sel] = np.where(acc, testT, T)
            used = acc.any(1)
            us = sel[used]
            last[us] = j + 1
            used_mat[us, j] = True
            ncontrib[us] += 1
        self.T0 = Ts[:, 0]
        self.pix_colour = (Cc + self.T0[:, None] * self.bg[None, :]).astype(F32)
        self.used = used_mat
        self.last = last
        self.ncontrib = ncontrib
        if self.lmax > 65535:
            self._wrap_uint16()

    def _wrap_uint16(self):
        """contributed_ids are uint16 (forward.cu 879, 983, 1145): replay the second pass's matching."""
        for p in np.nonzero(self.ncontrib)[0]:
            stored = (np.nonzero(self.used[p])[0] + 1) % 65536
            keep = np.zeros(self.used.shape[1], bool)
            ptr = 0
            for it in range(1, int(self.last[p]) + 1):
                if ptr < len(stored) and it == stored[ptr]:
                    keep[it - 1] = True
                    ptr += 1
            self.used[p] = keep

    # preprocessPointsCUDA (forward.cu 723-766) + per-point pass (1014-1211)
    def integrate(self, points):
        cam = self.cam
        W, H = cam.W, cam.H
        n = len(points)
        out_alpha = np.ones(n, F32)                  # torch::full({PN}, 1.0) (rasterize_points.cu 277)
        out_col = np.zeros((n, 3), F32)              # torch::full({PN, 3}, 0.0) (278)
        hom = np.concatenate([points.astype(F32), np.ones((n, 1), F32)], 1)
        pv = (hom @ cam.w2v.T)[:, :3].astype(F32)
        ok = pv[:, 2] > F32(0.2)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            u = (cam.fx32 * pv[:, 0] / (pv[:, 2] + F32(1e-7))).astype(np.float64) + W / 2.0
            v = (cam.fy32 * pv[:, 1] / (pv[:, 2] + F32(1e-7))).astype(np.float64) + H / 2.0
        u, v = u.astype(F32), v.astype(F32)
        ok &= (u >= 0) & (u < W) & (v >= 0) & (v < H)
        idx = np.nonzero(ok)[0]
        if len(idx) == 0:
            return out_alpha, out_col
        pxl = np.floor(u[idx]).astype(np.int64)     # pix <= u < pix + 1 (half-open footprint)
        pyl = np.floor(v[idx]).astype(np.int64)
        pid = pyl * W + pxl
        tile = (pyl // BLOCK) * self.gx + pxl // BLOCK
        rxp = ((u[idx].astype(np.float64) - W / 2.0) / float(cam.fx32)).astype(F32)
        ryp = ((v[idx].astype(np.float64) - H / 2.0) / float(cam.fy32)).astype(F32)
        dep = pv[idx, 2]
        order = np.argsort(tile, kind="stable")
        bounds = np.searchsorted(tile[order], np.arange(self.gx * self.gy + 1))
        for t in range(self.gx * self.gy):
            sl = order[bounds[t]:bounds[t + 1]]
            L = int(self.counts[t])
            if len(sl) == 0:
                continue
            gl = self.lists[t, :L]
            use = self.used[pid[sl], :L]                          # (m, L)
            if L == 0 or not use.any():                           # written as 0: no contributor
                out_alpha[idx[sl]] = 0
                out_col[idx[sl]] = self.pix_colour[pid[sl]]
                continue
            AA, BB, CC = quad_coeffs(self.v2g[gl][None, :, :], rxp[sl][:, None], ryp[sl][:, None])
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                tt = -BB / (F32(2) * AA)
                d = dep[sl][:, None]
                tt = np.where(tt > d, d, tt).astype(F32)
                power = (F32(-0.5) * (AA * tt * tt + BB * tt + CC)).astype(F32)
                alpha = np.fmin(ALPHA_MAX, self.opacity[gl][None, :] * np.exp(power)).astype(F32)
            alpha = np.where(use & ~(alpha < ALPHA_MIN), alpha, F32(0)).astype(F32)
            one_minus = (F32(1) - alpha).astype(F32)
            Tex = np.concatenate([np.ones((len(sl), 1), F32), np.cumprod(one_minus, axis=1, dtype=F32)[:, :-1]], 1)
            acc = np.cumsum((alpha * Tex).astype(F32), axis=1, dtype=F32)[:, -1]
            out_alpha[idx[sl]] = acc
            out_col[idx[sl]] = self.pix_colour[pid[sl]]
        return out_alpha, out_col


def evaluate_alpha(points, rasters, return_color=False):
    """evaluage_alpha (extract_mesh.py 17-34): 1 - min over views of the integrated opacity."""
    final = np.ones(len(points), F32)
    colour = np.ones((len(points), 3), F32)
    for r in rasters:
        a, c = r.integrate(points)
        if return_color:
            colour = np.where((a < final)[:, None], c, colour)
        final = np.minimum(final, a)
    alpha = (F32(1) - final).astype(F32)
    return (alpha, colour) if return_color else alpha


# ----------------------------------------------------------------------------- meshing

def marching_tetrahedra(cells, sdf):
    """utils/tetmesh.py: returns crossing edges (i<j, sorted), faces."""
    occ = sdf > 0
    occ4 = occ[cells]
    s = occ4.sum(1)
    valid = (s > 0) & (s < 4)
    vc = cells[valid]
    edges = vc[:, TET_EDGES].reshape(-1, 2)
    edges = np.sort(edges, axis=1)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    cross = occ[uniq].sum(1) == 1
    mapping = np.full(len(uniq), -1, np.int64)
    mapping[cross] = np.arange(cross.sum())
    idx_map = mapping[inv].reshape(-1, 6)
    tetindex = (occ4[valid] * np.array([1, 2, 4, 8])).sum(1)
    ntri = NUM_TRIANGLES[tetindex]
    f1 = np.take_along_axis(idx_map[ntri == 1], TRIANGLE_TABLE[tetindex[ntri == 1]][:, :3], 1).reshape(-1, 3)
    f2 = np.take_along_axis(idx_map[ntri == 2], TRIANGLE_TABLE[tetindex[ntri == 2]][:, :6], 1).reshape(-1, 3)
    return uniq[cross], np.concatenate([f1, f2], 0)


def extract(g, cams, near, far, kernel_size, bg, filter_mesh, texture_mesh, log=print, use_cgal=False):
    timings = {}
    t0 = time.perf_counter()
    points, pscale = tetra_points(g, cams, near, far)
    timings["tetra_points_s"] = time.perf_counter() - t0
    log(f"tetra points: {len(points)} of {9 * len(g['xyz'])}")
    t0 = time.perf_counter()
    cells, flat, dropped = triangulate_cgal(points) if use_cgal else triangulate(points)
    timings["triangulation_s"] = time.perf_counter() - t0
    log(f"cells: {len(cells)} ({flat} zero-volume, {dropped} points in no cell)")
    t0 = time.perf_counter()
    rasters = [ViewRaster(g, c, kernel_size, bg) for c in cams]
    timings["pixel_pass_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    alpha = evaluate_alpha(points, rasters)
    sdf = (alpha - F32(0.5)).astype(F32)
    ends, faces = marching_tetrahedra(cells, sdf)
    timings["tetra_alpha_and_marching_s"] = time.perf_counter() - t0
    log(f"marching tetrahedra: {len(ends)} vertices, {len(faces)} faces")
    left, right = points[ends[:, 0]].copy(), points[ends[:, 1]].copy()
    lsdf = sdf[ends[:, 0]].copy()
    distance = np.linalg.norm(left - right, axis=1)
    scale = pscale[ends[:, 0]] + pscale[ends[:, 1]]
    t0 = time.perf_counter()
    for _ in range(8):
        mid = ((left + right) / F32(2)).astype(F32)
        msdf = (evaluate_alpha(mid, rasters) - F32(0.5)).astype(F32)
        low = ((msdf < 0) & (lsdf < 0)) | ((msdf > 0) & (lsdf > 0))
        lsdf[low] = msdf[low]
        left[low] = mid[low]
        right[~low] = mid[~low]
    verts = ((left + right) / F32(2)).astype(F32)
    timings["binary_search_s"] = time.perf_counter() - t0
    colours = None
    if texture_mesh:
        _, col = evaluate_alpha(verts, rasters, return_color=True)
        colours = np.clip(col * 255, 0, 255).astype(np.uint8)  # GOF: astype(uint8) without clipping
    if filter_mesh:
        keep = distance <= scale
        fkeep = keep[faces].all(1)
        remap = np.cumsum(keep) - 1
        faces = remap[faces[fkeep]]
        verts = verts[keep]
        if colours is not None:
            colours = colours[keep]
    counts = dict(gaussians=len(g["xyz"]), points=len(points), cells=len(cells), zero_volume_cells=flat,
                  points_in_no_cell=dropped, triangulation="cgal" if use_cgal else "qhull", vertices=len(verts), faces=len(faces))
    return verts, faces, colours, counts, timings


def write_mesh(path, verts, faces, colours):
    vd = [("x", "f4"), ("y", "f4"), ("z", "f4")]
    if colours is not None:
        vd += [("red", "u1"), ("green", "u1"), ("blue", "u1"), ("alpha", "u1")]
    va = np.empty(len(verts), vd)
    va["x"], va["y"], va["z"] = verts[:, 0], verts[:, 1], verts[:, 2]
    if colours is not None:
        va["red"], va["green"], va["blue"] = colours[:, 0], colours[:, 1], colours[:, 2]
        va["alpha"] = 255
    fa = np.empty(len(faces), [("vertex_indices", "i4", (3,))])
    fa["vertex_indices"] = faces.astype(np.int32)
    el = [PlyElement.describe(va, "vertex"),
          PlyElement.describe(fa, "face", len_types={"vertex_indices": "u1"}, val_types={"vertex_indices": "i4"})]
    PlyData(el, text=False, byte_order="<").write(path)


def mesh_topology(faces, nverts):
    """Edge use counts: closed = every undirected edge in exactly two faces."""
    if len(faces) == 0:
        return dict(closed=False, boundary_edges=0, nonmanifold_edges=0, unreferenced_vertices=nverts)
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    unref = nverts - len(np.unique(faces))
    return dict(closed=bool(np.all(cnt == 2)), boundary_edges=int(np.sum(cnt == 1)),
                nonmanifold_edges=int(np.sum(cnt > 2)), unreferenced_vertices=int(unref))


# ----------------------------------------------------------------------------- self-test

def scalar_integrate(r, points):
    """Plain-loop transcription of integrateCUDA for one view (tile by tile, pixel by pixel,
    Gaussian by Gaussian, ray by ray), on the preprocessing of `r`. Used by --self-test to
    check the vectorised ViewRaster (same float32 operations, so results agree to rounding)."""
    cam = r.cam
    W, H = cam.W, cam.H
    n = len(points)
    out_alpha = np.ones(n, F32)
    out_col = np.zeros((n, 3), F32)
    proj = {}
    for i, p in enumerate(points.astype(F32)):
        pv = cam.w2v[:3, :3] @ p + cam.w2v[:3, 3]
        if not pv[2] > F32(0.2):
            continue
        u = F32(float(cam.fx32 * pv[0] / (pv[2] + F32(1e-7))) + W / 2.0)
        v = F32(float(cam.fy32 * pv[1] / (pv[2] + F32(1e-7))) + H / 2.0)
        if u < 0 or u >= W or v < 0 or v >= H:
            continue
        proj[i] = (u, v, pv[2])
    for ty in range(r.gy):
        for tx in range(r.gx):
            lst = [int(g) for g in r.lists[ty * r.gx + tx, :r.counts[ty * r.gx + tx]]]
            for py in range(ty * BLOCK, min(ty * BLOCK + BLOCK, H)):
                for px in range(tx * BLOCK, min(tx * BLOCK + BLOCK, W)):
                    pfx, pfy = F32(px) + F32(0.5), F32(py) + F32(0.5)
                    Ts = [F32(1)] * 5
                    C = np.zeros(3, F32)
                    ids, last = [], 0
                    for j, g in enumerate(lst):
                        contributor = j + 1
                        used = False
                        for k in range(5):
                            rx = F32((float(pfx) + OFF_X[k] - W / 2.0) / float(cam.fx32))
                            ry = F32((float(pfy) + OFF_Y[k] - H / 2.0) / float(cam.fy32))
                            AA, BB, CC = quad_coeffs(r.v2g[g], rx, ry)
                            with np.errstate(all="ignore"):
                                t = -BB / (F32(2) * AA)
                                if t <= F32(NEAR_PLANE):
                                    continue
                                mv = -float(BB / AA) * (float(BB) / 4.0) + float(CC)
                                power = min(F32(-0.5 * mv), F32(0))
                                alpha = np.fmin(ALPHA_MAX, r.opacity[g] * np.exp(power))
                            if alpha < ALPHA_MIN:
                                continue
                            testT = Ts[k] * (F32(1) - alpha)
                            if testT < T_MIN:
                                continue
                            if k == 0:
                                C += r.rgb[g] * (alpha * Ts[0])
                            Ts[k] = testT
                            used = True
                        if used:
                            last = contributor
                            ids.append(contributor % 65536)
                            if len(ids) >= MAX_CONTRIBUTORS:
                                break
                    colour = C + Ts[0] * r.bg
                    mine = [i for i, (u, v, _) in proj.items()
                            if u >= float(pfx) - 0.5 and u < float(pfx) + 0.5
                            and v >= float(pfy) - 0.5 and v < float(pfy) + 0.5]
                    for i in mine:
                        u, v, dep = proj[i]
                        rx = F32((float(u) - W / 2.0) / float(cam.fx32))
                        ry = F32((float(v) - H / 2.0) / float(cam.fy32))
                        T, acc, ptr = F32(1), F32(0), 0
                        for it in range(1, last + 1):
                            if ptr >= len(ids) or it != ids[ptr]:
                                continue
                            ptr += 1
                            g = lst[it - 1]
                            AA, BB, CC = quad_coeffs(r.v2g[g], rx, ry)
                            with np.errstate(all="ignore"):
                                t = -BB / (F32(2) * AA)
                                t = dep if t > dep else t
                                power = F32(-0.5) * (AA * t * t + BB * t + CC)
                                alpha = np.fmin(ALPHA_MAX, r.opacity[g] * np.exp(power))
                            if alpha < ALPHA_MIN:
                                continue
                            acc = acc + alpha * T
                            T = T * (F32(1) - alpha)
                        out_alpha[i] = acc
                        out_col[i] = colour
    return out_alpha, out_col


def self_test(seed=0):
    """Vectorised ViewRaster vs the plain loops on a small random scene; cap lowered to 6
    so that the contributor cap is exercised. Exit status 1 on a mismatch."""
    global MAX_CONTRIBUTORS
    rng = np.random.default_rng(seed)
    n = 60
    xyz = rng.uniform(-0.4, 0.4, (n, 3)).astype(F32)
    q = rng.normal(size=(n, 4)).astype(F32)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    scale = np.exp(rng.uniform(np.log(0.02), np.log(0.3), (n, 3))).astype(F32)
    sh = np.zeros((n, 16, 3), F32)
    sh[:, 0] = rng.normal(size=(n, 3))
    sh[:, 1:] = 0.1 * rng.normal(size=(n, 15, 3))
    opacity = rng.uniform(0.3, 1.0, n).astype(F32)
    # a stack of opaque Gaussians on the optical axis (T falls below 1e-4) and large ones just
    # in front of the camera (ray maxima at t <= 0.2)
    xyz[:6] = [[0.3, -0.2, z] for z in np.linspace(-0.3, 0.3, 6)]
    scale[:6], opacity[:6] = 0.1, 1.0
    xyz[6:10] = [[0.3 + dx, -0.2, -2.5 + 0.3] for dx in (-0.05, 0.0, 0.05, 0.1)]
    scale[6:10] = 0.3
    g = dict(xyz=xyz, sh=sh, sh_degree=3, scale=scale, rot=q, opacity=opacity, has_filter=False)
    cam = Camera(dict(width=37, height=21, fx=30.0, fy=33.0, position=[0.3, -0.2, -2.5],
                      rotation=np.eye(3).tolist()), "self-test")
    pts = np.concatenate([rng.uniform(-0.8, 0.8, (400, 3)), xyz + rng.normal(0, 0.02, (n, 3))]).astype(F32)
    worst = 0.0
    saved = MAX_CONTRIBUTORS
    try:
        for cap in (saved, 6):
            MAX_CONTRIBUTORS = cap
            r = ViewRaster(g, cam, 0.1, [0.2, 0.5, 1.0])
            a1, c1 = r.integrate(pts)
            a2, c2 = scalar_integrate(r, pts)
            err = max(float(np.abs(a1 - a2).max()), float(np.abs(c1 - c2).max()))
            seen = int(np.sum(a1 < 1))
            capped = int(np.sum(r.ncontrib >= cap))
            print(f"cap {cap}: {seen} of {len(pts)} points in a pixel, {capped} capped pixels, "
                  f"max |vectorised - loops| = {err:.2e}")
            worst = max(worst, err)
    finally:
        MAX_CONTRIBUTORS = saved
    ok = worst <= 1e-5
    print("self-test", "passed" if ok else "FAILED", "(tolerance 1e-5: float32 rounding order)")
    return ok


# ----------------------------------------------------------------------------- test scene

def make_test_scene(out_dir, n=1500, sigma=0.05, thin=0.005, opacity_logit=3.0, dist=3.5, W=64, H=48, f=60.0):
    """Flat Gaussians tangent to the unit sphere (Fibonacci points) and 6 cameras on the axes."""
    os.makedirs(out_dir, exist_ok=True)
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = math.pi * (1 + 5 ** 0.5) * i
    p = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], 1)
    # quaternion rotating +z onto the normal p: axis z x p, angle acos(p_z)
    axis = np.stack([-p[:, 1], p[:, 0], np.zeros(n)], 1)
    an = np.linalg.norm(axis, axis=1, keepdims=True)
    axis = np.where(an > 1e-12, axis / np.maximum(an, 1e-12), np.array([1.0, 0, 0]))
    ang = np.arccos(np.clip(p[:, 2], -1, 1))
    q = np.concatenate([np.cos(ang / 2)[:, None], axis * np.sin(ang / 2)[:, None]], 1)
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"] + \
        [f"f_rest_{k}" for k in range(45)] + ["opacity", "scale_0", "scale_1", "scale_2"] + \
        [f"rot_{k}" for k in range(4)]
    a = np.zeros(n, [(s, "f4") for s in names])
    a["x"], a["y"], a["z"] = p[:, 0], p[:, 1], p[:, 2]
    col = 0.5 + 0.4 * p                                      # colour from the normal, as SH DC
    for k in range(3):
        a[f"f_dc_{k}"] = (col[:, k] - 0.5) / SH_C0
    a["opacity"] = opacity_logit
    a["scale_0"] = math.log(sigma); a["scale_1"] = math.log(sigma); a["scale_2"] = math.log(thin)
    for k in range(4):
        a[f"rot_{k}"] = q[:, k]
    PlyData([PlyElement.describe(a, "vertex")], byte_order="<").write(os.path.join(out_dir, "scene.ply"))
    cams = []
    for k, c in enumerate(np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)):
        pos = c * dist
        fwd = -c
        up = np.array([0, 0, 1.0]) if abs(fwd[2]) < 0.9 else np.array([0, 1.0, 0])
        right = np.cross(fwd, up); right /= np.linalg.norm(right)
        down = np.cross(fwd, right)
        R = np.stack([right, down, fwd], 1)                  # columns: camera x, y, z in world
        cams.append(dict(id=k, img_name=f"view{k}", width=W, height=H, position=pos.tolist(),
                         rotation=R.tolist(), fx=f, fy=f))
    with open(os.path.join(out_dir, "cameras.json"), "w") as fh:
        json.dump(cams, fh, indent=1)
    print(f"wrote {out_dir}/scene.ply ({n} Gaussians) and {out_dir}/cameras.json (6 views {W}x{H})")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?")
    ap.add_argument("cameras", nargs="?")
    ap.add_argument("-o", "--output")
    ap.add_argument("--filter-mesh", action="store_true")
    ap.add_argument("--texture-mesh", action="store_true", help="vertex colours (GOF --texture_mesh)")
    ap.add_argument("--near", type=float, default=0.02)
    ap.add_argument("--far", type=float, default=1e6)
    ap.add_argument("--kernel-size", type=float, default=0.0)
    ap.add_argument("--white-background", action="store_true")
    ap.add_argument("--json")
    ap.add_argument("--sphere-radius", type=float, help="report | |v| - R | of the vertices (test scene)")
    ap.add_argument("--cgal", action="store_true", help="cells from CGAL's Python bindings (pip install cgal), as GOF")
    ap.add_argument("--make-test-scene", metavar="DIR")
    ap.add_argument("--self-test", action="store_true", help="check the vectorised code against plain loops")
    a = ap.parse_args()
    if a.self_test:
        sys.exit(0 if self_test() else 1)
    if a.make_test_scene:
        make_test_scene(a.make_test_scene)
        return
    if not (a.scene and a.cameras and a.output):
        ap.error("SCENE, CAMERAS and -o are required")
    g = load_scene(a.scene)
    cams = load_cameras(a.cameras)
    bg = [1.0, 1.0, 1.0] if a.white_background else [0.0, 0.0, 0.0]
    t0 = time.perf_counter()
    verts, faces, colours, counts, timings = extract(
        g, cams, a.near, a.far, a.kernel_size, bg, a.filter_mesh, a.texture_mesh,
        log=lambda s: print(s, file=sys.stderr), use_cgal=a.cgal)
    timings["total_s"] = time.perf_counter() - t0
    write_mesh(a.output, verts, faces, colours)
    report = dict(counts=counts, topology=mesh_topology(faces, len(verts)), timings=timings,
                  settings=dict(near=a.near, far=a.far, kernel_size=a.kernel_size, background=bg,
                                filter_mesh=a.filter_mesh, texture_mesh=a.texture_mesh,
                                filter_3D=g["has_filter"], views=len(cams)))
    if a.sphere_radius is not None and len(verts):
        d = np.abs(np.linalg.norm(verts.astype(np.float64), axis=1) - a.sphere_radius)
        report["sphere"] = dict(radius=a.sphere_radius, mean_abs_error=float(d.mean()),
                                max_abs_error=float(d.max()))
    text = json.dumps(report, indent=1)
    if a.json:
        with open(a.json, "w") as fh:
            fh.write(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
