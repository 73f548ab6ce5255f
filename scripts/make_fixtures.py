#!/usr/bin/env python3
"""Write testdata/: small files written by the tools splatkit's users already
run, plus the values a reader must find in them (testdata/expected.json),
computed here by those tools and numpy, never by splatkit.

Usage (from the repository root):

    python3 -m venv /tmp/fxvenv
    /tmp/fxvenv/bin/pip install numpy scipy open3d trimesh pymeshlab pycolmap plyfile torch
    /tmp/fxvenv/bin/python scripts/make_fixtures.py [TESTDATA_DIR]
    /tmp/fxvenv/bin/python scripts/make_fixtures.py --only-mip [TESTDATA_DIR]

(--only-mip writes only gaussians/mip_splatting.{ply,json}, needing only
numpy and plyfile, and prints its README lines.)
    /tmp/fxvenv/bin/python scripts/make_fixtures.py --only-surfels [TESTDATA_DIR]

TESTDATA_DIR defaults to testdata/ at the repository root. Everything is
deterministic (fixed seeds); re-running rewrites the same bytes except the
creation date in the .mat headers. It also runs
scripts/make_pt_fixtures.py into TESTDATA_DIR/pt and writes
TESTDATA_DIR/README.md (one line per file: script, tool and version).
Open3D needs libusb-1.0 (Debian: apt-get install libusb-1.0-0).

What is written, and checked by tests/fixtures.rs:
  mat/       scipy.io.savemat, the DTU evaluation layout: ObsMask (3-D
             logical), BB (2x3), Res (scalar); Plane: P (4x1); compressed
             (do_compression=True, as MATLAB -v7) and uncompressed
  npz/       numpy np.savez / np.savez_compressed, the NeuS/IDR
             cameras_sphere.npz layout (world_mat_i, scale_mat_i)
  mesh/      Open3D, trimesh and pymeshlab PLY (ASCII and binary) and OBJ of
             a coloured icosphere with normals and of a coloured oriented
             point cloud; a GLB written by trimesh
  colmap/    a COLMAP text model written by pycolmap (write_text)
  gaussians/ a 3DGS PLY written with plyfile as graphdeco's save_ply does,
             and a Mip-Splatting / GOF PLY (with filter_3D) as theirs does
  surfels/   a 2DGS PLY written as hbb1/2d-gaussian-splatting's save_ply does
             (two scales), with its own expected.json (--only-surfels
             writes just this folder and prints its README lines)
  splats/scene300/ a small 3DGS PLY and its compressed PLY (splat-transform),
             .splat (antimatter15 convert.py) and KSPLAT (GaussianSplats3D),
             with splat-transform's decoding in splats/scene300/expected.json
             (`make_fixtures.py --only splats` writes just these; needs
             node/npm, see splat_files)

Each entry of expected.json says how its floats compare: "exact" (the f32
the tool stored, or the f64 it stored rounded to f32 by the reader) or a
tolerance |got - want| <= abs + rel * |want| matching the precision the tool
prints, with a note naming that precision. Every file is read back here with
the tool that wrote it and checked against the same values and tolerance.
"""

import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# Tolerances for ASCII text. A value printed with d significant digits is
# within 0.5e-(d-1) relative of the number; the reader then rounds it to f32
# (2^-24 relative). F32_REL covers one f32 rounding step each way.
F32_REL = 1.2e-7
G6 = {"exact": False, "rel": 5e-6 + F32_REL, "abs": 1e-12, "note": "printed with %g (6 significant digits)"}
G16 = {"exact": False, "rel": F32_REL, "abs": 1e-12, "note": "printed with 16-17 significant digits, then rounded to f32"}
F8 = {"exact": False, "rel": F32_REL, "abs": 5.1e-9, "note": "printed with %.8f (8 decimals)"}
EXACT = {"exact": True, "rel": 0.0, "abs": 0.0, "note": "binary: the reader's f32 equals the stored value rounded to f32"}


def rows(a, kind=float):
    """A 2-D array as nested lists of Python numbers (f64 repr is exact)."""
    return [[kind(x) for x in r] for r in np.asarray(a)]


def close(got, want, tol, what):
    """Check a tool's read-back against the expected values with a tolerance."""
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
    if tol["exact"]:
        ok = np.array_equal(got.astype(np.float32), want.astype(np.float32))
    else:
        ok = np.all(np.abs(got - want) <= tol["abs"] + tol["rel"] * np.abs(want))
    assert ok, f"{what}: read-back differs beyond {tol}"


# --------------------------------------------------------------------------
# Shapes shared by the mesh writers.

def icosphere():
    """A coloured icosphere (162 vertices, 320 faces), off-centre and scaled
    so that coordinates are not round numbers."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=2)
    v = np.asarray(ico.vertices) * 1.75 + np.array([0.25, -0.5, 2.125])
    rng = np.random.default_rng(10)
    rgb = rng.integers(0, 256, (len(v), 3))
    return v, np.asarray(ico.faces), rgb


def oriented_points():
    """96 points with unit normals and colours."""
    rng = np.random.default_rng(11)
    p = rng.normal(size=(96, 3)) * np.array([2.0, 1.0, 0.5]) + np.array([1.0, 2.0, -3.0])
    n = rng.normal(size=(96, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    rgb = rng.integers(0, 256, (96, 3))
    return p, n, rgb


# Arrays that several files share (the same in-memory mesh saved in several
# formats) are stored once in expected.json's "arrays" and referenced as
# "@name" from the file entries.
ARRAYS = {}


def shared(name, value):
    """`value` (nested lists) stored once; returns its "@name" reference."""
    text = json.dumps(value)
    for k, v in ARRAYS.items():
        if json.dumps(v) == text:
            return "@" + k
    assert name not in ARRAYS, name
    ARRAYS[name] = value
    return "@" + name


def mesh_entry(writer, version, v, f, n, rgba, tol, scalars=None):
    w = writer.lower()
    e = {
        "kind": "mesh",
        "writer": f"{writer} {version}",
        "vertices": shared("icosphere_vertices", rows(v)),
        "faces": shared("icosphere_faces", rows(f, int)),
        "normals": shared(f"icosphere_normals_{w}", rows(n)) if n is not None else None,
        "colors": shared("icosphere_colors", rows(rgba, int)) if rgba is not None else None,
        "tol": tol,
    }
    if scalars:
        e["vertex_scalars"] = {k: shared(f"icosphere_{k}_{w}", [float(x) for x in s]) for k, s in scalars.items()}
    return e


def points_entry(writer, version, p, n, rgb, tol):
    w = writer.lower()
    return {
        "kind": "points",
        "writer": f"{writer} {version}",
        "positions": shared("points_positions", rows(p)),
        "normals": shared("points_normals", rows(n)) if n is not None else None,
        "colors": shared("points_colors", rows(rgb, int)) if rgb is not None else None,
        "tol": tol,
    }


def u8_from_unit(c):
    """0-1 colours (as the tools hold them) to the 0-255 they stand for."""
    return np.rint(np.asarray(c) * 255.0).astype(int)


# --------------------------------------------------------------------------

def open3d_files(out, exp, readme):
    import open3d as o3d

    ver = o3d.__version__
    v, f, rgb = icosphere()
    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(f))
    m.compute_vertex_normals()
    m.vertex_colors = o3d.utility.Vector3dVector(rgb / 255.0)
    mv = np.asarray(m.vertices)
    mn = np.asarray(m.vertex_normals)
    mc = u8_from_unit(np.asarray(m.vertex_colors))
    rgba = np.c_[mc, np.full(len(mc), 255)]
    mf = np.asarray(m.triangles)
    for name, ascii_, tol in [
        ("open3d_mesh_ascii.ply", True, G6),
        ("open3d_mesh_binary.ply", False, EXACT),
    ]:
        path = os.path.join(out, "mesh", name)
        o3d.io.write_triangle_mesh(path, m, write_ascii=ascii_)
        back = o3d.io.read_triangle_mesh(path)
        close(back.vertices, mv, tol, name)
        close(back.vertex_normals, mn, tol, name)
        assert np.array_equal(np.asarray(back.triangles), mf)
        exp[f"mesh/{name}"] = mesh_entry("Open3D", ver, mv, mf, mn, rgba, tol)
        kind = "ASCII" if ascii_ else "binary little-endian"
        readme.append((f"mesh/{name}", f"open3d.io.write_triangle_mesh (Open3D {ver})",
                       f"{kind} PLY, icosphere 162 v / 320 f, double x y z nx ny nz, uchar rgb"))
    name = "open3d_mesh.obj"
    path = os.path.join(out, "mesh", name)
    o3d.io.write_triangle_mesh(path, m)
    back = o3d.io.read_triangle_mesh(path)
    # Open3D's OBJ reader renumbers vertices in face-corner order: compare
    # the sorted rows. (tests/fixtures.rs compares them in file order.)
    bv = np.asarray(back.vertices)
    close(bv[np.lexsort(bv.T)], mv[np.lexsort(mv.T)], G6, name)
    exp[f"mesh/{name}"] = mesh_entry("Open3D", ver, mv, mf, mn, rgba, G6)
    readme.append((f"mesh/{name}", f"open3d.io.write_triangle_mesh (Open3D {ver})",
                   "OBJ, v x y z r g b (%g), vn, f a//a"))

    p, n, prgb = oriented_points()
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
    pc.normals = o3d.utility.Vector3dVector(n)
    pc.colors = o3d.utility.Vector3dVector(prgb / 255.0)
    pp, pn, pcol = np.asarray(pc.points), np.asarray(pc.normals), u8_from_unit(np.asarray(pc.colors))
    for name, ascii_, tol in [
        ("open3d_points_ascii.ply", True, G6),
        ("open3d_points_binary.ply", False, EXACT),
    ]:
        path = os.path.join(out, "mesh", name)
        o3d.io.write_point_cloud(path, pc, write_ascii=ascii_)
        back = o3d.io.read_point_cloud(path)
        close(back.points, pp, tol, name)
        close(back.normals, pn, tol, name)
        close(u8_from_unit(np.asarray(back.colors)), pcol, EXACT, name)
        exp[f"mesh/{name}"] = points_entry("Open3D", ver, pp, pn, pcol, tol)
        kind = "ASCII" if ascii_ else "binary little-endian"
        readme.append((f"mesh/{name}", f"open3d.io.write_point_cloud (Open3D {ver})",
                       f"{kind} PLY, 96 points, double x y z nx ny nz, uchar rgb"))
    return f"Open3D {ver}"


def trimesh_files(out, exp, readme):
    import trimesh

    ver = trimesh.__version__
    v, f, rgb = icosphere()
    rgba = np.c_[rgb, np.full(len(rgb), 255)].astype(np.uint8)
    t = trimesh.Trimesh(v, f, vertex_colors=rgba, process=False)
    tn = np.array(t.vertex_normals)  # computed by trimesh (area-weighted, unit)
    tv, tf, tc = np.asarray(t.vertices), np.asarray(t.faces), np.asarray(t.visual.vertex_colors)
    files = [
        ("trimesh_mesh_binary.ply", {}, EXACT, "binary little-endian PLY, float x y z nx ny nz, uchar rgba"),
        ("trimesh_mesh_ascii.ply", {"encoding": "ascii"}, F8, "ASCII PLY (%.8f), float x y z nx ny nz, uchar rgba"),
        ("trimesh_mesh.obj", {}, F8, "OBJ, v x y z r g b (%.8f), vn, f a//a"),
        ("trimesh_mesh.glb", {}, EXACT, "GLB: POSITION, NORMAL (f32), COLOR_0 (normalised u8 RGBA), u32 indices"),
    ]
    for name, kw, tol, what in files:
        path = os.path.join(out, "mesh", name)
        t.export(path, **kw)
        back = trimesh.load(path, process=False, force="mesh")
        close(back.vertices, tv, tol, name)
        assert np.array_equal(np.asarray(back.faces), tf), name
        colors = tc
        if name.endswith(".obj"):
            colors = np.c_[tc[:, :3], np.full(len(tc), 255)]  # OBJ has no alpha
        exp[f"mesh/{name}"] = mesh_entry("trimesh", ver, tv, tf, tn, colors, tol)
        readme.append((f"mesh/{name}", f"trimesh.Trimesh.export (trimesh {ver})", what))

    p, _, prgb = oriented_points()
    tp = trimesh.PointCloud(p, colors=np.c_[prgb, np.full(len(prgb), 255)].astype(np.uint8))
    for name, kw, tol, what in [
        ("trimesh_points_binary.ply", {}, EXACT, "binary little-endian PLY, 96 points, float x y z, uchar rgba"),
        ("trimesh_points_ascii.ply", {"encoding": "ascii"}, F8, "ASCII PLY (%.8f), 96 points, float x y z, uchar rgba"),
    ]:
        path = os.path.join(out, "mesh", name)
        tp.export(path, **kw)
        back = trimesh.load(path)
        close(back.vertices, tp.vertices, tol, name)
        exp[f"mesh/{name}"] = points_entry(
            "trimesh", ver, np.asarray(tp.vertices), None, np.asarray(tp.colors)[:, :3], tol
        )
        readme.append((f"mesh/{name}", f"trimesh.PointCloud.export (trimesh {ver})", what))
    return f"trimesh {ver}"


def pymeshlab_files(out, exp, readme):
    import pymeshlab

    ver = pymeshlab.__version__ if hasattr(pymeshlab, "__version__") else None
    if ver is None:
        from importlib.metadata import version

        ver = version("pymeshlab")
    v, f, rgb = icosphere()
    ms = pymeshlab.MeshSet()
    ms.add_mesh(
        pymeshlab.Mesh(
            vertex_matrix=v,
            face_matrix=f,
            v_color_matrix=np.c_[rgb / 255.0, np.ones(len(rgb))],
        ),
        "icosphere",
    )
    # MeshLab computes area-weighted vertex normals on load; make them unit,
    # as a user does with Filters > Normals > Normalize Vertex Normals.
    ms.apply_filter("apply_normal_normalization_per_vertex")
    cm = ms.current_mesh()
    mv, mf, mn = cm.vertex_matrix(), cm.face_matrix(), cm.vertex_normal_matrix()
    mc = u8_from_unit(cm.vertex_color_matrix())
    quality = cm.vertex_scalar_array()
    files = [
        ("pymeshlab_mesh_binary.ply", {"save_vertex_normal": True}, EXACT,
         "binary little-endian PLY (defaults + save_vertex_normal): double x y z nx ny nz, uchar rgba, double quality"),
        ("pymeshlab_mesh_ascii.ply", {"binary": False, "save_vertex_normal": True}, G16,
         "ASCII PLY (%.16g), double x y z nx ny nz, uchar rgba, double quality"),
        ("pymeshlab_mesh.obj", {"save_vertex_normal": True}, G16,
         "OBJ, v x y z (%.16f) r g b (%f), vn, f a//a"),
    ]
    for name, kw, tol, what in files:
        path = os.path.join(out, "mesh", name)
        ms.save_current_mesh(path, **kw)
        back = pymeshlab.MeshSet()
        back.load_new_mesh(path)
        close(back.current_mesh().vertex_matrix(), mv, tol, name)
        assert np.array_equal(back.current_mesh().face_matrix(), mf), name
        scalars = {"quality": quality} if name.endswith(".ply") else None
        exp[f"mesh/{name}"] = mesh_entry("pymeshlab", ver, mv, mf, mn, mc, tol, scalars)
        readme.append((f"mesh/{name}", f"pymeshlab.MeshSet.save_current_mesh (PyMeshLab {ver})", what))

    p, n, prgb = oriented_points()
    ms = pymeshlab.MeshSet()
    ms.add_mesh(
        pymeshlab.Mesh(vertex_matrix=p, v_normals_matrix=n, v_color_matrix=np.c_[prgb / 255.0, np.ones(len(p))]),
        "points",
    )
    cm = ms.current_mesh()
    pp, pn, pcol = cm.vertex_matrix(), cm.vertex_normal_matrix(), u8_from_unit(cm.vertex_color_matrix())[:, :3]
    name = "pymeshlab_points_binary.ply"
    path = os.path.join(out, "mesh", name)
    ms.save_current_mesh(path, save_vertex_normal=True)
    back = pymeshlab.MeshSet()
    back.load_new_mesh(path)
    close(back.current_mesh().vertex_normal_matrix(), pn, EXACT, name)
    exp[f"mesh/{name}"] = points_entry("pymeshlab", ver, pp, pn, pcol, EXACT)
    readme.append((f"mesh/{name}", f"pymeshlab.MeshSet.save_current_mesh (PyMeshLab {ver})",
                   "binary little-endian PLY, 96 points (a mesh with no faces), double x y z nx ny nz, uchar rgba"))
    return f"PyMeshLab {ver}"


# --------------------------------------------------------------------------

def mat_files(out, exp, readme):
    import scipy
    import scipy.io

    ver = scipy.__version__
    rng = np.random.default_rng(12)
    dims = (7, 5, 4)
    mask = rng.random(dims) < 0.6
    res = 0.5
    bb = np.array([[-12.25, 3.5, 610.1], [-9.25, 5.5, 611.6]])
    plane = np.array([[0.011], [-0.023], [0.9996], [-612.375]])

    # eval.py's observability test, on probe points: BB cast to float32,
    # voxel = np.around((p - BB_min) / Res) as int32, kept when in range.
    bb32 = bb.astype(np.float32)
    probes = []
    for g in np.ndindex(*dims):
        probes.append(bb[0] + np.array(g) * res)
    probes = np.array(probes[::3])
    probes = np.r_[probes, probes[:12] + rng.uniform(-0.3, 0.3, (12, 3)),
                   [[-13.0, 4.0, 610.5], [-10.0, 6.0, 610.5], [-10.0, 4.0, 612.2]]]
    grid = np.around((probes - bb32[:1]) / res).astype(np.int32)
    inside = np.all((grid >= 0) & (grid < np.array(dims)), axis=1)
    in_obs = np.zeros(len(probes), dtype=bool)
    in_obs[inside] = mask[grid[inside, 0], grid[inside, 1], grid[inside, 2]]

    for comp in [True, False]:
        suffix = "" if comp else "_uncompressed"
        for name, data in [
            (f"ObsMask1_10{suffix}.mat", {"ObsMask": mask, "BB": bb, "Res": res}),
            (f"Plane1{suffix}.mat", {"P": plane}),
        ]:
            path = os.path.join(out, "mat", name)
            scipy.io.savemat(path, data, do_compression=comp)
            back = scipy.io.loadmat(path)
            for k, val in data.items():
                assert np.array_equal(back[k], np.atleast_2d(val)), (name, k)
            if "ObsMask" in data:
                assert back["ObsMask"].dtype == np.uint8 or back["ObsMask"].dtype == bool
                exp[f"mat/{name}"] = {
                    "kind": "obsmask",
                    "writer": f"scipy {ver}",
                    "dims": list(dims),
                    "mask_column_major": [int(x) for x in mask.flatten(order="F")],
                    "bb": rows(bb),
                    "res": res,
                    "probes": rows(probes),
                    "in_obs": [bool(x) for x in in_obs],
                }
                what = "ObsMask 7x5x4 logical, BB 2x3 double, Res 1x1 double"
            else:
                exp[f"mat/{name}"] = {"kind": "plane", "writer": f"scipy {ver}", "dims": [4, 1],
                                      "p": [float(x) for x in plane.flatten()]}
                what = "P 4x1 double"
            how = "do_compression=True" if comp else "uncompressed"
            readme.append((f"mat/{name}", f"scipy.io.savemat, {how} (SciPy {ver})", f"MAT v5, {what}"))
    return f"SciPy {ver}"


def rot(axis, angle):
    axis = np.asarray(axis, dtype=np.float64)
    axis /= np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def decompose(p):
    """P (3x4) = s K [R | t] with K upper-triangular, positive diagonal,
    K[2,2] = 1, det R = +1 (scipy's RQ decomposition)."""
    import scipy.linalg

    k, r = scipy.linalg.rq(p[:, :3])
    d = np.diag(np.sign(np.diag(k)))
    k, r = k @ d, d @ r
    s = k[2, 2]
    k = k / s
    if np.linalg.det(r) < 0:
        r, s = -r, -s
    t = np.linalg.solve(s * k, p[:, 3])
    return k, r, t


def npz_files(out, exp, readme):
    ver = np.__version__
    rng = np.random.default_rng(13)
    # Normalised-frame cameras looking at the origin, then the world frame
    # (DTU-like: millimetres, object centred away from the origin).
    scale = 212.5
    centre = np.array([-24.0, 17.5, 610.0])
    scale_mat = np.eye(4)
    scale_mat[:3, :3] *= scale
    scale_mat[:3, 3] = centre
    arrays = {}
    truth = []
    for i in range(4):
        fx, fy = 1150.0 + 10 * i, 1148.5 + 10 * i
        cx, cy = 799.5 - i, 599.5 + 0.25 * i
        k = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        r = rot(rng.normal(size=3), rng.uniform(0.2, 1.0))
        cam_centre = -r.T @ np.array([0.0, 0.0, 3.0]) + rng.normal(size=3) * 0.1
        t = -r @ cam_centre
        p_norm = k @ np.c_[r, t]
        world = np.eye(4)
        world[:3, :4] = p_norm @ np.linalg.inv(scale_mat)
        arrays[f"world_mat_{i}"] = world
        arrays[f"scale_mat_{i}"] = scale_mat
        truth.append((k, r, t))
    cams_norm, cams_world = [], []
    for i, (k0, r0, t0) in enumerate(truth):
        w = arrays[f"world_mat_{i}"]
        for frame, out_list in [("norm", cams_norm), ("world", cams_world)]:
            p = (w @ scale_mat)[:3] if frame == "norm" else w[:3]
            k, r, t = decompose(p)
            if frame == "norm":
                assert np.allclose(k, k0, rtol=1e-9) and np.allclose(r, r0, atol=1e-9)
                assert np.allclose(t, t0, atol=1e-9)
            out_list.append({
                "name": f"{i:03}",
                "width": int(round(2 * (k[0, 2] + 0.5))),
                "height": int(round(2 * (k[1, 2] + 0.5))),
                "fx": k[0, 0], "fy": k[1, 1],
                "cx": k[0, 2] + 0.5, "cy": k[1, 2] + 0.5,
                "rotation": rows(r), "translation": [float(x) for x in t],
            })
    entry = {
        "kind": "neus_npz",
        "writer": f"numpy {ver}",
        "world_mats": [rows(arrays[f"world_mat_{i}"]) for i in range(4)],
        "scale_mat": rows(scale_mat),
        "cameras_normalised": cams_norm,
        "cameras_world": cams_world,
        "tol": {"rel": 1e-9, "abs": 1e-9,
                "note": "decomposition by scipy.linalg.rq in f64; raw matrices are exact f64"},
    }
    for name, fn, how in [
        ("cameras_sphere.npz", np.savez, "np.savez (stored)"),
        ("cameras_sphere_compressed.npz", np.savez_compressed, "np.savez_compressed (deflate)"),
    ]:
        path = os.path.join(out, "npz", name)
        fn(path, **arrays)
        with np.load(path) as back:
            for key, val in arrays.items():
                assert np.array_equal(back[key], val)
        exp[f"npz/{name}"] = dict(entry, writer=f"numpy {ver}")
        readme.append((f"npz/{name}", f"{how} (NumPy {ver})",
                       "NeuS cameras_sphere.npz: world_mat_0..3, scale_mat_0..3 (4x4 float64)"))
    return f"NumPy {ver}"


def colmap_files(out, exp, readme):
    import pycolmap

    ver = pycolmap.__version__
    rng = np.random.default_rng(14)
    rec = pycolmap.Reconstruction()
    cams = [
        (1, "PINHOLE", 640, 480, [512.25, 511.75, 320.5, 239.25]),
        (2, "OPENCV", 800, 600, [701.5, 702.25, 401.0, 299.5, -0.0125, 0.003, 0.0004, -0.0002]),
        (3, "SIMPLE_RADIAL", 320, 240, [300.5, 160.25, 119.75, 0.021]),
    ]
    for cid, model, w, h, params in cams:
        c = pycolmap.Camera.create_from_model_name(cid, model, params[0], w, h)
        c.params = params
        rec.add_camera_with_trivial_rig(c)
    pts = rng.normal(size=(12, 3)) * 0.5 + np.array([0.0, 0.0, 4.0])
    # Image ids deliberately not in name order (readers sort by name).
    images = [(1, "frame_c.jpg", 1), (2, "frame_a.jpg", 2), (3, "frame_b.jpg", 3), (4, "frame_d.jpg", 1)]
    poses = {}
    for iid, name, cid in images:
        q = rng.normal(size=4) * np.array([0.1, 0.1, 0.1, 1.0])
        q /= np.linalg.norm(q)
        if q[3] < 0:
            q = -q
        pose = pycolmap.Rigid3d(pycolmap.Rotation3d(q), rng.normal(size=3) * 0.3)  # xyzw
        cam = rec.cameras[cid]
        obs = []
        for j in range(len(pts)):
            pc = pose * pts[j]
            xy = cam.img_from_cam(pc)
            obs.append(pycolmap.Point2D(np.asarray(xy) + rng.normal(size=2) * 0.4))
        obs.append(pycolmap.Point2D(np.array([5.5, 7.25])))  # not triangulated
        im = pycolmap.Image(name=name, points2D=pycolmap.Point2DList(obs), camera_id=cid, image_id=iid)
        rec.add_image_with_trivial_frame(im, pose)
        poses[iid] = pose
    for j in range(len(pts)):
        track = pycolmap.Track()
        for iid, _, _ in images:
            if (j + iid) % 4 != 0:
                track.add_element(iid, j)
        rgb = rng.integers(0, 256, 3).astype(np.uint8)
        rec.add_point3D(pts[j], track, rgb)
    rec.update_point_3d_errors()
    folder = os.path.join(out, "colmap")
    os.makedirs(folder, exist_ok=True)
    rec.write_text(folder)
    back = pycolmap.Reconstruction(folder)
    assert back.num_images() == len(images) and back.num_points3D() == len(pts)

    e_cams = []
    for cid in sorted(rec.cameras):
        c = rec.cameras[cid]
        e_cams.append({"id": cid, "model": c.model.name, "width": c.width, "height": c.height,
                       "params": [float(x) for x in c.params]})
    e_imgs = []
    for iid in sorted(rec.images, key=lambda i: rec.images[i].name):
        im = rec.images[iid]
        pose = im.cam_from_world()
        x, y, z, w = (float(v) for v in pose.rotation.quat)
        e_imgs.append({
            "id": iid, "name": im.name, "camera_id": im.camera_id,
            "qvec_wxyz": [w, x, y, z], "tvec": [float(v) for v in pose.translation],
            "rotation": rows(pose.rotation.matrix()),
            "points2d": [[float(p.xy[0]), float(p.xy[1]), int(p.point3D_id) if p.has_point3D() else -1]
                         for p in im.points2D],
        })
    e_pts = []
    for pid in sorted(rec.points3D):
        p = rec.points3D[pid]
        e_pts.append({"id": pid, "xyz": [float(v) for v in p.xyz], "rgb": [int(v) for v in p.color],
                      "error": float(p.error),
                      "track": [[int(t.image_id), int(t.point2D_idx)] for t in p.track.elements]})
    exp["colmap"] = {
        "kind": "colmap",
        "writer": f"pycolmap {ver}",
        "cameras": e_cams,
        "images": e_imgs,
        "points3d": e_pts,
        "tol": {"rel": 0.0, "abs": 1e-15, "note": "written with 17 significant digits: f64 exact; "
                "rotation matrices from the quaternion compared at 1e-12"},
    }
    for f in sorted(os.listdir(folder)):
        readme.append((f"colmap/{f}", f"pycolmap.Reconstruction.write_text (pycolmap {ver})",
                       "COLMAP text model: 3 cameras (PINHOLE, OPENCV, SIMPLE_RADIAL), 4 images, 12 points"
                       if f == "cameras.txt" else "part of the same model"))
    return f"pycolmap {ver}"


def gaussians_file(out, exp, readme):
    import plyfile

    from importlib.metadata import version

    ver = version("plyfile")
    rng = np.random.default_rng(15)
    n = 40
    xyz = rng.normal(size=(n, 3)).astype(np.float32)
    normals = np.zeros_like(xyz)  # 3DGS writes zeros
    f_dc = rng.normal(size=(n, 1, 3)).astype(np.float32)  # [N, 1, 3] as in GaussianModel
    f_rest = (rng.normal(size=(n, 15, 3)) * 0.1).astype(np.float32)  # [N, 15, 3]
    opacity = rng.normal(size=(n, 1)).astype(np.float32)
    scale = (rng.normal(size=(n, 3)) - 4.0).astype(np.float32)
    rotation = rng.normal(size=(n, 4)).astype(np.float32)  # w x y z, unnormalised
    # save_ply flattens features transposed (channel-major f_rest).
    dc_flat = f_dc.transpose(0, 2, 1).reshape(n, -1)
    rest_flat = f_rest.transpose(0, 2, 1).reshape(n, -1)
    names = ["x", "y", "z", "nx", "ny", "nz"]
    names += [f"f_dc_{i}" for i in range(3)] + [f"f_rest_{i}" for i in range(45)]
    names += ["opacity"] + [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)]
    table = np.concatenate([xyz, normals, dc_flat, rest_flat, opacity, scale, rotation], axis=1)
    rec = np.empty(n, dtype=[(a, "f4") for a in names])
    for j, a in enumerate(names):
        rec[a] = table[:, j]
    path = os.path.join(out, "gaussians", "point_cloud.ply")
    plyfile.PlyData([plyfile.PlyElement.describe(rec, "vertex")]).write(path)
    back = plyfile.PlyData.read(path)["vertex"].data
    assert all(np.array_equal(back[a], rec[a]) for a in names)
    exp["gaussians/point_cloud.ply"] = {
        "kind": "gaussians",
        "writer": f"plyfile {ver}",
        "n": n,
        "sh_degree": 3,
        "means": rows(xyz),
        "sh_dc": rows(f_dc.reshape(n, 3)),
        "sh_rest_coefficient_major": [float(x) for x in f_rest.flatten()],
        "opacity_logits": [float(x) for x in opacity.flatten()],
        "log_scales": rows(scale),
        "rotations_wxyz": rows(rotation),
        "property_order": names,
        "tol": EXACT,
    }
    readme.append(("gaussians/point_cloud.ply", f"plyfile.PlyData.write (plyfile {ver})",
                   "3DGS PLY as graphdeco save_ply: 40 Gaussians, SH degree 3, float32, binary little-endian"))
    return f"plyfile {ver}"


def pt_files(out, readme):
    sys.path.insert(0, HERE)
    import make_pt_fixtures
    import torch

    folder = os.path.join(out, "pt")
    rc = make_pt_fixtures.main([folder])
    assert rc == 0
    ver = torch.__version__
    for f in sorted(os.listdir(folder)):
        what = {
            "ts_f32_param.pt": "Triangle Splatting checkpoint, nn.Parameter f32, 7 triangles, SH 3",
            "ts_f16.pt": "the same cast to float16 (plain tensors)",
            "ts_views.pt": "OrderedDict, strided/offset views, SH 1, uint16 extra, pickle protocol 4",
            "ts_plus.pt": "Triangle Splatting+ indexed model (6 vertices, 5 triangles)",
            "expected.json": "values torch reports for each checkpoint (for tests/torch_pt.rs)",
        }.get(f, "")
        tool = f"torch.save (PyTorch {ver}, CPU)" if f.endswith(".pt") else f"json, values from PyTorch {ver}"
        readme.append((f"pt/{f}", tool, what, "scripts/make_pt_fixtures.py"))
    return f"PyTorch {ver}"

SPLAT_NPM = ["@playcanvas/splat-transform@3.7.0", "@adobe/spz@0.2.3"]

# Node side of splat_files: the official SPZ library (nianticlabs/spz compiled to
# WebAssembly, npm @adobe/spz) writes SPZ v4 and v3 from the same arrays and
# decodes them; splat-transform (the CLI users run) writes SOG and SPZ from the
# PLY and decodes both back to PLY.
SPLAT_NODE = r"""
import fs from 'node:fs';
import createModule from '@adobe/spz';
const dir = process.argv[2];
const inp = JSON.parse(fs.readFileSync(dir + '/cloud.json', 'utf8'));
const spz = await createModule();
const f32 = a => new Float32Array(a);
const cloud = {
  numPoints: inp.n, shDegree: inp.sh_degree, antialiased: false, extensions: [],
  positions: f32(inp.positions), scales: f32(inp.scales), rotations: f32(inp.rotations_xyzw),
  alphas: f32(inp.alphas), colors: f32(inp.colors), sh: f32(inp.sh),
};
const out = { latest: spz.LATEST_SPZ_HEADER_VERSION };
for (const version of [4, 3]) {
  const opts = { version, from: spz.CoordinateSystem.RDF, sh1Bits: 5, shRestBits: 4 };
  const bytes = spz.saveSpzToBuffer(cloud, opts);
  fs.writeFileSync(`${dir}/adobe_v${version}.spz`, bytes);
  const back = spz.loadSpzFromBuffer(bytes, { to: spz.CoordinateSystem.RDF });
  out[`v${version}`] = {
    positions: Array.from(back.positions), scales: Array.from(back.scales),
    rotations_xyzw: Array.from(back.rotations), alphas: Array.from(back.alphas),
    colors: Array.from(back.colors), sh: Array.from(back.sh),
  };
}
fs.writeFileSync(dir + '/adobe_decoded.json', JSON.stringify(out));
"""


def read_ply_f32(path):
    """A binary little-endian PLY whose vertex properties are all float, as a dict of columns."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names, n = [], 0
    for line in data[:end].decode().splitlines():
        t = line.split()
        if t[:2] == ["element", "vertex"]:
            n = int(t[2])
        elif t[:1] == ["property"]:
            assert t[1] == "float", line
            names.append(t[2])
    arr = np.frombuffer(data[end:end + 4 * n * len(names)], dtype="<f4").reshape(n, len(names))
    return {a: arr[:, j].copy() for j, a in enumerate(names)}


def write_ply_f32(path, cols):
    n = len(next(iter(cols.values())))
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {n}"]
    head += [f"property float {a}" for a in cols] + ["end_header"]
    table = np.stack([np.asarray(v, dtype=np.float32) for v in cols.values()], axis=1)
    with open(path, "wb") as f:
        f.write(("\n".join(head) + "\n").encode())
        f.write(table.astype("<f4").tobytes())


def splat_files(out, readme):
    """testdata/splats/: SPZ and SOG written by the official SPZ library and by
    splat-transform from one numpy-written PLY, plus splats/expected.json with
    the values those tools decode. Needs node and npm (packages go to a temp
    folder). Run alone with `python3 scripts/make_fixtures.py --splats`."""
    import shutil
    import subprocess
    import tempfile

    folder = os.path.join(out, "splats")
    os.makedirs(folder, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="splat-fixtures-")
    subprocess.run(["npm", "install", "--silent", "--prefix", tmp] + SPLAT_NPM, check=True)
    vers = {}
    for pkg in ["@playcanvas/splat-transform", "@adobe/spz"]:
        with open(os.path.join(tmp, "node_modules", pkg, "package.json")) as f:
            vers[pkg] = json.load(f)["version"]

    rng = np.random.default_rng(25)
    n, k = 128, 15
    xyz = rng.uniform(-3, 3, size=(n, 3)).astype(np.float32)
    f_dc = rng.uniform(-1.5, 1.5, size=(n, 3)).astype(np.float32)
    f_rest = rng.uniform(-0.6, 0.6, size=(n, k, 3)).astype(np.float32)  # [N, coeff, channel]
    opacity = rng.uniform(-4, 4, size=n).astype(np.float32)
    scale = rng.uniform(-7, -1, size=(n, 3)).astype(np.float32)
    rot = rng.normal(size=(n, 4)).astype(np.float32)  # w x y z, unnormalised
    # Gaussian 0: a known off-axis pose for the axis test: at (1.5, 2.25, -3),
    # rotated 0.6 rad about (1, 2, 3)/sqrt(14).
    xyz[0] = [1.5, 2.25, -3.0]
    s = np.sin(0.3) / np.sqrt(14.0)
    rot[0] = [np.cos(0.3), s, 2 * s, 3 * s]
    cols = {"x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2]}
    cols.update({f"f_dc_{c}": f_dc[:, c] for c in range(3)})
    rest_cm = f_rest.transpose(0, 2, 1).reshape(n, -1)  # PLY: channel-major f_rest
    cols.update({f"f_rest_{j}": rest_cm[:, j] for j in range(3 * k)})
    cols["opacity"] = opacity
    cols.update({f"scale_{j}": scale[:, j] for j in range(3)})
    cols.update({f"rot_{j}": rot[:, j] for j in range(4)})
    src = os.path.join(folder, "source.ply")
    write_ply_f32(src, cols)

    with open(os.path.join(tmp, "cloud.json"), "w") as f:
        json.dump({
            "n": n, "sh_degree": 3,
            "positions": [float(v) for v in xyz.flatten()],
            "scales": [float(v) for v in scale.flatten()],
            "rotations_xyzw": [float(v) for v in rot[:, [1, 2, 3, 0]].flatten()],
            "alphas": [float(v) for v in opacity],
            "colors": [float(v) for v in f_dc.flatten()],
            "sh": [float(v) for v in f_rest.flatten()],
        }, f)
    with open(os.path.join(tmp, "run.mjs"), "w") as f:
        f.write(SPLAT_NODE)
    subprocess.run(["node", os.path.join(tmp, "run.mjs"), tmp], check=True, cwd=tmp)
    with open(os.path.join(tmp, "adobe_decoded.json")) as f:
        adobe = json.load(f)

    cli = os.path.join(tmp, "node_modules", "@playcanvas", "splat-transform", "bin", "cli.mjs")
    def st(*args):
        subprocess.run(["node", cli, "-q", "-w", "-g", "cpu", *args], check=True, cwd=tmp)
    st(src, os.path.join(tmp, "st.sog"))
    st(src, os.path.join(tmp, "st.spz"))
    st(os.path.join(tmp, "st.sog"), os.path.join(tmp, "st_sog_decoded.ply"))
    st(os.path.join(tmp, "st.spz"), os.path.join(tmp, "st_spz_decoded.ply"))
    for name in ["adobe_v4.spz", "adobe_v3.spz", "st.sog", "st.spz"]:
        shutil.copy(os.path.join(tmp, name), os.path.join(folder, name.replace("st.", "splat_transform.")))

    pick = list(range(0, n, 8))  # 16 Gaussians stored in full

    def from_cloud(d):
        p = np.array(d["positions"]).reshape(n, 3)
        q = np.array(d["rotations_xyzw"]).reshape(n, 4)[:, [3, 0, 1, 2]]
        sh = np.array(d["sh"]).reshape(n, k * 3)  # coefficient-major, channel innermost
        return {
            "means": p, "log_scales": np.array(d["scales"]).reshape(n, 3),
            "rotations_wxyz": q, "opacity_logits": np.array(d["alphas"]),
            "sh_dc": np.array(d["colors"]).reshape(n, 3), "sh_rest_coefficient_major": sh,
        }

    def from_ply(c):
        m = len(c["x"])
        rest = np.stack([c[f"f_rest_{j}"] for j in range(3 * k)], axis=1)
        rest = rest.reshape(m, 3, k).transpose(0, 2, 1).reshape(m, 3 * k)
        return {
            "means": np.stack([c["x"], c["y"], c["z"]], axis=1),
            "log_scales": np.stack([c[f"scale_{j}"] for j in range(3)], axis=1),
            "rotations_wxyz": np.stack([c[f"rot_{j}"] for j in range(4)], axis=1),
            "opacity_logits": c["opacity"],
            "sh_dc": np.stack([c[f"f_dc_{j}"] for j in range(3)], axis=1),
            "sh_rest_coefficient_major": rest,
        }

    def entry(d, writer, what, axes):
        e = {"writer": writer, "what": what, "n": n, "sh_degree": 3, "axes": axes,
             "rows": pick, "decoded_by": writer}
        for key, v in d.items():
            v = np.asarray(v, dtype=np.float64)
            e[key] = [([float(x) for x in v[i]] if v.ndim > 1 else float(v[i])) for i in pick]
        return e

    adobe_ver = f"@adobe/spz {vers['@adobe/spz']} (nianticlabs/spz compiled to WebAssembly)"
    st_ver = f"@playcanvas/splat-transform {vers['@playcanvas/splat-transform']}"
    exp = {"source.ply": {"writer": f"numpy {np.__version__}", "n": n, "sh_degree": 3}}
    exp["adobe_v4.spz"] = entry(from_cloud(adobe["v4"]), adobe_ver,
                                "saveSpzToBuffer version 4 from RDF; decoded with loadSpzFromBuffer to RDF", "RDF")
    exp["adobe_v3.spz"] = entry(from_cloud(adobe["v3"]), adobe_ver,
                                "saveSpzToBuffer version 3 (gzip) from RDF; decoded to RDF", "RDF")
    exp["splat_transform.spz"] = entry(from_ply(read_ply_f32(os.path.join(tmp, "st_spz_decoded.ply"))), st_ver,
                                       "splat-transform source.ply x.spz; decoded by splat-transform x.spz y.ply "
                                       "(no axis conversion either way: stored axes are the PLY's)", "stored as RDF")
    exp["splat_transform.sog"] = entry(from_ply(read_ply_f32(os.path.join(tmp, "st_sog_decoded.ply"))), st_ver,
                                       "splat-transform source.ply x.sog (bundled, version 2, Morton order); "
                                       "decoded by splat-transform x.sog y.ply (texel order)", "RDF")
    exp["latest_spz_version_of_official_library"] = adobe["latest"]
    with open(os.path.join(folder, "expected.json"), "w") as f:
        json.dump(exp, f, separators=(",", ":"))
        f.write("\n")
    shutil.rmtree(tmp)
    readme += [
        ("splats/source.ply", f"numpy {np.__version__} (hand-written PLY header)",
         "3DGS PLY, 128 Gaussians, SH degree 3, float32; Gaussian 0 at (1.5, 2.25, -3) rotated 0.6 rad about (1,2,3)"),
        ("splats/adobe_v4.spz", adobe_ver, "SPZ version 4 (zstd streams) of source.ply, packed from RDF (stored RUB)"),
        ("splats/adobe_v3.spz", adobe_ver, "SPZ version 3 (gzip) of source.ply, packed from RDF (stored RUB)"),
        ("splats/splat_transform.spz", st_ver, "SPZ of source.ply as splat-transform writes it (PLY axes, no conversion)"),
        ("splats/splat_transform.sog", st_ver, "bundled SOG version 2 of source.ply"),
        ("splats/expected.json", f"json, values decoded by {adobe_ver} and {st_ver}",
         "for every 8th Gaussian of each file, the values its writing tool decodes"),
    ]
    return f"{st_ver}, {adobe_ver}"


# --- Gaussian-splat formats (splats/scene300/): run alone with `--only splats` ----------
#
# Needs node/npm (installs @playcanvas/splat-transform and
# @mkkellogg/gaussian-splats-3d + three into a temp folder), numpy and plyfile,
# and antimatter15's convert.py (the .splat exporter; there is no package):
# pass its path in ANTIMATTER15_CONVERT, or the script clones
# https://github.com/antimatter15/splat at the commit below.

SPLAT_TRANSFORM = "@playcanvas/splat-transform@2.7.1"
GS3D = "@mkkellogg/gaussian-splats-3d@0.4.7"
THREE = "three@0.180.0"
ANTIMATTER15_COMMIT = "ba182b51b7c2ad5738cdd6741cd63336d27470fb"

KSPLAT_JS = r"""
import * as GS from '@mkkellogg/gaussian-splats-3d';
import * as THREE from 'three';
import * as fs from 'fs';
const [inp, out, level, degree] = process.argv.slice(2);
const data = fs.readFileSync(inp);
const buf = data.buffer.slice(data.byteOffset, data.byteOffset + data.byteLength);
const arr = GS.PlyParser.parseToUncompressedSplatArray(buf, parseInt(degree));
// alpha threshold 1, level, one section, scene centre 0, block 5, bucket 256
const gen = GS.SplatBufferGenerator.getStandardGenerator(1, parseInt(level), 0,
    new THREE.Vector3(0, 0, 0), 5.0, 256);
const sb = gen.generateFromUncompressedSplatArray(arr);
fs.writeFileSync(out, Buffer.from(sb.bufferData));
"""


def read_ply_vertex(path):
    """A binary little-endian PLY's vertex element as {name: float64 array},
    plus the element names and counts (a tiny reader: splat-transform writes
    plain float/uint/uchar scalar properties)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    types = {"float": "<f4", "uint": "<u4", "uchar": "u1", "double": "<f8", "int": "<i4"}
    elements = []
    for line in data[:end].decode().splitlines():
        w = line.split()
        if w[:1] == ["element"]:
            elements.append((w[1], int(w[2]), []))
        elif w[:1] == ["property"]:
            elements[-1][2].append((w[2], types[w[1]]))
    off, out = end, {}
    for name, count, props in elements:
        dt = np.dtype(props)
        arr = np.frombuffer(data, dtype=dt, count=count, offset=off)
        off += dt.itemsize * count
        if name == "vertex":
            out = {p: arr[p].astype(np.float64) for p, _ in props}
    return out, [(n, c) for n, c, _ in elements]


def scene300_files(out, readme):
    """testdata/splats/scene300/: a small 3DGS PLY (numpy + plyfile) and what the
    splat tools make of it: compressed PLY (splat-transform), .splat
    (antimatter15 convert.py), KSPLAT levels 1 and 2 (GaussianSplats3D);
    splats/scene300/expected.json holds splat-transform's decoding of each (every
    5th Gaussian, all attributes) for tests/splat_fixtures.rs."""
    import subprocess
    import tempfile

    import plyfile
    from importlib.metadata import version

    folder = os.path.join(out, "splats", "scene300")
    os.makedirs(folder, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="splatfx-")
    subprocess.run(["npm", "install", "--silent", "--prefix", tmp, SPLAT_TRANSFORM, GS3D, THREE],
                   check=True)
    st = os.path.join(tmp, "node_modules", ".bin", "splat-transform")

    # 300 Gaussians (one full chunk of 256 and a partial one), SH degree 3,
    # in four clusters; colours, SH and scales inside every format's range.
    rng = np.random.default_rng(25)
    n = 300
    centres = np.array([[0, 0, 0], [2, 0, 0], [0, 1.5, -1], [-1, -1, 2]], np.float32)
    xyz = (centres[rng.integers(0, 4, n)] + rng.normal(scale=0.3, size=(n, 3))).astype(np.float32)
    f_dc = rng.uniform(-1.5, 1.5, size=(n, 3)).astype(np.float32)
    f_rest = rng.uniform(-0.4, 0.4, size=(n, 15, 3)).astype(np.float32)  # [N, 15, 3]
    opacity = rng.uniform(-2.5, 4.0, size=(n, 1)).astype(np.float32)
    scale = rng.uniform(-5.0, -1.5, size=(n, 3)).astype(np.float32)
    rotation = rng.normal(size=(n, 4)).astype(np.float32)
    names = ["x", "y", "z", "nx", "ny", "nz"] + [f"f_dc_{i}" for i in range(3)]
    names += [f"f_rest_{i}" for i in range(45)] + ["opacity"]
    names += [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)]
    table = np.concatenate([xyz, np.zeros_like(xyz), f_dc, f_rest.transpose(0, 2, 1).reshape(n, -1),
                            opacity, scale, rotation], axis=1)
    rec = np.empty(n, dtype=[(a, "f4") for a in names])
    for j, a in enumerate(names):
        rec[a] = table[:, j]
    src = os.path.join(folder, "source.ply")
    plyfile.PlyData([plyfile.PlyElement.describe(rec, "vertex")]).write(src)
    r = subprocess.run([st, "--version"], capture_output=True, text=True)
    st_ver = (r.stdout + r.stderr).split()[1].lstrip("v")
    gs_ver = json.load(open(os.path.join(tmp, "node_modules", "@mkkellogg", "gaussian-splats-3d",
                                         "package.json")))["version"]

    files = {}
    cp = os.path.join(folder, "source.compressed.ply")
    subprocess.run([st, "-q", "-w", src, cp], check=True)
    files["source.compressed.ply"] = f"splat-transform {st_ver}"

    conv = os.environ.get("ANTIMATTER15_CONVERT")
    if not conv:
        repo = os.path.join(tmp, "antimatter15-splat")
        subprocess.run(["git", "clone", "-q", "https://github.com/antimatter15/splat", repo], check=True)
        subprocess.run(["git", "-C", repo, "checkout", "-q", ANTIMATTER15_COMMIT], check=True)
        conv = os.path.join(repo, "convert.py")
    sp = os.path.join(folder, "source.splat")
    subprocess.run([sys.executable, conv, src, "--output", sp], check=True, capture_output=True)
    files["source.splat"] = f"antimatter15/splat convert.py ({ANTIMATTER15_COMMIT[:7]}, plyfile {version('plyfile')})"

    js = os.path.join(tmp, "ksplat.mjs")
    open(js, "w").write(KSPLAT_JS)
    for level in (1, 2):
        kp = os.path.join(folder, f"source.level{level}.ksplat")
        subprocess.run(["node", js, src, kp, str(level), "2"], check=True, cwd=tmp,
                       capture_output=True)
        files[f"source.level{level}.ksplat"] = f"GaussianSplats3D {gs_ver} SplatBufferGenerator"

    # splat-transform's decoding of each file (and of the source, for the
    # .splat, which splat-transform reads too)
    exp = {"source": "source.ply", "every": 5, "files": {}}
    for f, tool in files.items():
        dec = os.path.join(tmp, f + ".decoded.ply")
        subprocess.run([st, "-q", "-w", os.path.join(folder, f), dec], check=True)
        v, elements = read_ply_vertex(dec)
        count = len(v["x"])
        rest = sorted((k for k in v if k.startswith("f_rest_")), key=lambda k: int(k[7:]))
        keep = list(range(0, count, 5))
        cols = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1",
                "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"] + rest
        exp["files"][f] = {
            "writer": tool,
            "decoder": f"splat-transform {st_ver} (to .ply)",
            "count": count,
            "f_rest": len(rest),
            "columns": cols,
            "rows": {str(i): [float(np.float32(v[c][i])) for c in cols] for i in keep},
        }
        readme.append((f"splats/scene300/{f}", tool, {
            "source.compressed.ply": "SuperSplat compressed PLY of source.ply (Morton order, SH 3 as bytes)",
            "source.splat": "antimatter15 .splat of source.ply (sorted by size x opacity, SH dropped)",
            "source.level1.ksplat": "KSPLAT level 1 (half floats, bucketed positions), SH degree 2",
            "source.level2.ksplat": "KSPLAT level 2 (8-bit SH), SH degree 2",
        }[f]))
    readme.insert(len(readme) - len(files), ("splats/scene300/source.ply", f"plyfile.PlyData.write (plyfile {version('plyfile')})",
                                             "3DGS PLY, 300 Gaussians in 4 clusters, SH degree 3 (the input of the files below)"))
    with open(os.path.join(folder, "expected.json"), "w") as fh:
        json.dump(exp, fh, separators=(",", ":"))
        fh.write("\n")
    readme.append(("splats/scene300/expected.json", f"json, values decoded by splat-transform {st_ver}",
                   "every 5th Gaussian of each file above as splat-transform decodes it (for tests/splat_fixtures.rs)"))
    return f"splat-transform {st_ver}, GaussianSplats3D {gs_ver}"


def splat_readme_lines(out, readme):
    """Replaces the splats/ lines of an existing README.md (for `--only splats`)."""
    path = os.path.join(out, "README.md")
    lines = [l for l in open(path).read().splitlines() if not l.startswith("- `splats/scene300/")]
    for path_, tool, what in readme:
        lines.append(f"- `{path_}` — `scripts/make_fixtures.py` — {tool} — {what}")
    with open(os.path.join(out, "README.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def mip_gaussians_file(out, exp, readme):
    """A PLY as Mip-Splatting's / GOF's GaussianModel.save_ply writes it: the
    3DGS attribute list (x y z nx ny nz f_dc_0..2 f_rest_0..44 opacity
    scale_0..2 rot_0..3) then `filter_3D`, all float32, SH degree 3. The
    expected values (in gaussians/mip_splatting.json, so that this function
    can run alone) include the scales and opacities their renderer draws,
    computed here with NumPy float64 by get_scaling_with_3D_filter and
    get_opacity_with_3D_filter's formulas."""
    import plyfile

    from importlib.metadata import version

    ver = version("plyfile")
    rng = np.random.default_rng(25)
    n = 60
    xyz = rng.normal(size=(n, 3)).astype(np.float32)
    normals = np.zeros_like(xyz)
    f_dc = rng.normal(size=(n, 1, 3)).astype(np.float32)
    f_rest = (rng.normal(size=(n, 15, 3)) * 0.1).astype(np.float32)
    opacity = rng.normal(size=(n, 1)).astype(np.float32)
    scale = (rng.normal(size=(n, 3)) - 4.5).astype(np.float32)
    rotation = rng.normal(size=(n, 4)).astype(np.float32)
    # compute_3D_filter: distance / focal * sqrt(0.2), a few 1e-3 here
    filter_3d = (rng.uniform(2.0, 6.0, size=(n, 1)) / 1000.0 * 0.2 ** 0.5).astype(np.float32)
    dc_flat = f_dc.transpose(0, 2, 1).reshape(n, -1)
    rest_flat = f_rest.transpose(0, 2, 1).reshape(n, -1)
    names = ["x", "y", "z", "nx", "ny", "nz"]
    names += [f"f_dc_{i}" for i in range(3)] + [f"f_rest_{i}" for i in range(45)]
    names += ["opacity"] + [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)]
    names += ["filter_3D"]
    table = np.concatenate([xyz, normals, dc_flat, rest_flat, opacity, scale, rotation, filter_3d], axis=1)
    rec = np.empty(n, dtype=[(a, "f4") for a in names])
    rec[:] = list(map(tuple, table))  # as save_ply fills its structured array
    path = os.path.join(out, "gaussians", "mip_splatting.ply")
    plyfile.PlyData([plyfile.PlyElement.describe(rec, "vertex")]).write(path)
    back = plyfile.PlyData.read(path)["vertex"].data
    assert all(np.array_equal(back[a], rec[a]) for a in names)
    # the renderer's values (float64 here)
    s = np.exp(scale.astype(np.float64))
    f = filter_3d.astype(np.float64)
    s2 = s * s + f * f
    eff_scales = np.sqrt(s2)
    coef = np.sqrt(np.prod(s * s, axis=1) / np.prod(s2, axis=1))
    eff_opacity = 1.0 / (1.0 + np.exp(-opacity[:, 0].astype(np.float64))) * coef
    doc = {
        "writer": f"plyfile {ver}",
        "n": n,
        "sh_degree": 3,
        "property_order": names,
        "means": rows(xyz),
        "opacity_logits": [float(x) for x in opacity.flatten()],
        "log_scales": rows(scale),
        "filter_3D": [float(x) for x in filter_3d.flatten()],
        "effective_scales": rows(eff_scales),
        "effective_opacities": [float(x) for x in eff_opacity],
        "note": "effective_* are get_scaling_with_3D_filter / get_opacity_with_3D_filter in float64",
    }
    with open(os.path.join(out, "gaussians", "mip_splatting.json"), "w") as fh:
        json.dump(doc, fh, separators=(",", ":"))
        fh.write("\n")
    for f_name, what in [
        ("gaussians/mip_splatting.ply", "Mip-Splatting / GOF PLY as their save_ply: 60 Gaussians, SH degree 3, "
                                        "3DGS properties + filter_3D, float32, binary little-endian"),
        ("gaussians/mip_splatting.json", "its values and the scales/opacities the Mip-Splatting renderer draws "
                                         "(NumPy float64), for tests/filter3d.rs"),
    ]:
        readme.append((f_name, f"plyfile.PlyData.write (plyfile {ver})" if f_name.endswith(".ply")
                       else f"json, values from NumPy {np.__version__}", what))
    return f"plyfile {ver}"


def mip_filter_reference_file(out, readme):
    """render/mip_filter_reference.json by scripts/compare/mip_filter_reference.py."""
    sys.path.insert(0, os.path.join(HERE, "compare"))
    import mip_filter_reference

    os.makedirs(os.path.join(out, "render"), exist_ok=True)
    assert mip_filter_reference.main([os.path.join(out, "render", "mip_filter_reference.json")]) == 0
    readme.append(("render/mip_filter_reference.json",
                   f"json, values from NumPy {np.__version__} (float32)",
                   "32×24 RGB and alpha of 14 Gaussians under the 2-D Mip filter (kernel 0.1 and 0.0), "
                   "from the Mip-Splatting / GOF CUDA rules, for tests/mip_filter.rs",
                   "scripts/compare/mip_filter_reference.py"))


def quat_wxyz_from_z_to(n):
    """Unit quaternion (w, x, y, z) of the shortest rotation taking +z to the
    unit vector n."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(np.dot(z, n))
    if c < -1.0 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    axis = np.cross(z, n)
    q = np.array([1.0 + c, axis[0], axis[1], axis[2]])
    return q / np.linalg.norm(q)


def quat_mul(a, b):
    """Hamilton product of two (w, x, y, z) quaternions."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def build_rotation_np(q):
    """2DGS utils/general_utils.build_rotation for one (w, x, y, z) quaternion
    (normalised first), in numpy float64."""
    r, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - r * z), 2 * (x * z + r * y)],
        [2 * (x * y + r * z), 1 - 2 * (x * x + z * z), 2 * (y * z - r * x)],
        [2 * (x * z - r * y), 2 * (y * z + r * x), 1 - 2 * (x * x + y * y)],
    ])


class _SurfelModel:
    """The attributes 2DGS's GaussianModel.save_ply reads, as numpy arrays of
    the tensors' shapes: _xyz [N,3], _features_dc [N,1,3], _features_rest
    [N,15,3], _opacity [N,1], _scaling [N,2] (two scales), _rotation [N,4]."""

    def construct_list_of_attributes(self):
        # hbb1/2d-gaussian-splatting scene/gaussian_model.py, same order
        l = ["x", "y", "z", "nx", "ny", "nz"]
        for i in range(self._features_dc.shape[1] * self._features_dc.shape[2]):
            l.append("f_dc_{}".format(i))
        for i in range(self._features_rest.shape[1] * self._features_rest.shape[2]):
            l.append("f_rest_{}".format(i))
        l.append("opacity")
        for i in range(self._scaling.shape[1]):
            l.append("scale_{}".format(i))
        for i in range(self._rotation.shape[1]):
            l.append("rot_{}".format(i))
        return l

    def save_ply(self, path):
        # GaussianModel.save_ply with .detach().cpu().numpy() dropped
        from plyfile import PlyData, PlyElement

        xyz = self._xyz
        normals = np.zeros_like(xyz)
        f_dc = self._features_dc.transpose(0, 2, 1).reshape(xyz.shape[0], -1)
        f_rest = self._features_rest.transpose(0, 2, 1).reshape(xyz.shape[0], -1)
        opacities = self._opacity
        scale = self._scaling
        rotation = self._rotation
        dtype_full = [(attribute, "f4") for attribute in self.construct_list_of_attributes()]
        elements = np.empty(xyz.shape[0], dtype=dtype_full)
        attributes = np.concatenate((xyz, normals, f_dc, f_rest, opacities, scale, rotation), axis=1)
        elements[:] = list(map(tuple, attributes))
        el = PlyElement.describe(elements, "vertex")
        PlyData([el]).write(path)


def surfels_file(out, readme):
    """testdata/surfels/point_cloud.ply, written as 2DGS's save_ply writes it:
    128 surfels tangent to the unit sphere (Fibonacci centres, disc normal =
    the radial direction, a random twist about it, quaternions scaled by a
    random factor as training leaves them unnormalised), SH degree 3, and
    surfels/expected.json with the values and each disc normal (R[:, 2] of
    2DGS's build_rotation)."""
    import plyfile

    from importlib.metadata import version

    ver = version("plyfile")
    rng = np.random.default_rng(25)
    n = 128
    k = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * k / n)
    theta = np.pi * (1.0 + 5.0 ** 0.5) * k
    radial = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], axis=1)
    rot = []
    for i in range(n):
        t = rng.uniform(0.0, 2.0 * np.pi)
        twist = np.array([np.cos(t / 2), 0.0, 0.0, np.sin(t / 2)])
        q = quat_mul(quat_wxyz_from_z_to(radial[i]), twist)
        rot.append(q * rng.uniform(0.5, 2.0))
    m = _SurfelModel()
    m._xyz = radial.astype(np.float32)
    m._features_dc = (rng.normal(size=(n, 1, 3)) * 0.5).astype(np.float32)
    m._features_rest = (rng.normal(size=(n, 15, 3)) * 0.05).astype(np.float32)
    m._opacity = rng.uniform(2.0, 4.0, size=(n, 1)).astype(np.float32)
    m._scaling = np.log(np.stack([rng.uniform(0.2, 0.26, n), rng.uniform(0.16, 0.2, n)], axis=1)).astype(np.float32)
    m._rotation = np.array(rot).astype(np.float32)
    folder = os.path.join(out, "surfels")
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "point_cloud.ply")
    m.save_ply(path)
    names = m.construct_list_of_attributes()
    back = plyfile.PlyData.read(path)["vertex"]
    assert [p.name for p in back.properties] == names
    assert np.array_equal(back.data["scale_1"], m._scaling[:, 1])
    disc_normals = [build_rotation_np(q.astype(np.float64))[:, 2] for q in m._rotation]

    def f32rows(a):
        # the shortest decimal that reads back as the same f32 (exact, smaller file)
        return [[float(str(np.float32(x))) for x in np.atleast_1d(r)] for r in np.asarray(a, dtype=np.float32)]

    exp = {
        "writer": f"plyfile {ver}",
        "file": "point_cloud.ply",
        "n": n,
        "sh_degree": 3,
        "means": f32rows(m._xyz),
        "sh_dc": f32rows(m._features_dc.reshape(n, 3)),
        "sh_rest_coefficient_major": f32rows(m._features_rest.reshape(n, 45)),
        "opacity_logits": [r[0] for r in f32rows(m._opacity)],
        "log_scales": f32rows(m._scaling),
        "rotations_wxyz": f32rows(m._rotation),
        "disc_normals": [[round(float(x), 9) for x in r] for r in disc_normals],
        "sphere": {"center": [0.0, 0.0, 0.0], "radius": 1.0},
        "property_order": names,
        "tol": EXACT,
        "normal_tol": {"abs": 1e-6, "note": "R[:, 2] from the f32 quaternion in float64, 9 decimals; splatkit normalises in f32"},
    }
    with open(os.path.join(folder, "expected.json"), "w") as f:
        json.dump(exp, f, separators=(",", ":"))
        f.write("\n")
    readme.append(("surfels/point_cloud.ply", f"plyfile.PlyData.write (plyfile {ver})",
                   "2DGS PLY as hbb1/2d-gaussian-splatting save_ply: 128 surfels tangent to the unit sphere, "
                   "two scales, SH degree 3, float32, binary little-endian"))
    readme.append(("surfels/expected.json", "json, values from NumPy " + np.__version__,
                   "the values tests/fixtures.rs must find in surfels/point_cloud.ply, and each disc normal"))
    return f"plyfile {ver}"


def main(argv):
    if argv[:2] == ["--only", "splats"]:
        out = argv[2] if len(argv) > 2 else os.path.join(ROOT, "testdata")
        readme = []
        tool = scene300_files(out, readme)
        splat_readme_lines(out, readme)
        print(f"wrote {len(readme)} files to {out}/splats/scene300 with: {tool}")
        return 0
    if argv[:1] == ["--splats"]:
        return splats_only(argv[1:])
    if argv and argv[0] == "--only-mip":
        # only the Mip-Splatting / GOF PLY and its JSON (needs numpy, plyfile)
        out = argv[1] if len(argv) > 1 else os.path.join(ROOT, "testdata")
        os.makedirs(os.path.join(out, "gaussians"), exist_ok=True)
        readme = []
        mip_gaussians_file(out, {}, readme)
        for entry in readme:
            print(f"- `{entry[0]}` — `scripts/make_fixtures.py` — {entry[1]} — {entry[2]}")
        return 0
    if argv[:1] == ["--only-surfels"]:
        # just testdata/surfels/ (its README lines are printed to paste)
        out = argv[1] if len(argv) > 1 else os.path.join(ROOT, "testdata")
        readme = []
        surfels_file(out, readme)
        for path, tool, what in readme:
            print(f"- `{path}` — `scripts/make_fixtures.py` — {tool} — {what}")
        return 0
    out = argv[0] if argv else os.path.join(ROOT, "testdata")
    for d in ["mat", "npz", "mesh", "colmap", "gaussians", "pt"]:
        os.makedirs(os.path.join(out, d), exist_ok=True)
    exp, readme, tools = {}, [], []
    tools.append(mat_files(out, exp, readme))
    tools.append(npz_files(out, exp, readme))
    tools.append(open3d_files(out, exp, readme))
    tools.append(trimesh_files(out, exp, readme))
    tools.append(pymeshlab_files(out, exp, readme))
    tools.append(colmap_files(out, exp, readme))
    tools.append(gaussians_file(out, exp, readme))
    mip_gaussians_file(out, exp, readme)
    surfels_file(out, readme)
    tools.append(pt_files(out, readme))
    mip_filter_reference_file(out, readme)
    tools.append(splat_files(out, readme))
    tools.append(scene300_files(out, readme))
    with open(os.path.join(out, "expected.json"), "w") as f:
        json.dump({"tools": tools, "files": exp, "arrays": ARRAYS}, f, separators=(",", ":"))
        f.write("\n")
    readme.append(("expected.json", "json (Python " + sys.version.split()[0] + ")",
                   "the values tests/fixtures.rs must find in every file above, computed by the writing tools"))
    write_readme(out, readme, tools)
    print(f"wrote {len(readme)} files to {out} with: {', '.join(tools)}")
    return 0


def splats_only(argv):
    """Regenerates testdata/splats/ alone and replaces its lines in testdata/README.md."""
    out = argv[0] if argv else os.path.join(ROOT, "testdata")
    rows_ = []
    tool = splat_files(out, rows_)
    path = os.path.join(out, "README.md")
    with open(path) as f:
        lines = [ln for ln in f.read().splitlines()
                 if not ln.startswith("- `splats/") or ln.startswith("- `splats/scene300/")]
    while lines and not lines[-1]:
        lines.pop()
    lines += [f"- `{p}` — `scripts/make_fixtures.py --splats` — {t} — {w}" for p, t, w in rows_]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {len(rows_)} files to {out}/splats with {tool}")
    return 0


def write_readme(out, readme, tools):
    lines = [
        "# testdata",
        "",
        "Small files written by the tools splatkit's users already run, read by `tests/fixtures.rs`",
        "and `tests/torch_pt.rs` (never skipped: they are committed). Regenerate everything with",
        "`python scripts/make_fixtures.py` (see its docstring for the pip packages); the values the",
        "tests compare with are in `expected.json` and `pt/expected.json`, computed by the tools.",
        "",
        "Tools: " + ", ".join(tools) + f", Python {sys.version.split()[0]}.",
        "PyTorch is the PyPI wheel (the CPU-only index was not reachable where these were made),",
        "run on the CPU; the checkpoints do not depend on the build.",
        "",
        "One line per file: path — script — tool (version) — what it holds.",
        "",
    ]
    for entry in readme:
        path, tool, what = entry[:3]
        script = entry[3] if len(entry) > 3 else "scripts/make_fixtures.py"
        lines.append(f"- `{path}` — `{script}` — {tool} — {what}")
    with open(os.path.join(out, "README.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
