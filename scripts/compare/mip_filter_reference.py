#!/usr/bin/env python3
"""Reference images of the 2-D Mip filter, written from the rules of the
Mip-Splatting / Gaussian Opacity Fields CUDA rasteriser (their fork of
diff-gaussian-rasterization: forward.cu `computeCov2D`, `preprocessCUDA`,
`renderCUDA`; rasterizer_impl.cu `getRect`), in NumPy float32 like the kernel.

Usage (from the repository root; installs NumPy into a private venv):

    python3 scripts/compare/mip_filter_reference.py [OUT_JSON]

OUT_JSON defaults to testdata/render/mip_filter_reference.json. Read by
tests/mip_filter.rs, which renders the same Gaussians with
`Filter2d::Mip { kernel_size }` and compares.

Rules implemented (per Gaussian, then per pixel):
- camera space t = R mu + T; culled when t.z <= 0.2 (in_frustum);
- Sigma = R_q S S^T R_q^T, q = (w, x, y, z) normalised (the Python side's
  rotation_activation), S = diag(scales) (already activated, and already
  3D-filtered by the caller when the model has filter_3D);
- J = [[fx/z, 0, -fx x/z^2], [0, fy/z, -fy y/z^2]] with x/z, y/z clamped to
  +-1.3 tan(fov/2); cov = J W Sigma W^T J^T (2x2);
- det_0 = max(1e-6, det cov), det_1 = max(1e-6, det(cov + k I)),
  coef = sqrt(det_0 / (det_1 + 1e-6) + 1e-6), coef = 0 when det_0 <= 1e-6
  or det_1 <= 1e-6; cov += k I (k = kernel_size);
- conic = cov^-1; radius = ceil(3 sqrt(lambda_max)), lambda from
  mid +- sqrt(max(0.1, mid^2 - det)); pixel mean in the kernel's pixel
  coordinates (pixel centres at integers); tiles by getRect (16x16);
- opacity drawn = opacity * coef; colour = max(0, 0.5 + C0 * dc);
- per pixel, the tile's Gaussians sorted by view depth: power =
  -0.5 (a dx^2 + c dy^2) - b dx dy, skipped when > 0; alpha = min(0.99,
  o exp(power)), skipped when < 1/255; stop when T (1 - alpha) < 1e-4;
  C = sum c alpha T + T bg.
"""

import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
VENV = "/tmp/splatkit-mip-venv"


def ensure_numpy():
    try:
        import numpy  # noqa: F401
        return
    except ImportError:
        pass
    py = os.path.join(VENV, "bin", "python")
    if not os.path.exists(py):
        subprocess.check_call([sys.executable, "-m", "venv", VENV])
        subprocess.check_call([py, "-m", "pip", "install", "-q", "numpy"])
    os.execv(py, [py] + sys.argv)


ensure_numpy()
import numpy as np  # noqa: E402

F = np.float32
C0 = F(0.28209479177387814)
BLOCK = 16


def quat_matrix(q):
    q = q / np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ], dtype=F)


def preprocess(g, cam, k):
    """Per Gaussian: None if culled, else (xy, conic, opacity, rgb, depth, rect)."""
    W, H, fx, fy, cx, cy = cam["width"], cam["height"], F(cam["fx"]), F(cam["fy"]), cam["cx"], cam["cy"]
    R = np.asarray(cam["rotation"], dtype=F)
    T = np.asarray(cam["translation"], dtype=F)
    tanx, tany = F(W / (2 * cam["fx"])), F(H / (2 * cam["fy"]))
    grid = ((W + BLOCK - 1) // BLOCK, (H + BLOCK - 1) // BLOCK)
    out = []
    for i in range(len(g["means"])):
        mu = np.asarray(g["means"][i], dtype=F)
        t = R @ mu + T
        if t[2] <= F(0.2):
            out.append(None)
            continue
        rq = quat_matrix(np.asarray(g["rotations"][i], dtype=F))
        M = rq @ np.diag(np.asarray(g["scales"][i], dtype=F))
        sigma = M @ M.T
        limx, limy = F(1.3) * tanx, F(1.3) * tany
        tx = np.clip(t[0] / t[2], -limx, limx) * t[2]
        ty = np.clip(t[1] / t[2], -limy, limy) * t[2]
        J = np.array([[fx / t[2], 0, -(fx * tx) / (t[2] * t[2])],
                      [0, fy / t[2], -(fy * ty) / (t[2] * t[2])]], dtype=F)
        Tm = J @ R
        cov = Tm @ sigma @ Tm.T
        a, b, c = cov[0, 0], cov[0, 1], cov[1, 1]
        det_0 = max(1e-6, float(a * c - b * b))
        det_1 = max(1e-6, float((a + F(k)) * (c + F(k)) - b * b))
        coef = F(np.sqrt(det_0 / (det_1 + 1e-6) + 1e-6))
        if det_0 <= 1e-6 or det_1 <= 1e-6:
            coef = F(0.0)
        a, c = a + F(k), c + F(k)
        det = a * c - b * b
        if det == 0:
            out.append(None)
            continue
        conic = (c / det, -b / det, a / det)
        mid = F(0.5) * (a + c)
        l1 = mid + np.sqrt(max(F(0.1), mid * mid - det))
        l2 = mid - np.sqrt(max(F(0.1), mid * mid - det))
        radius = np.ceil(F(3.0) * np.sqrt(max(l1, l2)))
        # the kernel's pixel coordinates: pixel centres at integers
        px = fx * t[0] / t[2] + F(cx) - F(0.5)
        py = fy * t[1] / t[2] + F(cy) - F(0.5)
        rmin = (min(grid[0], max(0, int((px - radius) / BLOCK))),
                min(grid[1], max(0, int((py - radius) / BLOCK))))
        rmax = (min(grid[0], max(0, int((px + radius + BLOCK - 1) / BLOCK))),
                min(grid[1], max(0, int((py + radius + BLOCK - 1) / BLOCK))))
        if (rmax[0] - rmin[0]) * (rmax[1] - rmin[1]) == 0:
            out.append(None)
            continue
        dc = np.asarray(g["sh_dc"][i], dtype=F)
        rgb = np.maximum(F(0.5) + C0 * dc, F(0.0))
        op = F(g["opacities"][i]) * coef
        out.append(((px, py), conic, op, rgb, t[2], rmin, rmax))
    return out


def render(g, cam, k, bg):
    W, H = cam["width"], cam["height"]
    pre = preprocess(g, cam, k)
    order = sorted((p[4], i) for i, p in enumerate(pre) if p is not None)
    rgb = np.zeros((H, W, 3), dtype=F)
    alpha = np.zeros((H, W), dtype=F)
    for y in range(H):
        for x in range(W):
            tile = (x // BLOCK, y // BLOCK)
            T, C = F(1.0), np.zeros(3, dtype=F)
            for _, i in order:
                (px, py), (ca, cb, cc), op, col, _, rmin, rmax = pre[i]
                if not (rmin[0] <= tile[0] < rmax[0] and rmin[1] <= tile[1] < rmax[1]):
                    continue
                dx, dy = px - F(x), py - F(y)
                power = F(-0.5) * (ca * dx * dx + cc * dy * dy) - cb * dx * dy
                if power > 0:
                    continue
                a = min(F(0.99), op * np.exp(power))
                if a < F(1.0 / 255.0):
                    continue
                test_T = T * (F(1) - a)
                if test_T < F(0.0001):
                    break
                C = C + col * a * T
                T = test_T
            rgb[y, x] = C + T * np.asarray(bg, dtype=F)
            alpha[y, x] = F(1) - T
    return rgb, alpha


def scene():
    rng = np.random.default_rng(2024)
    n = 14
    g = {"means": [], "scales": [], "rotations": [], "opacities": [], "sh_dc": []}
    for i in range(n):
        z = rng.uniform(2.5, 4.0)
        g["means"].append([rng.uniform(-0.9, 0.9), rng.uniform(-0.7, 0.7), z])
        # projected sigma from ~0.02 px (coef 0: not drawn) through ~0.1-1 px
        # (coef well below 1) to several px (coef ~ 1)
        big = [0.0005, 0.003, 0.01, 0.03, 0.15][i % 5]
        g["scales"].append(list(big * rng.uniform(0.4, 1.6, size=3)))
        g["rotations"].append(list(rng.normal(size=4)))
        g["opacities"].append(float(rng.uniform(0.3, 1.0)))
        g["sh_dc"].append(list(rng.normal(size=3)))
    for key in g:
        g[key] = [[float(F(v)) for v in r] if isinstance(r, list) else float(F(r)) for r in g[key]]
    cam = {"width": 32, "height": 24, "fx": 40.0, "fy": 40.0, "cx": 16.0, "cy": 12.0,
           "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "translation": [0.0, 0.0, 0.0]}
    return g, cam


def main(argv):
    out = argv[0] if argv else os.path.join(ROOT, "testdata", "render", "mip_filter_reference.json")
    g, cam = scene()
    bg = [0.1, 0.2, 0.3]
    renders = []
    for k in [0.1, 0.0]:
        rgb, alpha = render(g, cam, k, bg)
        renders.append({
            "kernel_size": k,
            "rgb": [float("%.7g" % v) for v in rgb.flatten()],
            "alpha": [float("%.7g" % v) for v in alpha.flatten()],
        })
    doc = {
        "note": "written by scripts/compare/mip_filter_reference.py (NumPy " + np.__version__
                + ", float32) from the rules of the Mip-Splatting / GOF CUDA rasteriser; "
                "values printed with 7 significant digits",
        "camera": cam, "background": bg, "gaussians": g, "renders": renders,
    }
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {out} ({os.path.getsize(out)} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
