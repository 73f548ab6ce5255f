#!/usr/bin/env python3
"""Summary table of dtu_train.mk: held-out masked PSNR / SSIM, primitives, iterations, wall time and
peak memory per stage (from GNU time's files), mesh sizes.  usage: dtu_train_summary.py OUT"""
import json
import os
import sys

out = sys.argv[1]


def timing(name):
    p = os.path.join(out, name + ".time")
    return open(p).read().strip().splitlines()[-1] if os.path.exists(p) else "-"


def faces(ply):
    with open(ply, "rb") as f:
        for line in f:
            if line.startswith(b"element face"):
                return int(line.split()[2])
            if line.startswith(b"end_header"):
                break
    return 0


print("| model | iterations | primitives | held-out PSNR (masked) | SSIM | train wall, peak RSS | mesh faces | mesh wall, peak RSS |")
print("|---|---|---|---|---|---|---|---|")
for model in ("triangles", "gaussians"):
    m = json.load(open(os.path.join(out, model, "metrics.json")))
    e0, e1 = m["evals"][0], m["evals"][-1]
    mesh = os.path.join(out, model + "_mesh.ply")
    print(f"| {model} | {m['iterations']} | {m['primitives']} | {e0['psnr']:.2f} → {e1['psnr']:.2f} dB "
          f"| {e0['ssim']:.3f} → {e1['ssim']:.3f} | {timing(model)} | {faces(mesh)} | {timing(model + '_mesh')} |")
