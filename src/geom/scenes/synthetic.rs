//! Generated scenes with a known surface: a torus covered with flat,
//! coloured 3DGS Gaussians (raw parameters, ready to write as a standard
//! 3DGS PLY), its exact distance function and a fine triangle mesh of it.
//!
//! Torus convention (as the triangle demo's): ring in the x–z plane, axis
//! along y, point(u, v) = ((R + r cos v) cos u, r sin v, (R + r cos v) sin u).

use glam::{DMat3, DQuat, DVec3};
use rand::RngExt;

use crate::model::gaussians::{Gaussians, logit};
use crate::model::rng;
use crate::model::{Extras, Mesh, TriangleSoup};

/// A torus of major radius `major` and minor radius `minor`.
#[derive(Clone, Copy, Debug)]
pub struct Torus {
    pub major: f64,
    pub minor: f64,
}

impl Torus {
    /// Point and outward unit normal at (u, v), radians.
    pub fn at(&self, u: f64, v: f64) -> (DVec3, DVec3) {
        let n = DVec3::new(v.cos() * u.cos(), v.sin(), v.cos() * u.sin());
        let c = DVec3::new(self.major * u.cos(), 0.0, self.major * u.sin());
        (c + n * self.minor, n)
    }

    /// Unsigned distance from `p` to the surface (exact).
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        let ring = (p[0] * p[0] + p[2] * p[2]).sqrt() - self.major;
        ((ring * ring + p[1] * p[1]).sqrt() - self.minor).abs()
    }

    /// A closed triangle mesh on an `nu × nv` parameter grid (outward winding).
    pub fn mesh(&self, nu: usize, nv: usize) -> Mesh {
        let mut vertices = Vec::with_capacity(nu * nv);
        for i in 0..nu {
            for j in 0..nv {
                let (p, _) = self.at(
                    i as f64 / nu as f64 * std::f64::consts::TAU,
                    j as f64 / nv as f64 * std::f64::consts::TAU,
                );
                vertices.push([p.x as f32, p.y as f32, p.z as f32]);
            }
        }
        let id = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as u32;
        let mut faces = Vec::with_capacity(2 * nu * nv);
        for i in 0..nu {
            for j in 0..nv {
                faces.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
                faces.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
            }
        }
        Mesh::new(vertices, faces)
    }

    /// Flat Gaussians on an `nu × nv` grid: in-plane standard deviations
    /// 0.6 × the local grid spacing along u and v, thickness `thickness`,
    /// opacity 0.95, colour varying with (u, v), SH degree 0; plus
    /// `floaters` transparent (opacity 0.1) blobs around the torus, as an
    /// unregularised capture leaves them.
    pub fn gaussians(
        &self,
        nu: usize,
        nv: usize,
        thickness: f64,
        floaters: usize,
        seed: u64,
    ) -> Gaussians {
        let mut g = Gaussians::default();
        let mut rng = rng::seeded(seed);
        let push = |g: &mut Gaussians, p: DVec3, rot: DMat3, s: [f64; 3], o: f32, rgb: [f32; 3]| {
            let q = DQuat::from_mat3(&rot).normalize();
            g.means.push([p.x as f32, p.y as f32, p.z as f32]);
            g.log_scales.push(s.map(|v| v.ln() as f32));
            g.rotations
                .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
            g.opacity_logits.push(logit(o));
            g.sh_dc.push(rgb.map(splatkit_render::sh::rgb_to_sh));
        };
        for i in 0..nu {
            for j in 0..nv {
                let (u, v) = (
                    (i as f64 + 0.5) / nu as f64 * std::f64::consts::TAU,
                    (j as f64 + 0.5) / nv as f64 * std::f64::consts::TAU,
                );
                let (p, n) = self.at(u, v);
                let tu = DVec3::new(-u.sin(), 0.0, u.cos());
                let tv = n.cross(tu);
                let su =
                    0.6 * std::f64::consts::TAU * (self.major + self.minor * v.cos()) / nu as f64;
                let sv = 0.6 * std::f64::consts::TAU * self.minor / nv as f64;
                let rgb = [
                    (0.5 + 0.4 * u.cos()) as f32,
                    (0.5 + 0.4 * v.sin()) as f32,
                    (0.5 - 0.3 * u.sin()) as f32,
                ];
                push(
                    &mut g,
                    p,
                    DMat3::from_cols(tu, tv, n),
                    [su, sv, thickness],
                    0.95,
                    rgb,
                );
            }
        }
        for _ in 0..floaters {
            let p = DVec3::new(
                rng.random_range(-1.6..1.6),
                rng.random_range(-0.8..0.8),
                rng.random_range(-1.6..1.6),
            );
            let s = rng.random_range(0.02..0.1);
            push(&mut g, p, DMat3::IDENTITY, [s, s, s], 0.1, [1.0, 1.0, 1.0]);
        }
        g.sh_degree = 0;
        g
    }
}

/// The demo's triangle-splat scene: a torus (major radius 1, minor 0.35)
/// tiled with solid, opaque triangles (α = 0.95, σ = 0.5) coloured by angle
/// with SH degree 3, followed by floaters (transparent α = 0.2, or soft
/// σ = 3). Returns `(soup, number of torus triangles)`.
pub fn demo_soup(seed: u64, segments: usize) -> (TriangleSoup, usize) {
    let mut rng = rng::seeded(seed);
    let (nu, nv) = (segments.max(3), (segments / 2).max(3));
    let (big_r, small_r) = (1.0f32, 0.35f32);
    let point = |i: usize, j: usize| {
        let u = i as f32 / nu as f32 * std::f32::consts::TAU;
        let v = j as f32 / nv as f32 * std::f32::consts::TAU;
        let w = big_r + small_r * v.cos();
        [w * u.cos(), small_r * v.sin(), w * u.sin()]
    };
    let mut s = TriangleSoup {
        sh_degree: 3,
        active_sh_degree: 3,
        extras: Extras::default(),
        ..Default::default()
    };
    let push = |s: &mut TriangleSoup,
                t: [[f32; 3]; 3],
                opacity: f32,
                sigma: f32,
                rgb: [f32; 3],
                rng: &mut rng::Rng| {
        s.triangles.push(t);
        s.opacity_raw.push(logit(opacity));
        s.sigma_raw.push((sigma - 0.01).ln());
        s.sh_dc.push(rgb.map(splatkit_render::sh::rgb_to_sh));
        // Mild view dependence in the higher bands.
        s.sh_rest
            .extend((0..45).map(|_| rng.random_range(-0.05f32..0.05)));
    };
    for i in 0..nu {
        for j in 0..nv {
            // Indices wrap so the seams share bit-identical vertices.
            let (a, b, c, d) = (
                point(i, j),
                point((i + 1) % nu, j),
                point((i + 1) % nu, (j + 1) % nv),
                point(i, (j + 1) % nv),
            );
            let hue = i as f32 / nu as f32;
            let rgb = [
                0.5 + 0.4 * (hue * std::f32::consts::TAU).cos(),
                0.5 + 0.4 * (hue * std::f32::consts::TAU + 2.1).cos(),
                0.5 + 0.4 * (hue * std::f32::consts::TAU + 4.2).cos(),
            ];
            push(&mut s, [a, b, c], 0.95, 0.5, rgb, &mut rng);
            push(&mut s, [a, c, d], 0.95, 0.5, rgb, &mut rng);
        }
    }
    let surface = s.len();
    for k in 0..surface / 4 {
        let centre: [f32; 3] = [0, 1, 2].map(|_| rng.random_range(-1.6f32..1.6));
        let t = [0, 1, 2].map(|_| [0, 1, 2].map(|c| centre[c] + rng.random_range(-0.08f32..0.08)));
        let (o, sig) = if k % 2 == 0 { (0.2, 0.5) } else { (0.95, 3.0) };
        push(&mut s, t, o, sig, [0.8, 0.8, 0.8], &mut rng);
    }
    (s, surface)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points and grid vertices lie on the surface; normals are outward
    /// (the distance grows along them); the mesh is closed and outward.
    #[test]
    fn torus_is_consistent() {
        let t = Torus {
            major: 1.0,
            minor: 0.35,
        };
        for (u, v) in [(0.3, 1.2), (2.0, -0.7), (4.5, 3.0)] {
            let (p, n) = t.at(u, v);
            assert!(t.distance(p.to_array()) < 1e-12);
            assert!((t.distance((p + n * 0.01).to_array()) - 0.01).abs() < 1e-12);
        }
        let m = t.mesh(40, 20);
        assert!(crate::geom::mesh_ops::clean::signed_volume(&m) > 0.0);
        let g = t.gaussians(40, 20, 0.005, 5, 1);
        assert_eq!(g.len(), 805);
        g.validate().unwrap();
        // the thin axis of each surface Gaussian is the torus normal
        let (_, n) = t.at(
            0.5 / 40.0 * std::f64::consts::TAU,
            0.5 / 20.0 * std::f64::consts::TAU,
        );
        let z = g.quat(0) * glam::Vec3::Z;
        assert!((z.as_dvec3().dot(n) - 1.0).abs() < 1e-5);
    }
}
