#!/usr/bin/env python3
"""Pictures for dtu_train.mk: renders two held-out views of both trained models and of both meshes
(lit), beside the masked photo, into OUT/pictures/dtu24_train.png (rows: views; columns: photo,
triangles, Gaussians, triangle mesh, Gaussian mesh).

usage: dtu_train_pictures.py OUT DATA "SPLATKIT COMMAND"
Needs Pillow (pip install pillow)."""
import glob
import json
import os
import shlex
import subprocess
import sys

from PIL import Image, ImageDraw

out, data, splatkit = sys.argv[1], sys.argv[2], shlex.split(sys.argv[3])
pics = os.path.join(out, "pictures")
os.makedirs(pics, exist_ok=True)
cams = os.path.join(out, "triangles", "cameras.json")
metrics = json.load(open(os.path.join(out, "triangles", "metrics.json")))
test = [v[0] for v in metrics["evals"][-1]["views"]][:2]


def last(pattern):
    return sorted(glob.glob(pattern), key=lambda p: int(p.split("iteration_")[1].split("/")[0]))[-1]


scenes = {
    "triangles": last(os.path.join(out, "triangles/point_cloud/iteration_*/point_cloud_state_dict.pt")),
    "gaussians": last(os.path.join(out, "gaussians/point_cloud/iteration_*/point_cloud.ply")),
    "triangles_mesh": os.path.join(out, "triangles_mesh.ply"),
    "gaussians_mesh": os.path.join(out, "gaussians_mesh.ply"),
}
for name, scene in scenes.items():
    args = splatkit + ["render", scene, "--cameras", cams, "--outputs", "rgb", "-o", os.path.join(pics, name), "-q"]
    if name.endswith("mesh"):
        args += ["--shading", "lit"]
    subprocess.run(args, check=True)

cj = json.load(open(cams))
size = (cj[0]["width"], cj[0]["height"])
photo_dir = next(d for d in ("image", "images", "image_full", "image_half") if os.path.isdir(os.path.join(data, d))
                 and len(os.listdir(os.path.join(data, d))) >= len(cj))


def find(folder, stem):
    for ext in ("png", "jpg"):
        for cand in (f"{stem}.{ext}", f"{stem}_rgb.{ext}"):
            p = os.path.join(folder, cand)
            if os.path.exists(p):
                return p
    hits = sorted(glob.glob(os.path.join(folder, f"*{stem}*")))
    return hits[0] if hits else None


cols = ["photo"] + list(scenes)
W, H = size
sheet = Image.new("RGB", (W * len(cols), (H + 16) * len(test)), "white")
d = ImageDraw.Draw(sheet)
for r, name in enumerate(test):
    idx = [c["img_name"] for c in cj].index(name) if "img_name" in cj[0] else r
    photos = sorted(os.listdir(os.path.join(data, photo_dir)))
    tiles = [Image.open(os.path.join(data, photo_dir, photos[idx])).convert("RGB").resize(size)]
    for s in scenes:
        p = find(os.path.join(pics, s), name)
        tiles.append(Image.open(p).convert("RGB").resize(size) if p else Image.new("RGB", size, "grey"))
    for c, t in enumerate(tiles):
        sheet.paste(t, (c * W, r * (H + 16) + 16))
        d.text((c * W + 4, r * (H + 16) + 2), f"{cols[c]} ({name})", fill="black")
sheet.save(os.path.join(pics, "dtu24_train.png"))
print(os.path.join(pics, "dtu24_train.png"))
