#!/usr/bin/env python3
"""splatkit's splat formats against PlayCanvas splat-transform.

usage: python3 scripts/compare/splat_transform.py [--convert BIN] [--shared DIR] [SCENE.ply ...]

Installs @playcanvas/splat-transform (npm, into /tmp/splatkit-splat-transform) on first
use; needs numpy and scipy (pip). BIN defaults to target/release/convert (built with
`cargo build --release --bin convert` if missing). SCENE defaults to
testdata/splats/scene300/source.ply and, when the shared data are there,
3dgs-kacytran-iter7000/point_cloud.ply.

1. For each format `convert` writes (.compressed.ply, .splat, .spz, .sog) and each scene:
   `convert SCENE -o OUT --lossy`, then `splat-transform OUT back.ply`, and the errors of what
   splat-transform read back against SCENE. Gaussians are matched by nearest position (the
   compressed PLY and SOG are Morton-sorted), so a large position error would show as mismatches.
   A second table compares splat-transform's decode of OUT with splatkit's (`convert OUT -o
   mine.ply`): the two readers of the same file.
2. The real SuperSplat files (biker / guitar .compressed.ply, biker.spz) read by splatkit
   (`convert F -o ours.ply`) and by splat-transform (`splat-transform F theirs.ply`): the largest
   difference per attribute, Gaussian by Gaussian in file order.

Errors, per component: position (scene units, max and RMS), colour 0.5 + C0*f_dc (max, RMS),
opacity sigmoid(v) (max, RMS), log scale (max, RMS), rotation (largest angle between the
normalised quaternions, degrees), SH rest (max). Prints markdown tables.
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
NPM = "/tmp/splatkit-splat-transform"
C0 = 0.28209479177387814


def splat_transform():
    exe = os.path.join(NPM, "node_modules", ".bin", "splat-transform")
    if not os.path.exists(exe):
        subprocess.run(["npm", "install", "--silent", "--prefix", NPM,
                        "@playcanvas/splat-transform@2.7.1"], check=True)
    r = subprocess.run([exe, "--version"], capture_output=True, text=True)
    return exe, (r.stdout + r.stderr).split()[1]


def read_ply(path):
    """Vertex properties of a binary little-endian PLY as float64 arrays."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    types = {"float": "<f4", "uint": "<u4", "uchar": "u1", "double": "<f8", "int": "<i4",
             "float32": "<f4", "uint8": "u1", "uint32": "<u4"}
    els = []
    for line in data[:end].decode().splitlines():
        w = line.split()
        if w[:1] == ["element"]:
            els.append((w[1], int(w[2]), []))
        elif w[:1] == ["property"]:
            els[-1][2].append((w[2], types[w[1]]))
    off = end
    for name, count, props in els:
        dt = np.dtype(props)
        arr = np.frombuffer(data, dtype=dt, count=count, offset=off)
        off += dt.itemsize * count
        if name == "vertex":
            return {p: arr[p].astype(np.float64) for p, _ in props}
    raise SystemExit(f"{path}: no vertex element")


def attrs(v):
    n = len(v["x"])
    rest = sorted((k for k in v if k.startswith("f_rest_")), key=lambda k: int(k[7:]))
    q = np.stack([v[f"rot_{i}"] for i in range(4)], 1)
    q = q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-30)
    return {
        "pos": np.stack([v["x"], v["y"], v["z"]], 1),
        "col": 0.5 + C0 * np.stack([v[f"f_dc_{i}"] for i in range(3)], 1),
        "op": 1 / (1 + np.exp(-v["opacity"])),
        "scale": np.stack([v[f"scale_{i}"] for i in range(3)], 1),
        "rot": q,
        "rest": np.stack([v[k] for k in rest], 1) if rest else np.zeros((n, 0)),
    }


def errors(a, b):
    """b against a, row by row."""
    def mr(x):
        x = np.abs(x[np.isfinite(x)])
        return (float(x.max()) if x.size else 0.0, float(np.sqrt((x ** 2).mean())) if x.size else 0.0)
    dot = np.clip(np.abs((a["rot"] * b["rot"]).sum(1)), 0, 1)
    k = max(a["rest"].shape[1], b["rest"].shape[1])

    # f_rest is channel-major (K per channel): a lower degree is padded per channel
    def per_channel(r, have):
        if have == k or have == 0:
            return r if have else np.zeros((len(dot), k))
        out = np.zeros((len(dot), k))
        for c in range(3):
            out[:, c * k // 3:c * k // 3 + have // 3] = r[:, c * have // 3:(c + 1) * have // 3]
        return out
    ra = per_channel(a["rest"], a["rest"].shape[1])
    rb = per_channel(b["rest"], b["rest"].shape[1])
    return {
        "position": mr(a["pos"] - b["pos"]),
        "colour": mr(a["col"] - b["col"]),
        "opacity": mr(a["op"] - b["op"]),
        "log_scale": mr(a["scale"] - b["scale"]),
        "rotation_deg": float(np.degrees(2 * np.arccos(dot)).max()),
        "sh_rest_max": float(np.abs(ra - rb).max()) if k else 0.0,
    }


def matched(src, back):
    """back reordered to src by nearest position."""
    from scipy.spatial import cKDTree
    _, j = cKDTree(back["pos"]).query(src["pos"])
    return {k: v[j] for k, v in back.items()}, len(set(j.tolist())) != len(j)


def fmt(e):
    return (f"{e['position'][0]:.2e} / {e['position'][1]:.2e} | {e['colour'][0]:.2e} / {e['colour'][1]:.2e} | "
            f"{e['opacity'][0]:.2e} / {e['opacity'][1]:.2e} | {e['log_scale'][0]:.2e} / {e['log_scale'][1]:.2e} | "
            f"{e['rotation_deg']:.3f} | {e['sh_rest_max']:.2e}")


def main(argv):
    conv = os.path.join(ROOT, "target", "release", "convert")
    shared = os.path.join(ROOT, "..", "shared", "data")
    scenes = []
    i = 0
    while i < len(argv):
        if argv[i] == "--convert":
            conv = argv[i + 1]; i += 2
        elif argv[i] == "--shared":
            shared = argv[i + 1]; i += 2
        else:
            scenes.append(argv[i]); i += 1
    if not os.path.exists(conv):
        subprocess.run(["cargo", "build", "--release", "-q", "--bin", "convert"], cwd=ROOT, check=True)
    if not scenes:
        scenes = [os.path.join(ROOT, "testdata", "splats", "scene300", "source.ply")]
        k = os.path.join(shared, "3dgs-kacytran-iter7000", "point_cloud.ply")
        if os.path.exists(k):
            scenes.append(k)
    st, ver = splat_transform()
    tmp = tempfile.mkdtemp(prefix="splatkit-vs-st-")
    print(f"splat-transform {ver}; errors max / RMS per component (rotation: max degrees)\n")
    print("| scene | format | bytes | position | colour | opacity | log scale | rotation ° | SH rest max | ours: position max |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    same = []
    for scene in scenes:
        src = attrs(read_ply(scene))
        for ext in ["compressed.ply", "splat", "spz", "sog"]:
            out = os.path.join(tmp, "out." + ext)
            rep = os.path.join(tmp, "r.json")
            subprocess.run([conv, scene, "-o", out, "--lossy", "--quiet", f"--json={rep}"], check=True)
            ours = json.load(open(rep))
            back = os.path.join(tmp, "back.ply")
            subprocess.run([st, "-q", "-w", out, back], check=True, capture_output=True)
            b, dup = matched(src, attrs(read_ply(back)))
            e = errors(src, b)
            note = " (matching not one-to-one)" if dup else ""
            print(f"| {os.path.basename(scene)} ({len(src['op'])}) | {ext}{note} | {os.path.getsize(out):,} | {fmt(e)} | "
                  f"{ours['error']['position']['max']:.2e} |")
            mine = os.path.join(tmp, "mine.ply")
            subprocess.run([conv, out, "-o", mine, "--quiet"], check=True)
            # the same file, so the same order: compared row by row
            m, t = attrs(read_ply(mine)), attrs(read_ply(back))
            same.append((os.path.basename(scene), len(src["op"]), ext, errors(m, t)))
    print("\nThe files above read by splat-transform and by splatkit, row by row in file order "
          "(max / RMS |ours - theirs|):\n")
    print("| scene | format | position | colour | opacity | log scale | rotation ° | SH rest max |")
    print("|---|---|---|---|---|---|---|---|")
    for scene, n, ext, e in same:
        print(f"| {scene} ({n}) | {ext} | {fmt(e)} |")
    print("\nReal files, splatkit's reader vs splat-transform's (max |ours - theirs|, file order):\n")
    print("| file | position | colour | opacity | log scale | rotation ° | SH rest max |")
    print("|---|---|---|---|---|---|---|")
    for rel in ["3dgs-playcanvas-biker/biker.compressed.ply", "3dgs-playcanvas-guitar/guitar.compressed.ply",
                "3dgs-playcanvas-biker/biker.spz"]:
        f = os.path.join(shared, rel)
        if not os.path.exists(f):
            continue
        ours_p, theirs_p = os.path.join(tmp, "ours.ply"), os.path.join(tmp, "theirs.ply")
        r = subprocess.run([conv, f, "-o", ours_p, "--quiet"], capture_output=True, text=True)
        if r.returncode != 0:
            print(f"| {rel} | splatkit cannot read it: {r.stderr.strip().splitlines()[-1]} |||||")
            continue
        subprocess.run([st, "-q", "-w", f, theirs_p], check=True, capture_output=True)
        a, b = attrs(read_ply(ours_p)), attrs(read_ply(theirs_p))
        e = errors(a, b)
        print(f"| {rel} | {e['position'][0]:.2e} | {e['colour'][0]:.2e} | {e['opacity'][0]:.2e} | "
              f"{e['log_scale'][0]:.2e} | {e['rotation_deg']:.2e} | {e['sh_rest_max']:.2e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
