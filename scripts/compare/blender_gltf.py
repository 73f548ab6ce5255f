#!/usr/bin/env python3
"""Import export-off's GLB and OBJ of the same run into Blender and compare the colours Blender reads.

usage: python3 scripts/compare/blender_gltf.py [INPUT] [--bin DIR]
  INPUT  a triangle soup (.pt or soup .ply); default testdata/pt/ts_f32_param.pt
  --bin  folder holding the export-off binary; default target/release, else target/debug
Installs Blender as a Python module (`pip install bpy`, 5.0.1 on Python 3.11; bpy wheels exist for
one Python minor version per Blender release) into a venv under /tmp on first use.

1. export-off INPUT -o run.glb and -o run.obj (same colours: OBJ `v x y z r g b` holds the 8-bit
   sRGB values / 255; glTF COLOR_0 must hold their linear values).
2. Blender's glTF importer (bpy.ops.import_scene.gltf) and OBJ importer (bpy.ops.wm.obj_import);
   per face corner, the colour Blender shows in sRGB (`color_srgb` of the colour attribute, i.e. after
   Blender's own conversion) is compared between the two: every channel must agree within 1/255.
3. export-off INPUT --alpha -o alpha.glb: the imported material must use blended rendering
   (surface_render_method BLENDED), the Principled BSDF's Alpha must be fed by the colour attribute,
   and the attribute's alpha must equal the alpha export-off wrote (within 1/255).
Prints the numbers and exits non-zero when a check fails.
"""
import os
import subprocess
import sys

VENV = "/tmp/splatkit-bpy-venv"
if not os.path.exists(os.path.join(VENV, "bin", "python")):
    subprocess.check_call([sys.executable, "-m", "venv", VENV])
    subprocess.check_call([os.path.join(VENV, "bin", "pip"), "install", "-q", "bpy", "numpy"])
if sys.prefix != VENV:
    os.execv(os.path.join(VENV, "bin", "python"), [os.path.join(VENV, "bin", "python")] + sys.argv)

import tempfile  # noqa: E402

import bpy  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
args = [a for a in sys.argv[1:]]
bindir = None
if "--bin" in args:
    i = args.index("--bin")
    bindir = args[i + 1]
    del args[i : i + 2]
inp = args[0] if args else os.path.join(ROOT, "testdata/pt/ts_f32_param.pt")
if bindir is None:
    for b in ("target/release", "target/debug"):
        if os.path.exists(os.path.join(ROOT, b, "export-off")):
            bindir = os.path.join(ROOT, b)
            break
exe = os.path.join(bindir, "export-off")
tmp = tempfile.mkdtemp(prefix="splatkit-blender-")


def export(name, *flags):
    out = os.path.join(tmp, name)
    subprocess.check_call([exe, inp, "-o", out, "-q", *flags])
    return out


def import_file(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.endswith(".obj"):
        bpy.ops.wm.obj_import(filepath=path)
    else:
        bpy.ops.import_scene.gltf(filepath=path)
    objs = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    assert len(objs) == 1, objs
    return objs[0]


def corner_colours(ob):
    """Per face: [(position, sRGB RGBA)] of its corners, as Blender shows them."""
    me = ob.data
    attr = me.color_attributes[me.color_attributes.render_color_index]
    n = len(attr.data)
    col = np.empty(4 * n, dtype=np.float32)
    attr.data.foreach_get("color_srgb", col)
    col = col.reshape(n, 4)
    faces = []
    for p in me.polygons:
        corners = []
        for li in p.loop_indices:
            vi = me.loops[li].vertex_index
            c = col[li] if attr.domain == "CORNER" else col[vi]
            corners.append((tuple(round(x, 5) for x in me.vertices[vi].co), c))
        faces.append(corners)
    # plain values only: the next import frees Blender's data
    return f"{attr.data_type}/{attr.domain}", faces


ok = True
glb, obj = export("run.glb"), export("run.obj")
a_glb, f_glb = corner_colours(import_file(glb))
a_obj, f_obj = corner_colours(import_file(obj))
print(f"blender {bpy.app.version_string}; input {inp}")
print(f"glTF import: {len(f_glb)} faces, colour attribute {a_glb}")
print(f"OBJ import:  {len(f_obj)} faces, colour attribute {a_obj}")
if len(f_glb) != len(f_obj):
    print("FAIL: face counts differ")
    sys.exit(1)
worst = 0.0
# Faces and their corners come in file order from both importers (each applies its own axis
# conversion, so positions are not compared).
for fg, fo in zip(f_glb, f_obj):
    for (_, c), (_, d) in zip(fg, fo):
        worst = max(worst, float(np.abs(c[:3] - d[:3]).max()))
print(f"max |glTF - OBJ| over every corner and RGB channel, sRGB as Blender shows: "
      f"{worst:.6f} = {worst * 255:.3f}/255")
ok &= worst <= 1.0 / 255 + 1e-6

alpha_glb = export("alpha.glb", "--alpha")
alpha_off = export("alpha.off", "--alpha", "--per-vertex-colors", "--off-layout", "compatible")
ob = import_file(alpha_glb)
mat = ob.active_material
method = getattr(mat, "surface_render_method", None)
bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
alpha_links = [l.from_node.type + "." + l.from_socket.name for l in bsdf.inputs["Alpha"].links]
print(f"alpha GLB: material {mat.name!r}, surface_render_method {method}, Alpha fed by {alpha_links}")
ok &= method == "BLENDED" and any(s.endswith(".Alpha") for s in alpha_links)
_, f_a = corner_colours(ob)
# the OFF written alongside: r g b a per vertex, three vertices per face, in face order
lines = [l for l in open(alpha_off).read().split("\n") if l.strip()]
nv, nf = map(int, lines[1].split()[:2])
want_a = np.array([float(l.split()[6]) for l in lines[2 : 2 + nv]]) / 255.0
got_a = np.array([c[3] for face in f_a for _, c in face])
aerr = float(np.abs(np.sort(got_a) - np.sort(want_a)).max()) if len(got_a) == len(want_a) else 1.0
print(f"alpha: {len(got_a)} corners, {int((want_a < 1).sum())} below 1; max |Blender - written| = "
      f"{aerr:.6f} = {aerr * 255:.3f}/255")
ok &= aerr <= 1.0 / 255 + 1e-6
print("OK" if ok else "FAIL")
sys.exit(0 if ok else 1)
