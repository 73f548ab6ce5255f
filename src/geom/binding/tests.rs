use glam::{DMat3, DQuat, DVec3};
use splatkit_render::gaussian::{RasterSettings, rasterize, render};
use splatkit_render::gaussian_grad;

use super::grad::{NormalConsistency, backward};
use super::rebind::{ScaleRule, rebind};
use super::*;
use crate::model::Camera;
use crate::model::bound::PER_FACE_CHOICES;
use crate::model::rng::seeded;
use rand::RngExt;

/// A small closed mesh with uneven faces: an octahedron with one vertex
/// pulled out and vertex colours.
fn octa() -> Mesh {
    let v = vec![
        [1.3, 0.0, 0.0],
        [-1.0, 0.1, 0.0],
        [0.0, 1.0, 0.2],
        [0.0, -1.1, 0.0],
        [0.1, 0.0, 1.2],
        [0.0, 0.0, -1.0],
    ];
    let f = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut m = Mesh::new(v, f);
    m.vertex_colors = Some(
        (0..6)
            .map(|i| [40 * i as u8, 200 - 30 * i as u8, 100, 255])
            .collect(),
    );
    m
}

fn opts(n: usize) -> BindOptions {
    BindOptions {
        per_face: n,
        thickness: 1e-4,
        sh_degree: 3,
    }
}

fn rot_matrix(q: [f64; 4]) -> DMat3 {
    DMat3::from_quat(DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize())
}

/// Means sit on their faces at the tabled barycentrics (which are positive
/// and sum to 1), for every n; the count is faces × n in face-major order.
/// Tolerance 1e-6: the means are f32 values of unit-sized coordinates.
#[test]
fn means_lie_on_their_triangles_at_the_table() {
    let m = octa();
    for n in PER_FACE_CHOICES {
        let b = bind(&m, &opts(n), None).unwrap();
        assert_eq!(b.len(), m.faces.len() * n);
        let g = materialize(&b);
        let table = crate::model::bound::barycentrics(n).unwrap();
        for row in table {
            assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            assert!(row.iter().all(|&w| w > 0.0));
        }
        for (i, mu) in g.means.iter().enumerate() {
            let (f, j) = (i / n, i % n);
            let v = face_vertices(&m, f);
            let w = table[j];
            for k in 0..3 {
                let want: f64 = (0..3).map(|a| w[a] as f64 * v[a][k]).sum();
                assert!((mu[k] as f64 - want).abs() < 1e-6, "gaussian {i}");
            }
        }
    }
}

/// Other counts are refused with a message naming the choices.
#[test]
fn per_face_outside_the_tables_is_an_error() {
    for n in [0, 2, 5, 7, 12] {
        let e = bind(&octa(), &opts(n), None).unwrap_err().to_string();
        assert!(e.contains("1, 3, 4 or 6"), "{e}");
    }
}

/// The rotation is orthonormal with a positive determinant, its first
/// column is the face normal, and its second is the edge v0 − v1 turned by
/// the complex number's angle in the face plane. Tolerance 1e-6 (f64 maths,
/// f32 inputs of unit size).
#[test]
fn rotation_is_the_face_frame_turned_by_the_complex_number() {
    let m = octa();
    let mut b = bind(&m, &opts(3), None).unwrap();
    let mut r = seeded(4);
    for c in &mut b.complex {
        *c = [
            r.random_range(-2.0..2.0) as f32,
            r.random_range(-2.0..2.0) as f32,
        ];
    }
    for i in 0..b.len() {
        let v = face_vertices(&m, b.face_of(i)).map(DVec3::from_array);
        let rm = rot_matrix(quat_of(&b, i));
        let id = rm.transpose() * rm;
        for k in 0..3 {
            assert!((id.col(k) - DMat3::IDENTITY.col(k)).length() < 1e-6);
        }
        assert!((rm.determinant() - 1.0).abs() < 1e-6);
        let normal = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        assert!(
            (rm.x_axis - normal).length() < 1e-6,
            "first column is the normal"
        );
        let e = (v[0] - v[1]).normalize();
        let c = b.complex[i].map(f64::from);
        let ang = c[1].atan2(c[0]);
        let want = DMat3::from_axis_angle(normal, ang) * e;
        assert!((rm.y_axis - want).length() < 1e-6, "gaussian {i}");
    }
}

/// SuGaR's initial values: complex (1, 0), both scales r(n) × shortest edge,
/// opacity 0.1, DC from the barycentric vertex colour, higher SH zero.
#[test]
fn initial_values_are_sugars() {
    let m = octa();
    for n in PER_FACE_CHOICES {
        let b = bind(&m, &opts(n), None).unwrap();
        let r = crate::model::bound::circle_radius(n).unwrap();
        for i in 0..b.len() {
            let v = face_vertices(&m, b.face_of(i)).map(DVec3::from_array);
            let short = (v[0] - v[1])
                .length()
                .min((v[1] - v[2]).length())
                .min((v[2] - v[0]).length());
            assert_eq!(b.complex[i], [1.0, 0.0]);
            for s in b.log_scales[i] {
                assert!((s as f64 - (r * short).ln()).abs() < 1e-6);
            }
            assert!((crate::model::gaussians::sigmoid(b.opacity_logits[i]) - 0.1).abs() < 1e-6);
            let w = b.bary_of(i);
            let face = m.faces[b.face_of(i)];
            let cols = m.vertex_colors.as_ref().unwrap();
            for (k, dc) in b.sh_dc[i].iter().enumerate() {
                let rgb: f32 = (0..3)
                    .map(|a| w[a] * cols[face[a] as usize][k] as f32 / 255.0)
                    .sum();
                let back = splatkit_render::sh::sh_to_rgb(*dc);
                assert!((back - rgb).abs() < 1e-5);
            }
        }
        assert!(b.sh_rest.iter().all(|&x| x == 0.0));
        assert_eq!(b.sh_rest.len(), b.len() * 45);
    }
}

fn transformed(m: &Mesh, rot: DMat3, t: DVec3, s: f64) -> Mesh {
    let mut out = m.clone();
    for v in &mut out.vertices {
        let p = rot * DVec3::from_array(v.map(f64::from)) * s + t;
        *v = p.to_array().map(|x| x as f32);
    }
    out
}

/// Rebinding after a rigid motion moves every Gaussian exactly with its
/// face: means transform like points, rotations compose with the motion,
/// scales are unchanged (bit for bit under the supplement's rule, within
/// 1e-5 under the anisotropic one, whose ratio is 1 up to rounding).
/// Tolerances: 2e-5 on means and rotation columns, from f32 vertex storage
/// (unit-sized coordinates moved by up to 3 units).
#[test]
fn rebinding_after_a_rigid_motion_moves_gaussians_with_their_faces() {
    let m = octa();
    let rot = DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0);
    let t = DVec3::new(0.5, -2.0, 3.0);
    let moved = transformed(&m, rot, t, 1.0);
    for rule in [ScaleRule::MeanSide, ScaleRule::Anisotropic] {
        for n in PER_FACE_CHOICES {
            let mut b = bind(&m, &opts(n), None).unwrap();
            let mut r = seeded(n as u64);
            for c in &mut b.complex {
                *c = [
                    r.random_range(-1.0..1.0) as f32,
                    r.random_range(-1.0..1.0) as f32,
                ];
            }
            let rb = rebind(&b, &moved, rule).unwrap();
            let (g0, g1) = (materialize(&b), materialize(&rb));
            for i in 0..b.len() {
                let p = rot * DVec3::from_array(g0.means[i].map(f64::from)) + t;
                assert!((p - DVec3::from_array(g1.means[i].map(f64::from))).length() < 2e-5);
                let r0 = rot * rot_matrix(g0.rotations[i].map(f64::from));
                let r1 = rot_matrix(g1.rotations[i].map(f64::from));
                for k in 0..3 {
                    assert!(
                        (r0.col(k) - r1.col(k)).length() < 2e-5,
                        "{rule:?} n={n} i={i}"
                    );
                }
                match rule {
                    ScaleRule::MeanSide => assert_eq!(g0.log_scales[i], g1.log_scales[i]),
                    ScaleRule::Anisotropic => {
                        for k in 0..3 {
                            assert!((g0.log_scales[i][k] - g1.log_scales[i][k]).abs() < 1e-5)
                        }
                    }
                }
            }
        }
    }
}

/// Uniform scaling by s multiplies the in-plane scales by s (log + ln s,
/// within f32 rounding of the logs) and leaves rotations alone.
#[test]
fn uniform_scaling_scales_the_in_plane_scales() {
    let m = octa();
    let b = bind(&m, &opts(4), None).unwrap();
    for s in [0.25, 3.0] {
        let rb = rebind(
            &b,
            &transformed(&m, DMat3::IDENTITY, DVec3::ZERO, s),
            ScaleRule::MeanSide,
        )
        .unwrap();
        for i in 0..b.len() {
            for k in 0..2 {
                let want = b.log_scales[i][k] as f64 + f64::ln(s);
                assert!((rb.log_scales[i][k] as f64 - want).abs() < 1e-6);
            }
            assert_eq!(rb.complex[i], b.complex[i]);
        }
    }
}

/// Stretching a face along one in-plane direction stretches the Gaussian
/// axis along it more than the orthogonal one under the anisotropic rule;
/// a uniform scaling keeps the rotation and scales by at most s; the
/// supplement's rule scales both axes by the mean-side ratio.
#[test]
fn anisotropic_rule_follows_the_stretch_direction() {
    // one right triangle in z = 0, stretched ×2 along x
    let m = Mesh::new(
        vec![[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let mut b = bind(&m, &opts(1), None).unwrap();
    b.complex[0] = [1.0, 0.0]; // R1 along v0 − v1 = +x
    let mut e = m.clone();
    for v in &mut e.vertices {
        v[0] *= 2.0;
    }
    let a = rebind(&b, &e, ScaleRule::Anisotropic).unwrap();
    let gx = (a.log_scales[0][0] - b.log_scales[0][0]).exp() as f64;
    let gy = (a.log_scales[0][1] - b.log_scales[0][1]).exp() as f64;
    // the turned axis R1 is still mostly along x; the x axis grows more
    // than the y axis, both at most by the largest length ratio (√(4+1)/√2
    // ≈ 1.58 for the centroid-to-v0 direction)
    assert!(gx > gy && gy >= 1.0 - 1e-6, "x {gx} y {gy}");
    assert!(gx < 1.59, "x {gx}");
    // under a uniform scaling by s the angles do not change, so the complex
    // number is kept and both factors are Σ_k b_k·√(s²cos²θ_k + sin²θ_k) ∈ [1, s]
    let big: Mesh = {
        let mut m2 = m.clone();
        m2.vertices.iter_mut().for_each(|v| *v = v.map(|x| 3.0 * x));
        m2
    };
    let u = rebind(&b, &big, ScaleRule::Anisotropic).unwrap();
    let c = u.complex[0];
    assert!((c[0] - 1.0).abs() < 1e-6 && c[1].abs() < 1e-6, "{c:?}");
    for k in 0..2 {
        let f = (u.log_scales[0][k] - b.log_scales[0][k]).exp();
        assert!((1.0..=3.0 + 1e-6).contains(&f), "{f}");
    }
    let s = rebind(&b, &e, ScaleRule::MeanSide).unwrap();
    let ratio = (2.0 + 5f64.sqrt() + 1.0) / (1.0 + 2f64.sqrt() + 1.0);
    assert!(((s.log_scales[0][0] - b.log_scales[0][0]) as f64 - ratio.ln()).abs() < 1e-6);
}

/// A rebind mesh with other faces is refused, naming the counts or face.
#[test]
fn rebinding_needs_the_same_faces() {
    let m = octa();
    let b = bind(&m, &opts(1), None).unwrap();
    let mut fewer = m.clone();
    fewer.faces.pop();
    let e = rebind(&b, &fewer, ScaleRule::MeanSide)
        .unwrap_err()
        .to_string();
    assert!(e.contains("7 faces") && e.contains("bound to 8"), "{e}");
    let mut other = m.clone();
    other.faces[3] = [0, 3, 4];
    let e = rebind(&b, &other, ScaleRule::MeanSide)
        .unwrap_err()
        .to_string();
    assert!(e.contains("face 3"), "{e}");
}

/// A NaN or infinite vertex is refused by binding and by rebinding (it
/// would give its faces' Gaussians NaN means and rotations), naming the
/// vertex and the coordinate.
#[test]
fn non_finite_vertices_are_refused() {
    let m = octa();
    let b = bind(&m, &opts(3), None).unwrap();
    for (x, shown) in [(f32::NAN, "NaN"), (f32::NEG_INFINITY, "-inf")] {
        let mut bad = m.clone();
        bad.vertices[4][1] = x;
        let want = format!("vertex 4 has a non-finite coordinate (y = {shown})");
        assert_eq!(bind(&bad, &opts(3), None).unwrap_err().to_string(), want);
        for rule in [ScaleRule::MeanSide, ScaleRule::Anisotropic] {
            assert_eq!(rebind(&b, &bad, rule).unwrap_err().to_string(), want);
        }
    }
}
/// Degenerate faces render axis-aligned instead of producing NaNs.
#[test]
fn degenerate_faces_get_the_identity() {
    let m = Mesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let b = bind(&m, &opts(3), None).unwrap();
    let g = materialize(&b);
    assert!(g.rotations.iter().all(|q| *q == [1.0, 0.0, 0.0, 0.0]));
    assert!(g.means.iter().flatten().all(|x| x.is_finite()));
}

/// Camera at (0, 0, −4) looking down +z at the origin.
fn front_camera(w: u32, h: u32) -> Camera {
    Camera::pinhole(
        "front",
        w,
        h,
        40.0,
        40.0,
        w as f64 / 2.0,
        h as f64 / 2.0,
        DMat3::IDENTITY,
        DVec3::new(0.0, 0.0, 4.0),
    )
}

/// Checks `analytic[k]` against central differences (f(k,+h) − f(k,−h))/2h:
/// relative error ≤ 2 %, or absolute ≤ 3e-5/h for entries near zero, on
/// every entry. The rasteriser blends in f32, so a loss summed over ~1500
/// pixels carries ~1e-5 of rounding noise, which the difference quotient
/// turns into 1e-5/2h; the floor is three times that.
fn check(name: &str, analytic: &[f64], h: f64, f: impl Fn(usize, f64) -> f64) {
    let scale = analytic.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0, "{name}: all-zero gradient");
    for (k, &a) in analytic.iter().enumerate() {
        let fd = (f(k, h) - f(k, -h)) / (2.0 * h);
        let err = (a - fd).abs();
        assert!(
            err <= 0.02 * fd.abs().max(a.abs()) || err <= 3e-5 / h,
            "{name}[{k}]: analytic {a:.6e}, finite difference {fd:.6e} (scale {scale:.3e})"
        );
    }
}

/// Finite differences through the whole chain: mesh vertices, complex
/// rotations, in-plane log scales, opacity logits and SH (DC and rest, at
/// active degree 3) → bound Gaussians → rasteriser → L = Σ w·rgb + Σ v·alpha.
/// The scene is smooth in every parameter (as the rasteriser's own check
/// requires): two tilted faces in front of the camera, 3 Gaussians each, in-
/// plane scales large against the 40×36 image so every Gaussian covers every
/// pixel, opacities ≤ 0.6 (no 0.99 clamp, T never near 1e-4), and mean
/// depths at least 0.025 apart (steps move them by ≤ 5e-4), so no two
/// Gaussians swap places in the depth sort, the one discontinuity left.
#[test]
fn gradients_through_the_binding_match_finite_differences() {
    let m = Mesh::new(
        vec![
            [-1.0, -0.8, 0.3],
            [1.1, -0.9, -0.2],
            [0.1, 1.0, 0.4],
            [1.2, 1.1, 0.7],
        ],
        vec![[0, 1, 2], [1, 3, 2]],
    );
    let mut b = bind(
        &m,
        &BindOptions {
            per_face: 3,
            thickness: 1e-3,
            sh_degree: 3,
        },
        None,
    )
    .unwrap();
    let mut r = seeded(11);
    for i in 0..b.len() {
        b.complex[i] = [
            r.random_range(0.3..1.5) as f32,
            r.random_range(-1.0..1.0) as f32,
        ];
        b.log_scales[i] = [
            r.random_range(1.2..1.6) as f32,
            r.random_range(1.2..1.6) as f32,
        ];
        b.opacity_logits[i] = r.random_range(-1.5..0.4) as f32;
        b.sh_dc[i] = [0; 3].map(|_| r.random_range(-0.8..0.8) as f32);
    }
    for x in &mut b.sh_rest {
        *x = r.random_range(-0.15..0.15) as f32;
    }
    let cam = front_camera(40, 36);
    let s = RasterSettings {
        background: [0.2, 0.3, 0.1],
        ..Default::default()
    };
    let npx = 40 * 36;
    let wr: Vec<[f32; 3]> = (0..npx)
        .map(|_| [0; 3].map(|_| r.random_range(-1.0..1.0) as f32))
        .collect();
    let wa: Vec<f32> = (0..npx).map(|_| r.random_range(-1.0..1.0) as f32).collect();
    let loss = |b: &BoundGaussians| -> f64 {
        let img = render(&to_raster(b, 3), &cam, &s);
        let mut l = 0.0;
        for i in 0..npx {
            for (c, w) in img.rgb[i].iter().zip(&wr[i]) {
                l += *c as f64 * *w as f64;
            }
            l += img.alpha[i] as f64 * wa[i] as f64;
        }
        l
    };
    let g3 = to_raster(&b, 3);
    let (img, st) = rasterize(&g3, &cam, &s);
    assert!(
        img.count.iter().all(|&c| c as usize == b.len()),
        "full coverage"
    );
    let gg = gaussian_grad::backward(&g3, &cam, &s, &st, &wr, Some(&wa));
    let bg = backward(&b, &gg, 3);
    let flat3 = |v: &[[f64; 3]]| v.iter().flatten().copied().collect::<Vec<f64>>();
    check("vertices", &flat3(&bg.vertices), 1e-3, |k, h| {
        let mut b2 = b.clone();
        b2.mesh.vertices[k / 3][k % 3] += h as f32;
        loss(&b2)
    });
    let f2 = |v: &[[f32; 2]]| v.iter().flatten().map(|&x| x as f64).collect::<Vec<f64>>();
    check("complex", &f2(&bg.complex), 1e-3, |k, h| {
        let mut b2 = b.clone();
        b2.complex[k / 2][k % 2] += h as f32;
        loss(&b2)
    });
    check("log scales", &f2(&bg.log_scales), 1e-3, |k, h| {
        let mut b2 = b.clone();
        b2.log_scales[k / 2][k % 2] += h as f32;
        loss(&b2)
    });
    let op: Vec<f64> = bg.opacity_logits.iter().map(|&x| x as f64).collect();
    check("opacity logits", &op, 1e-3, |k, h| {
        let mut b2 = b.clone();
        b2.opacity_logits[k] += h as f32;
        loss(&b2)
    });
    let dc: Vec<f64> = bg.sh_dc.iter().flatten().map(|&x| x as f64).collect();
    check("sh dc", &dc, 1e-2, |k, h| {
        let mut b2 = b.clone();
        b2.sh_dc[k / 3][k % 3] += h as f32;
        loss(&b2)
    });
    let rest: Vec<f64> = bg.sh_rest.iter().map(|&x| x as f64).collect();
    check("sh rest", &rest, 1e-2, |k, h| {
        let mut b2 = b.clone();
        b2.sh_rest[k] += h as f32;
        loss(&b2)
    });
}

/// At a lower active SH degree only the used coefficients get gradient.
#[test]
fn sh_warm_up_passes_gradient_only_to_active_bands() {
    let b = bind(&octa(), &opts(1), None).unwrap();
    let g3 = to_raster(&b, 1);
    assert_eq!(g3.sh.len(), b.len() * 4);
    let cam = front_camera(32, 32);
    let s = RasterSettings::default();
    let (_, st) = rasterize(&g3, &cam, &s);
    let ones = vec![[1.0f32; 3]; 32 * 32];
    let gg = gaussian_grad::backward(&g3, &cam, &s, &st, &ones, None);
    let bg = backward(&b, &gg, 1);
    for i in 0..b.len() {
        for k in 3..15 {
            assert_eq!(bg.sh_rest[(i * 15 + k) * 3], 0.0);
        }
    }
    assert!(bg.sh_rest.iter().any(|&x| x != 0.0));
}

/// Normal consistency: 0 on a plane, the closed form 1 − cos θ for two faces
/// folded by θ, and its vertex gradient matches central differences (f64
/// maths on f32 vertices: a 1e-3 step on f32 coordinates leaves ~1e-4 of
/// rounding in the quotient, so 1e-3 relative).
#[test]
fn normal_consistency_value_and_gradient() {
    let flat = Mesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [1, 3, 2]],
    );
    let nc = NormalConsistency::new(&flat.faces);
    assert_eq!(nc.pairs(), 1);
    assert!(nc.eval(&flat.vertices, 1.0, None).abs() < 1e-12);
    // fold vertex 3 up so the dihedral angle between the normals is θ
    let th: f64 = 0.7;
    let mut folded = flat.clone();
    // hinge is the edge (1, 2); move vertex 3 by rotating it about that edge
    let a = DVec3::new(1.0, 0.0, 0.0);
    let axis = (DVec3::new(0.0, 1.0, 0.0) - a).normalize();
    let p = DMat3::from_axis_angle(axis, th) * (DVec3::new(1.0, 1.0, 0.0) - a) + a;
    folded.vertices[3] = p.to_array().map(|x| x as f32);
    let l = nc.eval(&folded.vertices, 1.0, None);
    assert!((l - (1.0 - th.cos())).abs() < 1e-6, "{l}");
    let mut g = vec![[0.0; 3]; 4];
    nc.eval(&folded.vertices, 1.0, Some(&mut g));
    for v in 0..4 {
        for k in 0..3 {
            let h = 1e-3f32;
            let mut a = folded.vertices.clone();
            a[v][k] += h;
            let mut b = folded.vertices.clone();
            b[v][k] -= h;
            let fd = (nc.eval(&a, 1.0, None) - nc.eval(&b, 1.0, None)) / (2.0 * h as f64);
            assert!(
                (fd - g[v][k]).abs() < 1e-3 * (1.0 + fd.abs()),
                "v{v}[{k}] {fd} vs {}",
                g[v][k]
            );
        }
    }
}

/// The Jacobian path and the forward path agree: the dual numbers' values
/// are the forward quaternion.
#[test]
fn jacobian_values_match_the_forward_pass() {
    let b = bind(&octa(), &opts(6), None).unwrap();
    for i in 0..b.len() {
        let v = face_vertices(&b.mesh, b.face_of(i));
        let q = quat_of(&b, i);
        let j = super::grad::quat_jacobian(v, b.complex[i]).unwrap();
        // a tiny step along the Jacobian predicts the change of q
        let h = 1e-6;
        let mut v2 = v;
        v2[2][1] += h;
        let fr = face_frame(v2).unwrap();
        let q2 = quat_from_columns(rotation_columns(fr, b.complex[i].map(f64::from)));
        for k in 0..4 {
            assert!(((q2[k] - q[k]) / h - j[k][7]).abs() < 1e-4);
        }
    }
}

/// Colours from photos: Gaussians whose face the camera sees take the
/// photo's colour at their projected mean (a photo split in two colours,
/// so the pixel must be the right one); Gaussians on a face hidden behind
/// another keep the fallback.
#[test]
fn colours_from_views_take_the_visible_pixel() {
    // two parallel squares facing the camera at z = 0 and z = 1 (hidden)
    let sq = |z: f32| -> Vec<[f32; 3]> {
        vec![
            [-1.0, -1.0, z],
            [1.0, -1.0, z],
            [1.0, 1.0, z],
            [-1.0, 1.0, z],
        ]
    };
    let mut v = sq(0.0);
    v.extend(sq(1.0));
    let m = Mesh::new(v, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]);
    let b = bind(&m, &opts(3), None).unwrap();
    let cam = front_camera(64, 48);
    let (w, h) = (64usize, 48usize);
    let image: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            if i % w < w / 2 {
                [0.2, 0.6, 0.9]
            } else {
                [0.8, 0.1, 0.3]
            }
        })
        .collect();
    let view = crate::model::View {
        camera: cam.clone(),
        image,
        mask: None,
        alpha: None,
        source: "test".into(),
    };
    let fallback = vec![[0.5f32; 3]; b.len()];
    let (rgb, seen) = colors::rgb_from_views(&b, &[view], &fallback);
    for i in 0..b.len() {
        let mu = DVec3::from_array(mean_of(&b, i));
        if b.face_of(i) >= 2 {
            assert_eq!(seen[i], 0, "hidden face");
            assert_eq!(rgb[i], [0.5; 3]);
        } else {
            assert_eq!(seen[i], 1);
            let (px, _) = cam.project(mu).unwrap();
            let want = if (px.x as usize) < w / 2 {
                [0.2, 0.6, 0.9]
            } else {
                [0.8, 0.1, 0.3]
            };
            assert_eq!(rgb[i], want, "gaussian {i}");
        }
    }
}
