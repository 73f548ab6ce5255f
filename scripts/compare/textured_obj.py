#!/usr/bin/env python3
"""Does a textured OBJ written by `bake-texture` open with its texture in the
tools users have? Loads it with Open3D and trimesh and prints, for each,
whether the texture is attached and its size.

Usage: scripts/compare/textured_obj.py MESH.obj

Installs open3d-cpu, trimesh and pillow (trimesh's image loader) with pip
into a virtual environment under /tmp (SPLATKIT_COMPARE_VENV to choose
another) on first use, then re-runs itself there.
"""
import os
import subprocess
import sys

VENV = os.environ.get("SPLATKIT_COMPARE_VENV", "/tmp/splatkit-textured-obj-venv")


def ensure_venv():
    py = os.path.join(VENV, "bin", "python")
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        return
    if not os.path.exists(py):
        subprocess.check_call([sys.executable, "-m", "venv", VENV])
        subprocess.check_call([py, "-m", "pip", "install", "-q", "open3d-cpu", "trimesh", "pillow"])
    os.execv(py, [py] + sys.argv)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    path = sys.argv[1]
    ensure_venv()
    import numpy as np
    import open3d as o3d
    import trimesh

    def describe_o3d(m):
        shapes = [np.asarray(t).shape for t in m.textures]
        sizes = ["empty" if len(s) < 2 else f"{s[1]}x{s[0]}" for s in shapes]
        ids = np.unique(np.asarray(m.triangle_material_ids)).tolist()
        return (
            f"triangles {len(m.triangles)}, has_textures() = {m.has_textures()}, "
            f"has_triangle_uvs() = {m.has_triangle_uvs()}, textures {sizes}, "
            f"material ids used {ids}"
        )

    m = o3d.io.read_triangle_mesh(path, enable_post_processing=False)
    print(f"open3d {o3d.__version__}: {describe_o3d(m)}")
    # Control: a one-triangle textured mesh written by Open3D itself and read
    # back, to tell Open3D's own reader behaviour from a problem of the file.
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        c = o3d.geometry.TriangleMesh()
        c.vertices = o3d.utility.Vector3dVector(np.eye(3))
        c.triangles = o3d.utility.Vector3iVector(np.array([[0, 1, 2]]))
        c.triangle_uvs = o3d.utility.Vector2dVector(np.array([[0, 0], [1, 0], [0, 1]], float))
        c.textures = [o3d.geometry.Image(np.zeros((4, 4, 3), np.uint8))]
        c.triangle_material_ids = o3d.utility.IntVector([0])
        o3d.io.write_triangle_mesh(os.path.join(d, "c.obj"), c)
        back = o3d.io.read_triangle_mesh(os.path.join(d, "c.obj"))
        print(f"open3d control (its own textured OBJ read back): {describe_o3d(back)}")

    t = trimesh.load(path, force="mesh", process=False)
    kind = t.visual.kind
    img = getattr(getattr(t.visual, "material", None), "image", None)
    size = f"{img.size[0]}x{img.size[1]}" if img is not None else None
    uv = getattr(t.visual, "uv", None)
    uv_range = (
        f"[{uv.min():.4f}, {uv.max():.4f}]" if uv is not None and len(uv) else None
    )
    print(
        f"trimesh {trimesh.__version__}: faces {len(t.faces)}, visual.kind = {kind!r} "
        f"(texture attached: {kind == 'texture'}), image {size}, uv range {uv_range}"
    )


if __name__ == "__main__":
    main()
