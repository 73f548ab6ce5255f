#!/usr/bin/env python3
"""Write small Triangle Splatting checkpoints with real PyTorch, for checking
splatkit's Python-free reader (src/io/torch_pt).

Usage: make_pt_fixtures.py OUTDIR
       make_pt_fixtures.py --check OUTDIR

Writes into OUTDIR (created if needed), with a fixed seed:
  ts_f32_param.pt  dict of nn.Parameter f32 tensors, as Triangle Splatting's
                   training saves them (on CUDA when available, else CPU)
  ts_f16.pt        the same values cast to float16 (plain tensors)
  ts_views.pt      re-saved plain tensors (requires_grad=True) in an
                   OrderedDict, with a non-contiguous features_rest, a sigma
                   that is a column slice (storage offset + stride) of a
                   wider tensor, degree-1 SH, pickle protocol 4
  ts_plus.pt       a Triangle Splatting+ indexed model (vertices + indices,
                   per-vertex SH and vertex_weight, scalar sigma)
  expected.json    for each file, the TriangleSoup the reader must produce:
                   flat lists of triangles (N*9), opacity_raw, sigma_raw,
                   sh_dc (N*3), sh_rest (N*K*3), sh_degree, active_sh_degree,
                   "extras" (per-triangle columns by name), and "exact"
                   (bit-exact comparison) or a tolerance.

The committed copies live in testdata/pt/ (written by
scripts/make_fixtures.py, which runs this with OUTDIR = testdata/pt; see
testdata/README.md for the torch version) and are read on every
`cargo test --test torch_pt`.

The other direction: SPLATKIT_PT_FIXTURES=DIR cargo test --test torch_pt
writes DIR/from_splatkit.pt (splatkit's writer) and from_splatkit.json;
`--check DIR` loads the .pt with torch.load (weights_only=True, so only
allow-listed globals are accepted) and compares every value bit for bit,
exiting 1 on a mismatch.

pip install torch (the CPU wheel is enough). When torch is not installed
this prints so and exits 0 (nothing written or checked).
"""

import collections
import json
import math
import os
import sys


def check(torch, folder):
    """torch.load splatkit's output and compare it with the values it wrote."""
    with open(os.path.join(folder, "from_splatkit.json")) as f:
        want = json.load(f)
    sd = torch.load(os.path.join(folder, "from_splatkit.pt"), weights_only=True)
    n = want["n"]
    shapes = {
        "triangles_points": (n, 3, 3),
        "sigma": (n, 1),
        "opacity": (n, 1),
        "features_dc": (n, 1, 3),
        "features_rest": (n, 15, 3),
        "importance": (n,),
    }
    bad = 0
    for key, shape in shapes.items():
        t = sd[key]
        ok = tuple(t.shape) == shape
        ref = torch.tensor(want[key], dtype=t.dtype).reshape(shape)
        ok = ok and torch.equal(t, ref)
        print(f"{key}: {tuple(t.shape)} {t.dtype} {'ok' if ok else 'MISMATCH'}")
        bad += not ok
    if sd["active_sh_degree"] != want["active_sh_degree"]:
        print("active_sh_degree MISMATCH")
        bad += 1
    print("torch.load of splatkit's checkpoint:", "ok" if bad == 0 else f"{bad} mismatches")
    return 1 if bad else 0


def main(argv=None):
    args = list(sys.argv[1:] if argv is None else argv)
    check_mode = bool(args) and args[0] == "--check"
    if check_mode:
        args = args[1:]
    if len(args) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        import torch
    except ImportError:
        print("torch is not installed: no checkpoint fixtures written or checked")
        return 0
    if check_mode:
        return check(torch, args[0])
    out = args[0]
    os.makedirs(out, exist_ok=True)
    torch.manual_seed(20250603)
    expected = {}

    def flat(t):
        return [float(x) for x in t.detach().cpu().double().flatten().tolist()]

    def soup_expect(pts, opacity, sigma, dc, rest, active, exact=True, tol=0.0):
        k = rest.shape[1]
        degree = {0: 0, 3: 1, 8: 2, 15: 3}[k]
        return {
            "n": pts.shape[0],
            "triangles": flat(pts),
            "opacity_raw": flat(opacity),
            "sigma_raw": flat(sigma),
            "sh_dc": flat(dc),
            "sh_rest": flat(rest),
            "sh_degree": degree,
            "active_sh_degree": active,
            "exact": exact,
            "tol": tol,
        }

    n = 7
    device = "cuda" if torch.cuda.is_available() else "cpu"
    pts = torch.randn(n, 3, 3)
    opacity = torch.randn(n, 1)
    sigma = torch.randn(n, 1) - 1.0
    dc = torch.randn(n, 1, 3)
    rest = torch.randn(n, 15, 3) * 0.1

    # 1. As train.py saves: nn.Parameters (on the training device).
    params = {
        "triangles_points": torch.nn.Parameter(pts.clone().to(device)),
        "sigma": torch.nn.Parameter(sigma.clone().to(device)),
        "active_sh_degree": 3,
        "features_dc": torch.nn.Parameter(dc.clone().to(device)),
        "features_rest": torch.nn.Parameter(rest.clone().to(device)),
        "opacity": torch.nn.Parameter(opacity.clone().to(device)),
    }
    torch.save(params, os.path.join(out, "ts_f32_param.pt"))
    expected["ts_f32_param.pt"] = soup_expect(pts, opacity, sigma, dc, rest, 3)

    # 2. float16 storages (values as rounded to f16, widened exactly).
    half = {k: (v.detach().cpu().half() if torch.is_tensor(v) else v) for k, v in params.items()}
    torch.save(half, os.path.join(out, "ts_f16.pt"))
    expected["ts_f16.pt"] = soup_expect(
        pts.half(), opacity.half(), sigma.half(), dc.half(), rest.half(), 3
    )

    # 3. Views: plain tensors with requires_grad, OrderedDict, degree 1.
    rest1 = torch.randn(n, 3, 3) * 0.1
    rest_nc = rest1.transpose(1, 2).contiguous().transpose(1, 2)  # strides (9,1,3)
    assert not rest_nc.is_contiguous()
    wide = torch.randn(n, 2)
    sigma_view = wide[:, 1:2]  # storage offset 1, stride (2,1)
    views = collections.OrderedDict(
        [
            ("triangles_points", pts.clone().requires_grad_(True)),
            ("sigma", sigma_view),
            ("active_sh_degree", 0),
            ("features_dc", dc.clone().requires_grad_(True)),
            ("features_rest", rest_nc),
            ("opacity", opacity.clone()),
            ("note", "plain tensors re-saved"),
            # uint16 is pickled with _rebuild_tensor_v3 over an untyped storage.
            ("visible", torch.arange(n, dtype=torch.int32).to(torch.uint16) * 9000),
        ]
    )
    torch.save(views, os.path.join(out, "ts_views.pt"), pickle_protocol=4)
    expected["ts_views.pt"] = soup_expect(pts, opacity, sigma_view, dc, rest1, 0)
    expected["ts_views.pt"]["extras"] = {"visible": [float(i * 9000) for i in range(n)]}

    # 4. Triangle Splatting+ indexed variant.
    v, t = 6, 5
    verts = torch.randn(v, 3)
    idx = torch.tensor([[0, 1, 2], [0, 2, 3], [3, 4, 5], [1, 4, 2], [5, 0, 3]], dtype=torch.long)
    vdc = torch.randn(v, 1, 3)
    vrest = torch.randn(v, 15, 3) * 0.1
    weight = torch.randn(v, 1) * 3.0
    sig = torch.tensor(-2.5)
    plus = {
        "triangles_points": torch.nn.Parameter(verts.clone()),
        "_triangle_indices": idx,
        "features_dc": torch.nn.Parameter(vdc.clone()),
        "features_rest": torch.nn.Parameter(vrest.clone()),
        "vertex_weight": torch.nn.Parameter(weight.clone()),
        "sigma": torch.nn.Parameter(sig.clone()),
        "active_sh_degree": 3,
        "importance_score": torch.rand(t),
    }
    importance = flat(plus["importance_score"])
    torch.save(plus, os.path.join(out, "ts_plus.pt"))
    # The documented conversion, computed independently in float64.
    floor = 0.9999
    tri_pts = verts.double()[idx]  # [T,3,3]
    mean_w = weight.double()[idx].mean(dim=1).flatten()  # [T]
    op = []
    for m in mean_w.tolist():
        s = 1.0 / (1.0 + math.exp(-m))
        alpha = floor + (1.0 - floor) * s
        op.append(math.log(alpha / ((1.0 - floor) * (1.0 / (1.0 + math.exp(m))))))
    e = soup_expect(
        tri_pts,
        torch.tensor(op),
        sig.expand(t),
        vdc.double()[idx].mean(dim=1),
        vrest.double()[idx].mean(dim=1),
        3,
        exact=False,
        tol=1e-5,
    )
    e["extras"] = {"importance_score": importance}
    expected["ts_plus.pt"] = e

    with open(os.path.join(out, "expected.json"), "w") as f:
        json.dump(expected, f)
    print(f"wrote {len(expected)} checkpoints and expected.json to {out} (torch {torch.__version__}, {device})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
