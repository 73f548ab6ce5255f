#!/usr/bin/env python3
"""Independent NumPy re-implementation of 2DGS's surfel rasteriser (forward),
used to check splatkit's `render/src/surfel.rs` (test
`render/tests/surfel_reference.rs`).

Usage:  python3 scripts/compare/surfel_reference.py [--seed 0] [-o render/tests/data/surfel_reference.txt]
Needs numpy (installed here with `pip install numpy` when missing).

It renders a random, seeded scene of 2D Gaussian surfels pixel by pixel and
surfel by surfel (plain loops, f32 arithmetic as the CUDA kernel), written
from the rules of the official CUDA code, `hbb1/diff-surfel-rasterization`
(commit e0ed020), and of the Python side, `hbb1/2d-gaussian-splatting`
(commit 1920a23) -- not from splatkit's Rust. Each rule and where it comes from:

- camera matrices (2d-gaussian-splatting `utils/graphics_utils.py`,
  `scene/cameras.py`): world_view_transform = W2C^T, projection matrix
  `getProjectionMatrix(znear=0.01, zfar=100, fovX, fovY)` (principal point at
  the image centre), full_proj_transform = world_view @ projection^T-style
  row-vector product; the kernel reads them column-major
  (`transformPoint4x4`, `auxiliary.h`).
- near cull (`in_frustum`, auxiliary.h): view z <= 0.2 culls the surfel.
- rotation (`quat_to_rotmat`, auxiliary.h): quaternion (w, x, y, z),
  normalised; L = R * diag(s_u, s_v, 1) (`scale_to_mat`, modifier 1).
- homography (`compute_transmat`, forward.cu):
  T = transpose(splat2world) * world2ndc * ndc2pix with splat2world columns
  (L0, 0), (L1, 0), (mean, 1), world2ndc the projection matrix as glm reads
  it, ndc2pix columns (W/2, 0, 0, (W-1)/2), (0, H/2, 0, (H-1)/2),
  (0, 0, 0, 1); T_u, T_v, T_w are T's glm columns. Normal = view rotation
  times L2 (`transformVec4x3`).
- facing (`DUAL_VISIABLE`, preprocessCUDA): cos = -(p_view . n); cos == 0
  culls; cos < 0 flips n.
- box (`compute_aabb`, forward.cu, cutoff 3): t = (9, 9, -1),
  d = t . (T_w*T_w) (0 culls), f = t/d, centre p = (f . (T_u*T_w),
  f . (T_v*T_w)), h = sqrt(max(1e-4, p^2 - (f . T_u^2, f . T_v^2))),
  radius = ceil(max(h_x, h_y, 3 * 0.707106)) (`FilterSize`).
- tiles (`getRect`, auxiliary.h, 16x16 `BLOCK_X/Y` in config.h): columns
  [(int)((p.x - r)/16), (int)((p.x + r + 15)/16)) clamped to the grid; an
  empty range culls; surfels sorted per tile by view z of the centre
  (`depths`), ties by index (stable radix sort in rasterizer_impl.cu).
- colour (`computeColorFromSH`, forward.cu): SH degree D basis in the
  direction mean - campos, + 0.5, clamped at 0.
- per pixel (`renderCUDA`, forward.cu), pixel centre (x, y) integers:
  k = x*T_w - T_u, l = y*T_w - T_v, p = k x l (skip p.z == 0),
  s = p.xy / p.z, rho3d = |s|^2, rho2d = 2 |centre - pixel|^2
  (`FilterInvSquare`), rho = min; depth = s.x T_w.x + s.y T_w.y + T_w.z,
  skip depth < 0.2 (`near_n`); power = -rho/2 (skip > 0);
  alpha = min(0.99, o exp(power)), skip < 1/255; test_T = T (1 - alpha),
  stop the pixel (not blended) when test_T < 1e-4; w = alpha T;
  D += depth w, N += n w, C += c w, median depth = depth while T > 0.5;
  colour = C + T bg; alpha map = 1 - T.
- expected depth (2d-gaussian-splatting `gaussian_renderer/__init__.py`):
  D / alpha, `nan_to_num(., 0, 0)`.

Output convention: splatkit's pixel centres are at (i + 0.5, j + 0.5) with
cx = W/2, cy = H/2, the kernel's at integers with the principal point at
((W-1)/2, (H-1)/2): the same pixels, so the maps are written as they are,
row-major, index y*W + x.

Fixture format (text, whitespace separated; every value as written here):
  line `camera W H fx fy cx cy` (splatkit convention)
  line `rotation` + 9 values (world-to-camera, row-major)
  line `translation` + 3 values
  line `background` + 3 values
  line `surfels N D` then N lines: mean(3) scale(2) rot(4, w x y z)
       opacity sh((D+1)^2 * 3, coefficient-major)
  line `pixels` then W*H lines: r g b alpha expected_depth median_depth
       nsum_x nsum_y nsum_z (nsum: accumulated camera-space normal)
"""

import argparse
import math
import subprocess
import sys

try:
    import numpy as np
except ImportError:  # install it ourselves, as the project's scripts do
    subprocess.check_call([sys.executable, "-m", "pip", "install", "--quiet", "numpy"])
    import numpy as np

f32 = np.float32

SH_C0 = 0.28209479177387814
SH_C1 = 0.4886025119029199
SH_C2 = [1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
         -1.0925484305920792, 0.5462742152960396]
SH_C3 = [-0.5900435899266435, 2.890611442640554, -0.4570457994644658,
         0.3731763325901154, -0.4570457994644658, 1.445305721320277,
         -0.5900435899266435]


def projection_matrix(znear, zfar, fovx, fovy):
    """getProjectionMatrix (utils/graphics_utils.py), column-vector form."""
    th, tw = math.tan(fovy / 2), math.tan(fovx / 2)
    top, right = th * znear, tw * znear
    bottom, left = -top, -right
    p = np.zeros((4, 4))
    p[0, 0] = 2 * znear / (right - left)
    p[1, 1] = 2 * znear / (top - bottom)
    p[0, 2] = (right + left) / (right - left)
    p[1, 2] = (top + bottom) / (top - bottom)
    p[3, 2] = 1.0
    p[2, 2] = zfar / (zfar - znear)
    p[2, 3] = -(zfar * znear) / (zfar - znear)
    return p


def quat_to_rotmat(q):
    """auxiliary.h quat_to_rotmat: q = (w, x, y, z), normalised; R[row][col]."""
    q = np.asarray(q, dtype=f32)
    n = f32(1.0) / np.sqrt(np.sum(q * q, dtype=f32))
    w, x, y, z = (q * n).astype(f32)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ], dtype=f32)


def sh_colour(deg, sh, d):
    """computeColorFromSH: sh is ((deg+1)^2, 3); d unit direction."""
    x, y, z = d
    r = SH_C0 * sh[0]
    if deg > 0:
        r = r - SH_C1 * y * sh[1] + SH_C1 * z * sh[2] - SH_C1 * x * sh[3]
        if deg > 1:
            xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
            r = (r + SH_C2[0] * xy * sh[4] + SH_C2[1] * yz * sh[5]
                 + SH_C2[2] * (2 * zz - xx - yy) * sh[6] + SH_C2[3] * xz * sh[7]
                 + SH_C2[4] * (xx - yy) * sh[8])
            if deg > 2:
                r = (r + SH_C3[0] * y * (3 * xx - yy) * sh[9] + SH_C3[1] * xy * z * sh[10]
                     + SH_C3[2] * y * (4 * zz - xx - yy) * sh[11]
                     + SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy) * sh[12]
                     + SH_C3[4] * x * (4 * zz - xx - yy) * sh[13]
                     + SH_C3[5] * z * (xx - yy) * sh[14] + SH_C3[6] * x * (xx - 3 * yy) * sh[15])
    return np.maximum(r + 0.5, 0.0).astype(f32)


def render(scene, cam):
    W, H = cam["W"], cam["H"]
    fx, fy = cam["fx"], cam["fy"]
    fovx, fovy = 2 * math.atan(W / (2 * fx)), 2 * math.atan(H / (2 * fy))
    w2c = np.eye(4)
    w2c[:3, :3], w2c[:3, 3] = cam["R"], cam["t"]
    view = w2c.astype(f32)  # world_view_transform^T, column-vector form
    proj = (projection_matrix(0.01, 100.0, fovx, fovy) @ w2c).astype(f32)
    campos = (-cam["R"].T @ cam["t"]).astype(f32)
    world2ndc = proj.T  # glm::mat4 built from projmatrix rows: A^T
    ndc2pix = np.array([[W / 2, 0, 0], [0, H / 2, 0], [0, 0, 0],
                        [(W - 1) / 2, (H - 1) / 2, 1]], dtype=f32)
    bg = np.asarray(cam["bg"], dtype=f32)
    gx, gy = (W + 15) // 16, (H + 15) // 16
    deg = scene["deg"]
    pre = []
    for i in range(len(scene["means"])):
        mean = scene["means"][i]
        p_view = view[:3, :3] @ mean + view[:3, 3]
        if p_view[2] <= f32(0.2):  # in_frustum
            continue
        R = quat_to_rotmat(scene["rots"][i])
        L = R * np.array([scene["scales"][i][0], scene["scales"][i][1], 1.0], dtype=f32)
        splat2world = np.zeros((4, 3), dtype=f32)
        splat2world[:3, 0], splat2world[:3, 1] = L[:, 0], L[:, 1]
        splat2world[:3, 2], splat2world[3, 2] = mean, 1.0
        T = (splat2world.T @ world2ndc @ ndc2pix).astype(f32)
        Tu, Tv, Tw = T[:, 0], T[:, 1], T[:, 2]
        normal = (view[:3, :3] @ L[:, 2]).astype(f32)
        cos = -np.sum(p_view * normal, dtype=f32)
        if cos == 0:
            continue
        if cos < 0:
            normal = -normal
        t = np.array([9.0, 9.0, -1.0], dtype=f32)
        d = np.sum(t * Tw * Tw, dtype=f32)
        if d == 0:
            continue
        fv = (f32(1) / d) * t
        px = np.sum(fv * Tu * Tw, dtype=f32)
        py = np.sum(fv * Tv * Tw, dtype=f32)
        h0 = np.array([px * px - np.sum(fv * Tu * Tu, dtype=f32),
                       py * py - np.sum(fv * Tv * Tv, dtype=f32)], dtype=f32)
        h = np.sqrt(np.maximum(f32(1e-4), h0))
        radius = math.ceil(max(h[0], h[1], f32(3.0) * f32(0.707106)))
        clamp = lambda v, n: min(n, max(0, v))
        rx0 = clamp(int((px - radius) / 16), gx)
        ry0 = clamp(int((py - radius) / 16), gy)
        rx1 = clamp(int((px + radius + 15) / 16), gx)
        ry1 = clamp(int((py + radius + 15) / 16), gy)
        if (rx1 - rx0) * (ry1 - ry0) == 0:
            continue
        dirv = mean - campos
        dirv = dirv / np.linalg.norm(dirv)
        sh = scene["sh"][i].reshape(-1, 3)
        rgb = sh_colour(deg, sh.astype(np.float64), dirv.astype(np.float64))
        pre.append(dict(i=i, Tu=Tu, Tv=Tv, Tw=Tw, xy=np.array([px, py], dtype=f32),
                        depth=f32(p_view[2]), normal=normal, o=f32(scene["opac"][i]),
                        rgb=rgb, rect=(rx0, ry0, rx1, ry1)))
    pre.sort(key=lambda g: (g["depth"], g["i"]))
    out = np.zeros((H * W, 9))
    for y in range(H):
        for x in range(W):
            tx, ty = x // 16, y // 16
            pix = np.array([x, y], dtype=f32)
            T = f32(1.0)
            C = np.zeros(3, dtype=f32)
            N = np.zeros(3, dtype=f32)
            D = f32(0.0)
            median = f32(0.0)
            for g in pre:
                r = g["rect"]
                if not (r[0] <= tx < r[2] and r[1] <= ty < r[3]):
                    continue
                k = f32(x) * g["Tw"] - g["Tu"]
                l = f32(y) * g["Tw"] - g["Tv"]
                p = np.cross(k, l).astype(f32)
                if p[2] == 0:
                    continue
                s = (p[:2] / p[2]).astype(f32)
                rho3d = s[0] * s[0] + s[1] * s[1]
                dd = g["xy"] - pix
                rho2d = f32(2.0) * (dd[0] * dd[0] + dd[1] * dd[1])
                rho = min(rho3d, rho2d)
                depth = (s[0] * g["Tw"][0] + s[1] * g["Tw"][1]) + g["Tw"][2]
                if depth < f32(0.2):
                    continue
                power = f32(-0.5) * rho
                if power > 0:
                    continue
                alpha = min(f32(0.99), g["o"] * np.exp(power))
                if alpha < f32(1.0) / f32(255.0):
                    continue
                test_T = T * (f32(1) - alpha)
                if test_T < f32(0.0001):
                    break
                wgt = alpha * T
                D = D + depth * wgt
                if T > 0.5:
                    median = depth
                N = N + g["normal"] * wgt
                C = C + g["rgb"] * wgt
                T = test_T
            a = f32(1) - T
            with np.errstate(divide="ignore", invalid="ignore"):
                e = np.nan_to_num(np.float32(D) / a, nan=0.0, posinf=0.0)
            out[y * W + x] = [*(C + T * bg), a, e, median, *N]
    return out


def make_scene(rng, n, deg):
    means = np.stack([rng.uniform(-1.5, 1.5, n), rng.uniform(-1.0, 1.0, n),
                      rng.uniform(-1.0, 1.0, n)], axis=1).astype(f32)
    # log-uniform scales: a fifth from sub-pixel (drawn by the low-pass
    # filter) up, the rest large enough to cover the image in layers
    lo = np.where(rng.uniform(size=(n, 1)) < 0.2, math.log(0.003), math.log(0.15))
    scales = np.exp(rng.uniform(lo, math.log(0.9), (n, 2))).astype(f32)
    rots = rng.uniform(-1.0, 1.0, (n, 4)).astype(f32)
    opac = rng.uniform(0.05, 1.0, n).astype(f32)
    opac[rng.uniform(size=n) < 0.2] = 1.0  # the 0.99 cap
    k = (deg + 1) ** 2
    sh = rng.uniform(-0.15, 0.15, (n, k * 3)).astype(f32)
    sh[:, :3] = rng.uniform(-0.8, 0.8, (n, 3)).astype(f32)
    return dict(means=means, scales=scales, rots=rots, opac=opac, sh=sh, deg=deg)


def look_at(eye, target):
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(np.array([0.0, -1.0, 0.0]), z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    c2w = np.stack([x, y, z], axis=1)
    R = c2w.T
    return R, -R @ eye


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--output", default="render/tests/data/surfel_reference.txt")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    W, H, n, deg = 40, 30, 80, 1
    R, t = look_at(np.array([0.6, -0.4, -4.5]), np.array([0.0, 0.1, 0.0]))
    cam = dict(W=W, H=H, fx=38.0, fy=41.0, R=R, t=t, bg=[0.1, 0.2, 0.3])
    scene = make_scene(rng, n, deg)
    out = render(scene, cam)
    with open(args.output, "w") as fh:
        fh.write(f"camera {W} {H} {cam['fx']!r} {cam['fy']!r} {W / 2!r} {H / 2!r}\n")
        fh.write("rotation " + " ".join(repr(float(v)) for v in R.reshape(-1)) + "\n")
        fh.write("translation " + " ".join(repr(float(v)) for v in t) + "\n")
        fh.write("background " + " ".join(repr(float(v)) for v in cam["bg"]) + "\n")
        fh.write(f"surfels {n} {deg}\n")
        for i in range(n):
            vals = [*scene["means"][i], *scene["scales"][i], *scene["rots"][i],
                    scene["opac"][i], *scene["sh"][i]]
            fh.write(" ".join(repr(float(v)) for v in vals) + "\n")
        fh.write("pixels\n")
        for row in out:
            fh.write(" ".join(f"{v:.8g}" for v in row) + "\n")
    cover = np.mean(out[:, 3] > 0.5)
    print(f"wrote {args.output}: {n} surfels, {W}x{H}, {cover:.0%} of pixels with alpha > 0.5")


if __name__ == "__main__":
    main()
