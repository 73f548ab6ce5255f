#!/usr/bin/env python3
"""The table of scripts/mesh_bench.mk (standard library only).

    scripts/mesh_bench_table.py OUT "SHAPES" "METHODS" ITERS > OUT/table.md
"""
import json
import os
import sys


def load(path):
    with open(path) as f:
        return json.load(f)


def mesh_counts(path):
    """Vertex and face counts from a PLY header."""
    v = f = 0
    with open(path, "rb") as fh:
        for raw in fh:
            line = raw.decode("ascii", "replace").split()
            if line[:2] == ["element", "vertex"]:
                v = int(line[2])
            elif line[:2] == ["element", "face"]:
                f = int(line[2])
            elif line[:1] == ["end_header"]:
                break
    return v, f


STAGES = {"sugar": ["sugar_points", "sugar_poisson"], "tsdf": ["tsdf"], "tetra": ["tetra"]}
NAMES = {"sugar": "splat2points + poisson --sugar", "tsdf": "tsdf-fuse", "tetra": "tetra-mesh"}


def main():
    out, shapes, methods, iters = sys.argv[1], sys.argv[2].split(), sys.argv[3].split(), sys.argv[4]
    print("| shape | method | vertices | faces | time s | peak MiB | accuracy | completeness "
          "| DTU d2s / s2d / overall mm | TnT P / R / F |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for s in shapes:
        d = os.path.join(out, s)
        train = load(os.path.join(d, "time", "train.json"))
        metrics = load(os.path.join(d, "gs", "metrics.json"))
        prims = metrics.get("primitives")
        evals = metrics.get("evals") or [{}]
        psnr = evals[-1].get("psnr")
        print(f"| {s} | train gaussians ({iters} it, {prims} Gaussians, held-out PSNR "
              f"{psnr:.2f} dB) | | | {train['seconds']:.1f} | {train['peak_rss_mib']:.0f} | | | | |"
              if psnr is not None else
              f"| {s} | train gaussians ({iters} it, {prims} Gaussians) | | | "
              f"{train['seconds']:.1f} | {train['peak_rss_mib']:.0f} | | | | |")
        for m in methods:
            times = [load(os.path.join(d, "time", f"{st}.json")) for st in STAGES[m]]
            secs = sum(t["seconds"] for t in times)
            peak = max(t["peak_rss_mib"] for t in times)
            v, f = mesh_counts(os.path.join(d, f"{m}.ply"))
            ex = load(os.path.join(d, "score", f"{m}.exact.json"))
            dtu = load(os.path.join(d, "score", f"{m}.dtu.json"))
            tnt = load(os.path.join(d, "score", f"{m}.tnt.json"))
            print(f"| {s} | {NAMES.get(m, m)} | {v:,} | {f:,} | {secs:.1f} | {peak:.0f} "
                  f"| {ex['accuracy']['mean']:.4f} | {ex['completeness']['mean']:.4f} "
                  f"| {dtu['mean_d2s']:.3f} / {dtu['mean_s2d']:.3f} / {dtu['overall']:.3f} "
                  f"| {tnt['precision']:.3f} / {tnt['recall']:.3f} / {tnt['fscore']:.3f} |")


if __name__ == "__main__":
    main()
