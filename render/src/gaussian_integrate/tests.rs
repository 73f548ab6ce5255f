//! Tests of GOF's integration against closed forms.
//!
//! The expected alphas come from the Mahalanobis form of each Gaussian
//! (Σ⁻¹ = R diag(1/(σ² + 1e-7)) Rᵀ built with glam's quaternion, not the
//! crate's matrix) along the world-space ray from the camera centre:
//! min over the ray m = μ'ᵀΣ⁻¹μ' − (dᵀΣ⁻¹μ')²/(dᵀΣ⁻¹d) with μ' = μ − C, and
//! the form at the point itself when the minimum lies beyond it. The kernel
//! works in f32: the form A t² + B t + C cancels terms of size
//! C ≈ |μ − c|²/σ_min², so m carries an error of a few f32 ulps of C and α
//! of ½·o times that; [`tol`] allows 16 ulps (ε = 2⁻²³) of C, at least 2e-5.

use glam::{DMat3, DQuat, DVec3};

use super::*;
use crate::gaussian::{Filter2d, RasterSettings, render};
use crate::testutil::{Lcg, random_sh, test_camera};

const TOL: f32 = 2e-5;

/// The tolerance of an alpha made of Gaussians `g` seen from `c` (see the
/// module doc).
fn tol(g: &Gaussians3, c: DVec3) -> f32 {
    let worst = (0..g.len())
        .map(|i| {
            let d = DVec3::from_array(g.means[i].map(f64::from)) - c;
            let smin = g.scales[i].iter().fold(f32::MAX, |a, &b| a.min(b)) as f64;
            d.length_squared() / (smin * smin)
        })
        .fold(0.0, f64::max);
    (0.5 * 16.0 * f32::EPSILON as f64 * worst).max(TOL as f64) as f32
}

/// One Gaussian: mean, σ, quaternion (w, x, y, z), opacity.
type G = ([f32; 3], [f32; 3], [f32; 4], f32);

fn gaussians(list: &[G]) -> Gaussians3 {
    Gaussians3 {
        means: list.iter().map(|g| g.0).collect(),
        scales: list.iter().map(|g| g.1).collect(),
        rotations: list.iter().map(|g| g.2).collect(),
        opacities: list.iter().map(|g| g.3).collect(),
        sh: vec![[0.0; 3]; list.len()],
        sh_degree: 0,
    }
}

/// Σ⁻¹ of Gaussian i, independently of the crate's quaternion code.
fn inv_cov(g: &Gaussians3, i: usize) -> DMat3 {
    let [w, x, y, z] = g.rotations[i].map(f64::from);
    let r = DMat3::from_quat(DQuat::from_xyzw(x, y, z, w).normalize());
    let s = DVec3::from_array(g.scales[i].map(|v| 1.0 / ((v as f64).powi(2) + 1e-7)));
    r * DMat3::from_diagonal(s) * r.transpose()
}

/// GOF's per-Gaussian alpha for a point p seen from camera centre c: the
/// form minimised along the ray, at p if the minimum lies beyond it.
fn expected_alpha(g: &Gaussians3, i: usize, c: DVec3, p: DVec3) -> f64 {
    let si = inv_cov(g, i);
    let mu = DVec3::from_array(g.means[i].map(f64::from)) - c;
    let d = p - c;
    let s = d.dot(si * mu) / d.dot(si * d);
    let s = s.min(1.0);
    let q = s * d - mu;
    let m = q.dot(si * q);
    (g.opacities[i] as f64 * (-0.5 * m).exp()).min(0.99)
}

fn settings() -> IntegrateSettings {
    IntegrateSettings::default()
}

/// A posed camera: at (1, −0.5, −6) looking at the origin.
fn posed_camera() -> Camera {
    posed_camera_pp(40.0, 32.0)
}

/// [`posed_camera`] with principal point (cx, cy).
fn posed_camera_pp(cx: f64, cy: f64) -> Camera {
    let center = DVec3::new(1.0, -0.5, -6.0);
    let fwd = (-center).normalize();
    let right = DVec3::Y.cross(fwd).normalize() * -1.0;
    let down = fwd.cross(right);
    let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(right, down, fwd), center);
    Camera::pinhole("posed", 80, 64, 70.0, 70.0, cx, cy, r, t)
}

/// One rotated anisotropic Gaussian: a point far behind it on a ray gets
/// min(0.99, o·exp(−½·min over the ray)); a point in front of it gets the
/// value at its own depth (t clamped). Also with the principal point off
/// the centre (our rays use (cx, cy) where GOF has (W/2, H/2)).
#[test]
fn single_gaussian_behind_and_in_front() {
    single_gaussian_case(posed_camera());
    single_gaussian_case(posed_camera_pp(33.0, 29.5));
}

fn single_gaussian_case(cam: Camera) {
    let g = gaussians(&[(
        [0.05, 0.02, 0.1],
        [0.3, 0.15, 0.4],
        [0.9, 0.2, -0.3, 0.1],
        0.85,
    )]);
    let view = PreparedView::new(&g, &cam, &settings());
    let c = cam.center();
    let mu = DVec3::from_array(g.means[0].map(f64::from));
    // rays through points near the mean, extended far behind / cut in front
    let offsets = [
        DVec3::ZERO,
        DVec3::new(0.1, 0.05, 0.0),
        DVec3::new(-0.2, 0.1, 0.05),
    ];
    let mut pts = Vec::new();
    for o in offsets {
        let dir = (mu + o - c).normalize();
        pts.push(c + dir * 12.0); // far behind the Gaussian (depth ≈ 6)
        pts.push(c + dir * 5.5); // in front of it
    }
    let p32: Vec<[f32; 3]> = pts.iter().map(|p| p.as_vec3().to_array()).collect();
    let out = view.integrate(&p32);
    for (k, p) in p32.iter().enumerate() {
        let pd = DVec3::from_array(p.map(f64::from));
        let want = expected_alpha(&g, 0, c, pd) as f32;
        assert!(
            (out.alpha[k] - want).abs() < tol(&g, c),
            "point {k}: {} vs {want}",
            out.alpha[k]
        );
    }
    // in front really is cut: lower than behind on the same ray
    assert!(out.alpha[1] < out.alpha[0] - 0.05);
}

/// Two Gaussians in depth order compose as 1 − Π(1 − αᵢ).
#[test]
fn two_gaussians_compose() {
    let cam = test_camera(64, 64, 60.0);
    let g = gaussians(&[
        ([0.1, 0.0, 6.0], [0.4, 0.4, 0.4], [1.0, 0.0, 0.0, 0.0], 0.6),
        (
            [-0.05, 0.1, 4.0],
            [0.2, 0.5, 0.3],
            [0.8, 0.1, 0.5, -0.2],
            0.5,
        ),
    ]);
    let view = PreparedView::new(&g, &cam, &settings());
    let c = DVec3::ZERO;
    let pts = [
        DVec3::new(0.2, 0.1, 20.0),
        DVec3::new(-0.1, 0.3, 15.0),
        DVec3::new(0.05, 0.0, 5.0), // between the two: the far one is cut
    ];
    let p32: Vec<[f32; 3]> = pts.iter().map(|p| p.as_vec3().to_array()).collect();
    let out = view.integrate(&p32);
    for (k, p) in pts.iter().enumerate() {
        let a0 = expected_alpha(&g, 0, c, *p);
        let a1 = expected_alpha(&g, 1, c, *p);
        let want = (1.0 - (1.0 - a0) * (1.0 - a1)) as f32;
        assert!(
            (out.alpha[k] - want).abs() < tol(&g, c),
            "point {k}: {} vs {want}",
            out.alpha[k]
        );
    }
}

/// Only the pixel's contributors count: after one α = 0.99 Gaussian a
/// second one would take every pixel ray's T below 1e-4, so it is no
/// contributor and a point behind both gets 0.99, not 1 − 0.01².
#[test]
fn point_pass_walks_contributors_only() {
    let cam = test_camera(64, 64, 50.0);
    let g = gaussians(&[
        ([0.0, 0.0, 5.0], [2.0, 2.0, 2.0], [1.0, 0.0, 0.0, 0.0], 1.0),
        ([0.0, 0.0, 8.0], [2.0, 2.0, 2.0], [1.0, 0.0, 0.0, 0.0], 1.0),
    ]);
    let view = PreparedView::new(&g, &cam, &settings());
    let out = view.integrate(&[[0.01, 0.02, 30.0]]);
    assert_eq!(out.alpha[0], 0.99);
    // without the first Gaussian the second one counts
    let g2 = gaussians(&[([0.0, 0.0, 8.0], [2.0, 2.0, 2.0], [1.0, 0.0, 0.0, 0.0], 1.0)]);
    let out2 = PreparedView::new(&g2, &cam, &settings()).integrate(&[[0.01, 0.02, 30.0]]);
    assert_eq!(out2.alpha[0], 0.99);
}

/// Points outside the image, behind the near limit or behind the camera,
/// and points in a view without Gaussians in their pixel: the initial value
/// (1, black) for the first kind, 0 for the last.
#[test]
fn untouched_points_keep_the_initial_value() {
    let cam = test_camera(64, 48, 50.0);
    let g = gaussians(&[([0.0, 0.0, 5.0], [0.3, 0.3, 0.3], [1.0, 0.0, 0.0, 0.0], 0.7)]);
    let view = PreparedView::new(&g, &cam, &settings());
    let pts = [
        [10.0, 0.0, 5.0],  // right of the image
        [0.0, -10.0, 5.0], // above it
        [0.0, 0.0, 0.2],   // at the near limit
        [0.0, 0.0, -3.0],  // behind the camera
        [0.0, 0.0, 5.0],   // inside, for contrast
        [2.9, 2.0, 5.0],   // in the image, pixel far from the Gaussian
    ];
    let out = view.integrate(&pts);
    for k in 0..4 {
        assert_eq!((out.alpha[k], out.rgb[k]), (1.0, [0.0; 3]), "point {k}");
    }
    assert!((out.alpha[4] - 0.7).abs() < TOL);
    assert_eq!(out.alpha[5], 0.0);
    // y = 48 exactly (bottom edge) is outside: [0, H) is half-open
    let edge = [0.0, 24.0 * 5.0 / 50.0, 5.0];
    assert_eq!(view.integrate(&[edge]).alpha[0], 1.0);
}

/// A point whose pixel coordinate is exactly the integer i goes to pixel
/// i (the half-open [i, i + 1)): it gets pixel i's colour bit for bit.
#[test]
fn pixel_boundary_is_half_open() {
    let cam = test_camera(64, 64, 50.0);
    let mut g = gaussians(&[([0.3, 0.0, 5.0], [0.3, 0.3, 0.3], [1.0, 0.0, 0.0, 0.0], 0.7)]);
    g.sh = vec![[1.0, 0.5, -0.5]];
    let view = PreparedView::new(&g, &cam, &settings());
    let z = 5.0f32;
    // x = 50·X/(z + 1e-7) + 32: X = 0 gives exactly 32
    let at = |x: f32| [(x - 32.0) * z / 50.0, 0.0, z];
    let out = view.integrate(&[at(32.0), at(32.7), at(31.99), at(31.2)]);
    assert_eq!(out.rgb[0], out.rgb[1], "x = 32 is in pixel 32");
    assert_eq!(out.rgb[2], out.rgb[3]);
    assert_ne!(out.rgb[0], out.rgb[2], "pixels 31 and 32 differ");
}

/// The pixel's colour: where a pixel's centre ray goes through an isotropic
/// Gaussian's centre, the 3D ray rule and 3DGS's 2-D conic (Mip filter, k = 0)
/// both give α = o there, so GOF's colour of a point in that pixel equals
/// the rasterised pixel.
#[test]
fn colour_matches_rasteriser_at_the_centre_pixel() {
    let cam = test_camera(64, 64, 50.0);
    // centre on the ray of pixel (40, 20): u = 40.5, v = 20.5
    let z = 6.0;
    let mean = [(40.5 - 32.0) * z / 50.0, (20.5 - 32.0) * z / 50.0, z];
    let mut g = gaussians(&[(
        mean.map(|v| v as f32),
        [0.4, 0.4, 0.4],
        [1.0, 0.0, 0.0, 0.0],
        0.8,
    )]);
    g.sh = vec![[0.9, -0.3, 0.2]];
    let bg = [0.2, 0.4, 0.6];
    let s = IntegrateSettings {
        background: bg,
        kernel_size: 0.0,
        ..Default::default()
    };
    let view = PreparedView::new(&g, &cam, &s);
    let p = [
        (mean[0] * 2.0) as f32,
        (mean[1] * 2.0) as f32,
        (z * 2.0) as f32,
    ];
    let out = view.integrate(&[p]);
    let rs = RasterSettings {
        background: bg,
        near: 0.2,
        filter_2d: Filter2d::Mip { kernel_size: 0.0 },
        ..Default::default()
    };
    let img = render(&g, &cam, &rs);
    let want = img.rgb[20 * 64 + 40];
    for ch in 0..3 {
        assert!(
            (out.rgb[0][ch] - want[ch]).abs() < 1e-5,
            "{:?} vs {want:?}",
            out.rgb[0]
        );
    }
    assert!((out.alpha[0] - 0.8).abs() < TOL);
}

/// Appends `n` Gaussians with means in [−1, 1]² × `z`, each scale in
/// `scale`, random (unnormalised) quaternions and opacity in `opacity`.
fn push_random(
    g: &mut Gaussians3,
    r: &mut Lcg,
    n: usize,
    z: (f64, f64),
    scale: (f64, f64),
    opacity: (f64, f64),
) {
    for _ in 0..n {
        g.means
            .push([r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(z.0, z.1)]);
        g.scales.push([
            r.range(scale.0, scale.1),
            r.range(scale.0, scale.1),
            r.range(scale.0, scale.1),
        ]);
        g.rotations.push([
            r.range(-1.0, 1.0),
            r.range(-1.0, 1.0),
            r.range(-1.0, 1.0),
            r.range(-1.0, 1.0),
        ]);
        g.opacities.push(r.range(opacity.0, opacity.1));
    }
}

fn random_scene(n: usize, seed: u64) -> (Gaussians3, Vec<[f32; 3]>) {
    let mut r = Lcg(seed);
    let mut g = Gaussians3 {
        sh_degree: 1,
        ..Default::default()
    };
    push_random(&mut g, &mut r, n, (3.0, 5.0), (0.02, 0.3), (0.05, 1.0));
    g.sh = random_sh(&mut r, 4 * n);
    let pts = (0..3000)
        .map(|_| [r.range(-1.5, 1.5), r.range(-1.5, 1.5), r.range(0.0, 8.0)])
        .collect();
    (g, pts)
}

/// The same values for 1 and 4 threads, and for the kept and the streaming
/// multi-view evaluation.
#[test]
fn independent_of_thread_count() {
    let (g, pts) = random_scene(400, 7);
    let cams = [test_camera(96, 80, 70.0), posed_camera()];
    let s = IntegrateSettings {
        background: [1.0; 3],
        kernel_size: 0.1,
        ..Default::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| OpacityField::new(&g, &cams, &s).evaluate(&pts))
    };
    let one = run(1);
    assert_eq!(one, run(4));
    assert_eq!(one, opacity_field(&g, &cams, &pts, &s));
    // something was integrated, and alpha stays in [0, 1]
    assert!(one.0.iter().any(|&a| a > 0.3));
    assert!(one.0.iter().all(|&a| (0.0..=1.0).contains(&a)));
}

/// Kept pixel passes change nothing (bit for bit): a view evaluated twice
/// with its cache (the second call reuses the first's passes, then new
/// points in new pixels), without one, and with a limit too small to keep
/// more than a few passes.
#[test]
fn kept_pixel_passes_are_exact() {
    let (g, pts) = random_scene(400, 11);
    let (a, b) = pts.split_at(pts.len() / 2);
    let cam = test_camera(96, 80, 70.0);
    let with = |bytes: usize| IntegrateSettings {
        cache_bytes: bytes,
        ..Default::default()
    };
    let fresh = PreparedView::new(&g, &cam, &with(0));
    let want_a = fresh.integrate(a);
    let want_all = fresh.integrate(&pts);
    for bytes in [64 << 20, 2_000] {
        let v = PreparedView::new(&g, &cam, &with(bytes));
        assert_eq!(v.integrate(a), want_a, "cache {bytes}: first call");
        assert_eq!(v.integrate(&pts), want_all, "cache {bytes}: reuse");
        assert_eq!(v.integrate(a), want_a, "cache {bytes}: all kept");
        let kept = v.cache.bytes.load(std::sync::atomic::Ordering::Relaxed);
        assert!(kept <= bytes, "{kept} bytes kept over the limit {bytes}");
        assert!(kept > 0, "nothing kept");
    }
    assert!(!b.is_empty());
}

/// Skipping the Gaussians whose reach box misses a pixel changes nothing
/// (bit for bit), on a random scene with many near-threshold Gaussians.
#[test]
fn reach_skip_is_exact() {
    let (g, pts) = random_scene(600, 5);
    for cam in [test_camera(96, 80, 70.0), posed_camera_pp(37.0, 30.0)] {
        let s = IntegrateSettings {
            background: [0.3; 3],
            kernel_size: 0.1,
            ..Default::default()
        };
        let mut v = PreparedView::new(&g, &cam, &s);
        let fast = v.integrate(&pts);
        v.use_reach = false;
        assert_eq!(fast, v.integrate(&pts));
    }
}

/// The point pass's exits (every remaining Gaussian behind the point; the
/// transmittance spent) and its exponent skip change nothing, bit for bit,
/// where they matter most: four layers of nearly opaque flat Gaussians
/// (after them T < 2⁻²⁶) among faint ones, and points in front of, between
/// and behind the layers. The exits must also be taken on this scene:
/// some point ends at T < 2⁻²⁶ and some point is in front of whole walks.
#[test]
fn point_pass_shortcuts_are_exact() {
    let mut r = Lcg(21);
    let mut g = Gaussians3 {
        sh_degree: 0,
        ..Default::default()
    };
    for layer in 0..4 {
        for k in 0..120 {
            let (x, y) = ((k % 12) as f32 * 0.2 - 1.1, (k / 12) as f32 * 0.2 - 1.0);
            g.means
                .push([x + r.range(-0.03, 0.03), y, 3.0 + 0.25 * layer as f32]);
            g.scales.push([0.15, 0.15, 0.002]);
            g.rotations
                .push([1.0, r.range(-0.05, 0.05), r.range(-0.05, 0.05), 0.0]);
            g.opacities.push(0.99);
        }
    }
    push_random(&mut g, &mut r, 300, (2.0, 5.0), (0.01, 0.2), (0.01, 0.3));
    g.sh = random_sh(&mut r, g.means.len());
    let pts: Vec<[f32; 3]> = (0..6000)
        .map(|_| [r.range(-1.2, 1.2), r.range(-1.0, 1.0), r.range(0.5, 6.0)])
        .collect();
    let cam = test_camera(96, 80, 70.0);
    let mut v = PreparedView::new(&g, &cam, &IntegrateSettings::default());
    let fast = v.integrate(&pts);
    v.use_reach = false;
    let full = v.integrate(&pts);
    assert_eq!(fast, full);
    // The exits were taken. Behind the four layers T reaches 0.01⁴ < 2⁻²⁶,
    // so some point's walk ends there with acc ≈ 1. Every Gaussian's near
    // end lies beyond depth 1.0 (faint ones: z ≥ 2 less at most ~0.6), so the
    // claimed points nearer than that end their walk at its first entry and
    // get exactly 0.
    assert!(full.alpha.iter().any(|&a| a > 1.0 - 1e-6));
    let front: Vec<f32> = pts
        .iter()
        .zip(&full.alpha)
        .filter(|(p, a)| p[2] < 1.0 && **a != 1.0)
        .map(|(_, a)| *a)
        .collect();
    assert!(
        front.len() > 20,
        "{} claimed points before depth 1",
        front.len()
    );
    assert!(front.iter().all(|&a| a == 0.0), "{front:?}");
}

/// `evaluage_alpha`: alpha = 1 − min over views (from 1), colour from the
/// view with the smallest alpha_integrated (white where none is below 1).
#[test]
fn views_combine_by_minimum() {
    let (g, pts) = random_scene(200, 3);
    let cams = [test_camera(96, 80, 70.0), posed_camera()];
    let s = settings();
    let per: Vec<Integrated> = cams
        .iter()
        .map(|c| PreparedView::new(&g, c, &s).integrate(&pts))
        .collect();
    let (alpha, rgb) = opacity_field(&g, &cams, &pts, &s);
    for i in 0..pts.len() {
        let (a0, a1) = (per[0].alpha[i], per[1].alpha[i]);
        assert_eq!(alpha[i], 1.0 - a0.min(a1).min(1.0));
        let want = if a0 < 1.0 && a0 <= a1 {
            per[0].rgb[i]
        } else if a1 < 1.0 && a1 < a0 {
            per[1].rgb[i]
        } else {
            [1.0; 3]
        };
        assert_eq!(rgb[i], want, "point {i}");
    }
}

/// The kernel keeps contributors as u16 list positions: a contributor at
/// position 65541 is stored as 5, so the point pass walks the (transparent)
/// Gaussian at position 5 instead and never reaches it.
#[test]
fn contributor_positions_wrap_at_u16() {
    let cam = test_camera(64, 64, 50.0);
    let a = ([0.0, 0.0, 2.0], [0.3, 0.3, 0.3], [1.0, 0.0, 0.0, 0.0], 0.5);
    let b = ([0.0, 0.0, 50.0], [3.0, 3.0, 3.0], [1.0, 0.0, 0.0, 0.0], 0.6);
    let mut list = vec![a];
    // list positions 2..=65540: α < 1/255 everywhere (o = 0.003)
    for i in 0..65539 {
        list.push((
            [0.0, 0.0, 3.0 + i as f32 * 1e-5],
            [0.05; 3],
            [1.0, 0.0, 0.0, 0.0],
            0.003,
        ));
    }
    list.push(b); // position 65541
    let g = gaussians(&list);
    let p = [0.01f32, 0.01, 100.0];
    let got = PreparedView::new(&g, &cam, &settings())
        .integrate(&[p])
        .alpha[0];
    let pd = DVec3::new(0.01, 0.01, 100.0);
    let ga = gaussians(&[a, b]);
    let (aa, ab) = (
        expected_alpha(&ga, 0, DVec3::ZERO, pd),
        expected_alpha(&ga, 1, DVec3::ZERO, pd),
    );
    assert!((got - aa as f32).abs() < TOL, "{got} vs {aa}");
    // without the wrap, b counts
    let both = PreparedView::new(&ga, &cam, &settings())
        .integrate(&[p])
        .alpha[0];
    let want = (1.0 - (1.0 - aa) * (1.0 - ab)) as f32;
    assert!((both - want).abs() < TOL, "{both} vs {want}");
}

/// A closed shell of opaque Gaussians seen from six sides: inside, every
/// view's ray crosses the shell (one layer, accumulated opacity ≈ 0.85 with
/// its gaps), so GOF's alpha (1 − the minimum) is well below 0.5 (sdf < 0);
/// outside, some view sees the point through free space and alpha is near
/// 1 (sdf > 0).
#[test]
fn shell_inside_and_outside() {
    let mut g = Gaussians3::default();
    // Fibonacci sphere of radius 1, spacing ≈ 0.06, σ = 0.05
    let n = 1200;
    for i in 0..n {
        let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - y * y).sqrt();
        let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
        g.means
            .push([(r * phi.cos()) as f32, y as f32, (r * phi.sin()) as f32]);
        g.scales.push([0.05; 3]);
        g.rotations.push([1.0, 0.0, 0.0, 0.0]);
        g.opacities.push(0.95);
        g.sh.push([0.0; 3]);
    }
    let cams: Vec<Camera> = [
        DVec3::X,
        -DVec3::X,
        DVec3::Y,
        -DVec3::Y,
        DVec3::Z,
        -DVec3::Z,
    ]
    .iter()
    .map(|&d| {
        let center = d * 4.0;
        let fwd = -d;
        let up = if d.y.abs() > 0.5 { DVec3::Z } else { DVec3::Y };
        let right = fwd.cross(up).normalize();
        let down = fwd.cross(right);
        let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(right, down, fwd), center);
        Camera::pinhole("c", 96, 96, 80.0, 80.0, 48.0, 48.0, r, t)
    })
    .collect();
    let field = OpacityField::new(&g, &cams, &settings());
    let inside = [[0.0f32, 0.0, 0.0], [0.3, -0.2, 0.1], [0.0, 0.5, -0.4]];
    let outside = [[1.5f32, 0.0, 0.0], [0.0, -1.6, 0.3], [1.0, 1.0, 1.0]];
    let (a_in, _) = field.evaluate(&inside);
    let (a_out, _) = field.evaluate(&outside);
    assert!(a_in.iter().all(|&a| a < 0.3), "{a_in:?}");
    assert!(a_out.iter().all(|&a| a > 0.9), "{a_out:?}");
}

/// The tile pass (shared corner rays, reach boxes) gives every pixel the
/// same walk and colour, bit for bit, as the plain per-pixel kernel, with
/// all pixels of a tile occupied and with a sparse few.
#[test]
fn tile_pass_matches_pixel_pass() {
    let (g, _) = random_scene(500, 9);
    for cam in [test_camera(40, 36, 40.0), posed_camera_pp(41.0, 30.5)] {
        let s = IntegrateSettings {
            background: [0.1, 0.5, 0.9],
            kernel_size: 0.1,
            ..Default::default()
        };
        let v = PreparedView::new(&g, &cam, &s);
        let (w, h) = (cam.width as usize, cam.height as usize);
        for tile in 0..v.binned.lists.len() {
            let (x0, y0) = ((tile % v.tiles_x) * TILE, (tile / v.tiles_x) * TILE);
            let all: Vec<(usize, usize)> = (0..TILE * TILE)
                .map(|q| (q % TILE, q / TILE))
                .filter(|&(lx, ly)| x0 + lx < w && y0 + ly < h)
                .collect();
            let sparse: Vec<(usize, usize)> = all.iter().copied().step_by(7).collect();
            for set in [&all, &sparse] {
                let got = pixel::tile_pass(&v, tile, set);
                for (p, &(lx, ly)) in set.iter().enumerate() {
                    assert_eq!(got[p], v.pixel_pass(x0 + lx, y0 + ly), "pixel {lx},{ly}");
                }
            }
        }
    }
}
