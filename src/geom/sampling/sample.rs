//! Surface sampling of triangle meshes.
//!
//! Two samplers:
//! - the DTU `MeshSupSamp` rule ([`dtu_upsample`], [`dtu_mesh_points`] and its
//!   streaming / parallel forms), reproducing step 2 of the DTUeval-python
//!   `eval.py` mesh mode (the Python port of the MATLAB mex) bit for bit in
//!   float64: a deterministic grid of points per triangle, about one point
//!   per `d²` of area;
//! - uniform random sampling by area ([`sample_area_uniform`],
//!   [`sample_area_uniform_count`], [`sample_area_uniform_with_faces`]) for the
//!   generic Chamfer mode: deterministic for a seed and independent of the
//!   number of rayon threads.
//!
//! Units are those of the vertex coordinates (millimetres for DTU). Faces
//! index `vertices`; an index out of range is an [`Error`] naming the face.

use glam::DVec3;
use rand::RngExt;
use rayon::prelude::*;

use crate::model::rng;
use crate::{Error, Result};

/// Emits the DTU up-sampling points of one triangle `(v0, v1, v2)` at spacing
/// `d` (DTU uses `d = 0.2` mm), reproducing `MeshSupSamp` as ported in
/// DTUeval-python `eval.py` (step 2 of the protocol), all in float64:
///
/// - `e1 = v1 − v0`, `e2 = v2 − v0`, `l1 = |e1|`, `l2 = |e2|`,
///   `A2 = |e1 × e2|` (twice the area); a triangle with `A2 == 0` emits nothing;
/// - `thr = d·sqrt(l1·l2/A2)`, `n1 = floor(l1/thr)`, `n2 = floor(l2/thr)`;
/// - for `i = 0..=n1`, `j = 0..=n2`: `k1 = (i+0.5)/max(n1,1e-7)`,
///   `k2 = (j+0.5)/max(n2,1e-7)`, and the point `e1·k1 + e2·k2 + v0`
///   (evaluated in that order, per coordinate) is emitted iff `k1 + k2 < 1`
///   (strict). If `n1` or `n2` is 0 nothing is emitted.
///
/// A triangle yields exactly `(n1·n2 − T)/2` points, `T` being the grid
/// points with `k1 + k2 = 1` in exact arithmetic (those always round to 1.0
/// and fail the test), i.e. about `A/d²` points for area `A`.
///
/// Order: `i` outer, `j` inner. The reference builds `np.mgrid[:n1+1, :n2+1]`,
/// moves the (i, j) pair to the last axis and selects with a boolean mask,
/// which walks the grid in C order, i.e. the last index (`j`) fastest.
///
/// Divergence from the reference, on input it cannot handle: a triangle with
/// a NaN or infinite vertex emits nothing (numpy drops NaN areas too, but an
/// infinite area makes it fail), and so does a non-positive or non-finite `d`
/// or a grid of 2^52 steps or more along an edge.
pub fn dtu_upsample(
    v0: [f64; 3],
    v1: [f64; 3],
    v2: [f64; 3],
    d: f64,
    mut emit: impl FnMut([f64; 3]),
) {
    if !(d > 0.0 && d.is_finite()) || [v0, v1, v2].iter().flatten().any(|c| !c.is_finite()) {
        return;
    }
    let v0 = DVec3::from_array(v0);
    // glam computes these with numpy's operations: `cross` takes the
    // products of `np.cross` (each the same, as multiplication commutes) and
    // `length` is the sqrt of the squares summed left to right, as
    // `np.linalg.norm(x, axis=-1)`; so the bits match the reference.
    let e1 = DVec3::from_array(v1) - v0;
    let e2 = DVec3::from_array(v2) - v0;
    let l1 = e1.length();
    let l2 = e2.length();
    let a2 = e1.cross(e2).length();
    // A NaN area is dropped too, as by numpy's `area2 > 0` mask.
    if a2.is_nan() || a2 <= 0.0 {
        return;
    }
    let thr = d * (l1 * l2 / a2).sqrt();
    let n1 = (l1 / thr).floor();
    let n2 = (l2 / thr).floor();
    // Beyond 2^52 grid steps `i += 1.0` would stall (and the output could not
    // be stored anyway): such a triangle, only possible for an absurdly small
    // `d`, emits nothing.
    const MAX_STEPS: f64 = 4_503_599_627_370_496.0;
    if !(n1 < MAX_STEPS && n2 < MAX_STEPS) {
        return;
    }
    let m1 = n1.max(1e-7);
    let m2 = n2.max(1e-7);
    let k2_first = 0.5 / m2;
    // `i` and `j` are integers below 2^52 held exactly in f64, as in numpy's
    // float `mgrid`.
    let mut i = 0.0f64;
    while i <= n1 {
        let k1 = (i + 0.5) / m1;
        // k1 + k2 is non-decreasing in both i and j (rounding is monotone), so
        // once the first j fails every later (i, j) fails too.
        if k1 + k2_first >= 1.0 {
            break;
        }
        let mut j = 0.0f64;
        while j <= n2 {
            let k2 = (j + 0.5) / m2;
            if k1 + k2 >= 1.0 {
                break;
            }
            emit((e1 * k1 + e2 * k2 + v0).to_array());
            j += 1.0;
        }
        i += 1.0;
    }
}

/// An estimate (from above, within a small factor) of how many points
/// [`dtu_mesh_points`] makes at spacing `d`: the vertices plus, per face,
/// half the (n1 + 1)·(n2 + 1) grid of [`dtu_upsample`]. Costs one pass over
/// the faces and allocates nothing, so callers can refuse a request that
/// would not fit in memory before sampling (infinite for a non-positive or
/// non-finite `d` with any non-degenerate face).
pub fn dtu_sample_estimate(vertices: &[[f64; 3]], faces: &[[u32; 3]], d: f64) -> f64 {
    let mut total = vertices.len() as f64;
    for f in faces {
        let Some([a, b, c]) = f
            .iter()
            .map(|&i| vertices.get(i as usize).map(|v| DVec3::from_array(*v)))
            .collect::<Option<Vec<_>>>()
            .map(|v| [v[0], v[1], v[2]])
        else {
            continue;
        };
        let (e1, e2) = (b - a, c - a);
        let (l1, l2, a2) = (e1.length(), e2.length(), e1.cross(e2).length());
        if a2.is_nan() || a2 <= 0.0 || a2.is_infinite() {
            continue;
        }
        if !(d > 0.0 && d.is_finite()) {
            return f64::INFINITY;
        }
        let thr = d * (l1 * l2 / a2).sqrt();
        total += ((l1 / thr).floor() + 1.0) * ((l2 / thr).floor() + 1.0) / 2.0;
    }
    total
}

/// Checks that every face index is below `n_vertices`.
fn check_faces(n_vertices: usize, faces: &[[u32; 3]]) -> Result<()> {
    for (f, face) in faces.iter().enumerate() {
        if let Some(&v) = face.iter().find(|&&v| v as usize >= n_vertices) {
            return Err(Error::invalid(format!(
                "face {f} references vertex {v}, but the mesh has {n_vertices} vertices"
            )));
        }
    }
    Ok(())
}

#[inline]
fn corners(vertices: &[[f64; 3]], face: &[u32; 3]) -> [[f64; 3]; 3] {
    [
        vertices[face[0] as usize],
        vertices[face[1] as usize],
        vertices[face[2] as usize],
    ]
}

/// Streams the DTU point set of a mesh to `emit`: every vertex (unreferenced
/// ones included) in vertex order, then the [`dtu_upsample`] points of each
/// face at spacing `d`, in face order — the `np.concatenate([vertices,
/// new_pts])` of DTUeval-python step 2, without materialising it.
///
/// Errors (before anything is emitted) when a face index is out of range.
pub fn dtu_mesh_points_each(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    d: f64,
    mut emit: impl FnMut([f64; 3]),
) -> Result<()> {
    check_faces(vertices.len(), faces)?;
    vertices.iter().for_each(|&v| emit(v));
    for face in faces {
        let [a, b, c] = corners(vertices, face);
        dtu_upsample(a, b, c, d, &mut emit);
    }
    Ok(())
}

/// The DTU point set of a mesh (see [`dtu_mesh_points_each`]): vertices, then
/// the up-sampling points of each face in face order. Single-threaded.
pub fn dtu_mesh_points(vertices: &[[f64; 3]], faces: &[[u32; 3]], d: f64) -> Result<Vec<[f64; 3]>> {
    let mut out = Vec::with_capacity(vertices.len());
    dtu_mesh_points_each(vertices, faces, d, |p| out.push(p))?;
    Ok(out)
}

/// Faces per parallel work item of [`dtu_mesh_points_par_each`].
const PAR_FACE_CHUNK: usize = 4096;
/// Work items processed per parallel round; bounds the buffered samples.
const PAR_ROUND_CHUNKS: usize = 64;

/// Parallel form of [`dtu_mesh_points_each`] with the same output order:
/// faces are split into chunks of 4096, sampled on the rayon pool into
/// per-chunk buffers, and the buffers are emitted in face order, so the result
/// is identical to the serial form whatever the thread count. At most
/// 64 chunks are buffered at a time.
pub fn dtu_mesh_points_par_each(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    d: f64,
    mut emit: impl FnMut([f64; 3]),
) -> Result<()> {
    check_faces(vertices.len(), faces)?;
    vertices.iter().for_each(|&v| emit(v));
    for round in faces.chunks(PAR_FACE_CHUNK * PAR_ROUND_CHUNKS) {
        let buffers: Vec<Vec<[f64; 3]>> = round
            .par_chunks(PAR_FACE_CHUNK)
            .map(|chunk| {
                let mut buf = Vec::new();
                for face in chunk {
                    let [a, b, c] = corners(vertices, face);
                    dtu_upsample(a, b, c, d, |p| buf.push(p));
                }
                buf
            })
            .collect();
        buffers.into_iter().flatten().for_each(&mut emit);
    }
    Ok(())
}

/// Parallel, deterministic form of [`dtu_mesh_points`]: same output, computed
/// on the rayon pool (see [`dtu_mesh_points_par_each`]).
pub fn dtu_mesh_points_par(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    d: f64,
) -> Result<Vec<[f64; 3]>> {
    let mut out = Vec::with_capacity(vertices.len());
    dtu_mesh_points_par_each(vertices, faces, d, |p| out.push(p))?;
    Ok(out)
}

/// Samples per independently seeded block of [`sample_area_uniform_with_faces`].
const UNIFORM_BLOCK: usize = 4096;
/// Largest sample count accepted (2^32), against runaway allocations from a
/// density that does not match the mesh units.
const MAX_UNIFORM_SAMPLES: f64 = 4_294_967_296.0;

/// Face areas (half the cross-product norm); a NaN or infinite area counts as 0.
fn face_areas(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> Vec<f64> {
    faces
        .iter()
        .map(|face| {
            let [a, b, c] = corners(vertices, face).map(DVec3::from_array);
            let area = 0.5 * (b - a).cross(c - a).length();
            if area.is_finite() { area } else { 0.0 }
        })
        .collect()
}

/// Uniform random samples on the surface, `count` of them, each with the
/// index of the face it lies on.
///
/// Each sample picks a face with probability proportional to its area (by
/// bisection in the running sum of areas, accumulated in face order in f64),
/// then a uniform point in it with the square-root trick: with `r1, r2`
/// uniform in [0, 1) and `s = sqrt(r1)`, `p = (1−s)·a + s(1−r2)·b + s·r2·c`.
/// Faces with zero or non-finite area (including any with a non-finite
/// vertex) are never chosen.
///
/// Determinism: sample `k` belongs to block `k / 4096`, and each block draws
/// from its own generator, [`rng::stream`]`(seed, block)`, so the
/// output depends only on the inputs and `seed`, not on the rayon thread count.
///
/// Errors: a face index out of range; `count > 0` on a mesh of zero total
/// area; `count` above 2^32.
pub fn sample_area_uniform_with_faces(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    count: usize,
    seed: u64,
) -> Result<(Vec<[f64; 3]>, Vec<u32>)> {
    check_faces(vertices.len(), faces)?;
    if count as f64 > MAX_UNIFORM_SAMPLES {
        return Err(Error::invalid(format!(
            "{count} surface samples requested; the limit is {MAX_UNIFORM_SAMPLES}"
        )));
    }
    if count == 0 {
        return Ok((Vec::new(), Vec::new()));
    }
    let areas = face_areas(vertices, faces);
    let mut cdf = Vec::with_capacity(areas.len());
    let mut acc = 0.0f64;
    for &a in &areas {
        acc += a;
        cdf.push(acc);
    }
    let total = acc;
    if !(total > 0.0 && total.is_finite()) {
        return Err(Error::invalid(format!(
            "cannot sample {count} points: the mesh's total area is {total}"
        )));
    }
    // Fallback face when rounding makes u reach the total: the last face with area.
    let last_face = areas.iter().rposition(|&a| a > 0.0).unwrap_or(0);
    let mut points = vec![[0.0f64; 3]; count];
    let mut face_ids = vec![0u32; count];
    points
        .par_chunks_mut(UNIFORM_BLOCK)
        .zip(face_ids.par_chunks_mut(UNIFORM_BLOCK))
        .enumerate()
        .for_each(|(block, (pts, ids))| {
            let mut rng = rng::stream(seed, block as u64);
            for (p, id) in pts.iter_mut().zip(ids.iter_mut()) {
                let u = rng.random::<f64>() * total;
                let mut f = cdf.partition_point(|&c| c <= u);
                if f >= faces.len() {
                    f = last_face;
                }
                let [a, b, c] = corners(vertices, &faces[f]);
                let s = rng.random::<f64>().sqrt();
                let r2 = rng.random::<f64>();
                let (wa, wb, wc) = (1.0 - s, s * (1.0 - r2), s * r2);
                *p = [
                    wa * a[0] + wb * b[0] + wc * c[0],
                    wa * a[1] + wb * b[1] + wc * c[1],
                    wa * a[2] + wb * b[2] + wc * c[2],
                ];
                *id = f as u32;
            }
        });
    Ok((points, face_ids))
}

/// `count` uniform random samples on the surface; see
/// [`sample_area_uniform_with_faces`] for the method, determinism and errors.
pub fn sample_area_uniform_count(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    count: usize,
    seed: u64,
) -> Result<Vec<[f64; 3]>> {
    Ok(sample_area_uniform_with_faces(vertices, faces, count, seed)?.0)
}

/// Uniform random samples on the surface at `density_per_unit_area` samples
/// per unit area (per mm² for a mesh in mm): the count is
/// `round(density × total area)`, with the total area summed in face order
/// over faces of finite area. Method, determinism and errors as in
/// [`sample_area_uniform_with_faces`]; a negative or non-finite density is an
/// error.
pub fn sample_area_uniform(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    density_per_unit_area: f64,
    seed: u64,
) -> Result<Vec<[f64; 3]>> {
    if !(density_per_unit_area >= 0.0 && density_per_unit_area.is_finite()) {
        return Err(Error::invalid(format!(
            "sampling density must be a finite number >= 0, got {density_per_unit_area}"
        )));
    }
    check_faces(vertices.len(), faces)?;
    let total: f64 = face_areas(vertices, faces).iter().sum();
    let want = (density_per_unit_area * total).round();
    if want.is_nan() || want > MAX_UNIFORM_SAMPLES {
        return Err(Error::invalid(format!(
            "density {density_per_unit_area} on a total area of {total} asks for {want} samples; \
             the limit is {MAX_UNIFORM_SAMPLES}"
        )));
    }
    sample_area_uniform_count(vertices, faces, want as usize, seed)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The up-sampling estimate bounds the real count from above, within a
    /// factor of 3 (triangles of every shape, spacing from coarse to fine).
    #[test]
    fn dtu_estimate_bounds_the_real_count() {
        let mut rng = crate::model::rng::seeded(5);
        use rand::RngExt;
        for _ in 0..200 {
            let v: Vec<[f64; 3]> = (0..3)
                .map(|_| [0, 1, 2].map(|_| rng.random_range(-10.0..10.0)))
                .collect();
            for d in [0.05, 0.3, 2.0] {
                let real = dtu_mesh_points(&v, &[[0, 1, 2]], d).unwrap().len() as f64;
                let est = dtu_sample_estimate(&v, &[[0, 1, 2]], d);
                assert!(est >= real, "estimate {est} < real {real}");
                assert!(
                    est <= 3.0 * real + 8.0,
                    "estimate {est} far above real {real}"
                );
            }
        }
        assert!(
            dtu_sample_estimate(
                &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                &[[0, 1, 2]],
                0.0
            )
            .is_infinite()
        );
    }

    fn upsample_vec(t: [[f64; 3]; 3], d: f64) -> Vec<[f64; 3]> {
        let mut out = Vec::new();
        dtu_upsample(t[0], t[1], t[2], d, |p| out.push(p));
        out
    }

    /// Order-sensitive FNV-1a-style hash over the coordinate bit patterns.
    fn bits_hash(points: &[[f64; 3]]) -> u64 {
        points
            .iter()
            .flatten()
            .fold(0xcbf2_9ce4_8422_2325u64, |h, x| {
                (h ^ x.to_bits()).wrapping_mul(0x100_0000_01b3)
            })
    }

    #[test]
    fn worked_example_right_isosceles_1mm() {
        // l1 = l2 = 1, A2 = 1, thr = 0.2, n1 = n2 = floor(1/0.2) = 5, so
        // k ∈ {0.1, 0.3, 0.5, 0.7, 0.9, 1.1}. Pairs summing to exactly 1 in
        // reals (0.1+0.9, 0.3+0.7, 0.5+0.5) round to 1.0 and are excluded;
        // the rest below 1, i outer / j inner, are these 10 points (x = k1,
        // y = k2 as e1, e2 are the axes; (i + 0.5)/5 is the nearest double to
        // the decimal literal, so equality is exact).
        let expected = [
            [0.1, 0.1, 0.0],
            [0.1, 0.3, 0.0],
            [0.1, 0.5, 0.0],
            [0.1, 0.7, 0.0],
            [0.3, 0.1, 0.0],
            [0.3, 0.3, 0.0],
            [0.3, 0.5, 0.0],
            [0.5, 0.1, 0.0],
            [0.5, 0.3, 0.0],
            [0.7, 0.1, 0.0],
        ];
        let got = upsample_vec([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 0.2);
        assert_eq!(got, expected);
    }

    #[test]
    fn matches_numpy_reference_bits() {
        // Expected values were produced by running the DTUeval-python
        // sampling expressions (np.mgrid, boolean mask, `v1*k1 + v2*k2 + v0`)
        // in numpy 2.4 on these triangles: the count and a hash of every
        // coordinate's bits in output order, so order and rounding must match.
        let t1 = [
            [10.3, -4.7, 101.9],
            [13.1, -2.2, 99.4],
            [9.05, -1.15, 104.6],
        ];
        let got = upsample_vec(t1, 0.2);
        assert_eq!(got.len(), 253);
        assert_eq!(got[0][0], f64::from_bits(0x4024_ac44_ce6b_41c6)); // 0x1.4ac44ce6b41c6p+3
        assert_eq!(bits_hash(&got), 0xcab6_9482_eed3_4bc4);
        let t2 = [[0.0, 0.0, 0.0], [7.3, 0.1, -0.2], [-1.9, 0.65, 0.3]];
        let got = upsample_vec(t2, 0.2);
        assert_eq!(got.len(), 63);
        assert_eq!(bits_hash(&got), 0x5a0e_4205_927c_6967);
    }

    /// Exact count of half-integer grid points strictly inside
    /// u/n1 + v/n2 < 1 (u = i + ½, v = j + ½), in integers: (2i+1)·n2 +
    /// (2j+1)·n1 < 2·n1·n2. With n1 and n2 of different parity the two sides
    /// never tie (odd vs even), and they differ by at least 1, i.e. k1 + k2
    /// is at least 1/(2·n1·n2) away from 1, far beyond f64 rounding.
    fn lattice_count(n1: i64, n2: i64) -> i64 {
        (0..=n1)
            .map(|i| {
                let rest = 2 * n1 * n2 - (2 * i + 1) * n2 - n1;
                // number of j >= 0 with 2·n1·j < rest
                if rest > 0 {
                    (rest + 2 * n1 - 1) / (2 * n1)
                } else {
                    0
                }
            })
            .sum()
    }

    fn rng(seed: u64) -> rng::Rng {
        rng::seeded(seed)
    }

    fn v(p: [f64; 3]) -> DVec3 {
        DVec3::from_array(p)
    }

    fn random_triangle(r: &mut rng::Rng, scale: f64) -> [[f64; 3]; 3] {
        let mut p = || {
            [
                r.random_range(-scale..scale),
                r.random_range(-scale..scale),
                r.random_range(-scale..scale),
            ]
        };
        [p(), p(), p()]
    }

    /// n1, n2 as the rule computes them (to pick the expected-count formula).
    fn grid_size(t: &[[f64; 3]; 3], d: f64) -> (f64, f64) {
        let e1 = v(t[1]) - v(t[0]);
        let e2 = v(t[2]) - v(t[0]);
        let (l1, l2, a2) = (e1.length(), e2.length(), e1.cross(e2).length());
        let thr = d * (l1 * l2 / a2).sqrt();
        ((l1 / thr).floor(), (l2 / thr).floor())
    }

    #[test]
    fn counts_equal_lattice_count_and_full_grid_scan() {
        let d = 0.2;
        // Right triangles with legs (n + ½)·d: n1, n2 are exactly the chosen n.
        for (n1, n2) in [
            (1, 2),
            (2, 3),
            (4, 7),
            (10, 3),
            (30, 1),
            (1, 1),
            (0, 5),
            (16, 25),
        ] {
            let t = [
                [0.0; 3],
                [(n1 as f64 + 0.5) * d, 0.0, 0.0],
                [0.0, (n2 as f64 + 0.5) * d, 0.0],
            ];
            assert_eq!(grid_size(&t, d), (n1 as f64, n2 as f64));
            let got = upsample_vec(t, d).len() as i64;
            if (n1 + n2) % 2 == 1 {
                assert_eq!(got, lattice_count(n1, n2), "n1={n1} n2={n2}");
            }
            // n1 = n2 = 1: k = 0.5 + 0.5 = 1 is not < 1, so no sample.
            if n1 == 1 && n2 == 1 {
                assert_eq!(got, 0);
            }
            if n1 == 0 {
                assert_eq!(got, 0);
            }
        }
        // Random shapes: every triangle against a scan of the whole grid
        // (no early exit) with the rule's float expressions, and the
        // parity-distinct ones against the exact integer count as well.
        let mut r = rng(7);
        let mut exact_checked = 0;
        for _ in 0..400 {
            let t = random_triangle(&mut r, 3.0);
            let (n1, n2) = grid_size(&t, d);
            let (m1, m2) = (n1.max(1e-7), n2.max(1e-7));
            let mut scan = 0i64;
            for i in 0..=(n1 as i64) {
                for j in 0..=(n2 as i64) {
                    if (i as f64 + 0.5) / m1 + (j as f64 + 0.5) / m2 < 1.0 {
                        scan += 1;
                    }
                }
            }
            let got = upsample_vec(t, d).len() as i64;
            assert_eq!(got, scan);
            if (n1 as i64 + n2 as i64) % 2 == 1 {
                assert_eq!(got, lattice_count(n1 as i64, n2 as i64));
                exact_checked += 1;
            }
        }
        assert!(
            exact_checked > 100,
            "only {exact_checked} parity-distinct triangles"
        );
    }

    #[test]
    fn samples_lie_inside_their_triangle() {
        let mut r = rng(11);
        for _ in 0..200 {
            let t = random_triangle(&mut r, 2.0);
            let (e1, e2) = (v(t[1]) - v(t[0]), v(t[2]) - v(t[0]));
            for p in upsample_vec(t, 0.2) {
                // Solve p − v0 = a·e1 + b·e2 by the 2×2 normal equations.
                let q = v(p) - v(t[0]);
                let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                let (b1, b2) = (q.dot(e1), q.dot(e2));
                let det = g11 * g22 - g12 * g12;
                let a = (b1 * g22 - b2 * g12) / det;
                let b = (b2 * g11 - b1 * g12) / det;
                // Samples sit at k >= ½/n > 0 with k1 + k2 < 1; 1e-9 absorbs
                // the solve's rounding on these well-scaled triangles.
                assert!(a > -1e-9 && b > -1e-9 && a + b < 1.0 + 1e-9, "{a} {b}");
            }
        }
    }

    /// Number of exact ties: grid points with (i+½)/n1 + (j+½)/n2 = 1 in
    /// reals, i.e. (2i+1)·n2 + (2j+1)·n1 = 2·n1·n2, counted in integers.
    fn tie_count(n1: i64, n2: i64) -> i64 {
        (0..n1)
            .filter(|&i| {
                let rest = 2 * n1 * n2 - (2 * i + 1) * n2;
                rest > 0 && rest % n1 == 0 && (rest / n1) % 2 == 1
            })
            .count() as i64
    }

    #[test]
    fn count_is_half_grid_minus_ties_and_density_matches_derivation() {
        // Derivation. Only i < n1, j < n2 can qualify (otherwise k1 or k2
        // >= 1 + ½/n). The point reflection (i, j) -> (n1−1−i, n2−1−j) swaps
        // the sides of the line k1 + k2 = 1 in reals, so with T exact ties
        // the points strictly below number (n1·n2 − T)/2. Ties never pass the
        // float test: with a + b = 1, a <= ½, fl(a) + fl(b) lies within
        // 2^-54 of 1 (fl(b) is the rounding of 1 − fl(a) + (a − fl(a)), and
        // 1 − fl(a) is on a grid finer than fl(b)'s), and such a sum rounds
        // to 1.0 (ties to even). Hence count = (n1·n2 − T)/2 exactly.
        //
        // Density: x = l1/thr, y = l2/thr satisfy x·y = A2/d² = 2A/d², so
        // n1·n2/2 = (A/d²)·c with c = ⌊x⌋⌊y⌋/(x·y) <= 1: the rate is 1/d²
        // (25 per mm² at d = 0.2) times c, minus T/2 per triangle. With the
        // fractional parts of x and y roughly uniform, E[c] ≈ (1 − 1/(2x))·
        // (1 − 1/(2y)).
        let d = 0.2;
        let mut r = rng(3);
        let (mut count, mut area, mut approx) = (0i64, 0.0, 0.0);
        for _ in 0..2000 {
            let t = random_triangle(&mut r, 2.0);
            let (n1, n2) = grid_size(&t, d);
            let (a, b) = (n1 as i64, n2 as i64);
            let got = upsample_vec(t, d).len() as i64;
            let ties = tie_count(a, b);
            assert_eq!(2 * got, a * b - ties, "n1={a} n2={b} ties={ties}");
            count += got;
            let e1 = v(t[1]) - v(t[0]);
            let e2 = v(t[2]) - v(t[0]);
            let tri_area = 0.5 * e1.cross(e2).length();
            let thr = d * (e1.length() * e2.length() / (2.0 * tri_area)).sqrt();
            let (x, y) = (e1.length() / thr, e2.length() / thr);
            area += tri_area;
            approx += tri_area / (d * d) * (1.0 - 0.5 / x) * (1.0 - 0.5 / y) - ties as f64 / 2.0;
        }
        let density = count as f64 / area;
        // The approximation only replaces ⌊x⌋/x by its average over the
        // fractional part; over 2000 triangles with x, y of order 10 the
        // residual averages out to well under 1% (measured 0.13%; mean density 22.6 per mm²).
        assert!(
            (count as f64 - approx).abs() < 0.01 * approx,
            "count {count} approx {approx} density {density}"
        );
        assert!(density < 25.0, "density {density}");
    }

    #[test]
    fn degenerate_and_non_finite_emit_nothing() {
        let z = [0.0; 3];
        // Collinear: A2 = 0.
        assert!(upsample_vec([z, [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], 0.2).is_empty());
        // Repeated vertex.
        assert!(upsample_vec([z, z, [0.0, 1.0, 0.0]], 0.2).is_empty());
        let good = [z, [3.0, 0.0, 0.0], [0.0, 3.0, 0.0]];
        assert!(!upsample_vec(good, 0.2).is_empty());
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for k in 0..3 {
                let mut t = good;
                t[k][1] = bad;
                assert!(upsample_vec(t, 0.2).is_empty());
            }
            assert!(upsample_vec(good, bad).is_empty());
        }
        assert!(upsample_vec(good, 0.0).is_empty());
        assert!(upsample_vec(good, -0.2).is_empty());
        // A tiny d on a unit triangle would need ~10^31 steps: refused.
        assert!(upsample_vec(good, 1e-16).is_empty());
    }

    fn random_mesh(
        r: &mut rng::Rng,
        nv: usize,
        nf: usize,
        scale: f64,
    ) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let vertices = (0..nv)
            .map(|_| {
                [
                    r.random_range(-scale..scale),
                    r.random_range(-scale..scale),
                    r.random_range(-scale..scale),
                ]
            })
            .collect();
        // Faces use only the first nv − 2 vertices, so two are unreferenced.
        let faces = (0..nf)
            .map(|_| {
                [
                    r.random_range(0..nv as u32 - 2),
                    r.random_range(0..nv as u32 - 2),
                    r.random_range(0..nv as u32 - 2),
                ]
            })
            .collect();
        (vertices, faces)
    }

    #[test]
    fn mesh_points_are_vertices_then_samples_in_face_order() {
        let mut r = rng(5);
        let (v, f) = random_mesh(&mut r, 40, 60, 1.5);
        let got = dtu_mesh_points(&v, &f, 0.2).unwrap();
        let mut expected = v.clone();
        for face in &f {
            let t = [
                v[face[0] as usize],
                v[face[1] as usize],
                v[face[2] as usize],
            ];
            expected.extend(upsample_vec(t, 0.2));
        }
        assert!(expected.len() > v.len() + 100);
        assert_eq!(got, expected);
        let mut streamed = Vec::new();
        dtu_mesh_points_each(&v, &f, 0.2, |p| streamed.push(p)).unwrap();
        assert_eq!(streamed, expected);
    }

    #[test]
    fn parallel_form_equals_serial_across_chunks_and_rounds() {
        // More faces than one parallel round (4096 · 64), small triangles of
        // a few samples each, on a 2-thread and a 1-thread pool.
        let mut r = rng(9);
        let nf = PAR_FACE_CHUNK * PAR_ROUND_CHUNKS + 5000;
        let (v, f) = random_mesh(&mut r, 3000, nf, 0.8);
        let serial = dtu_mesh_points(&v, &f, 0.2).unwrap();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let par = pool.install(|| dtu_mesh_points_par(&v, &f, 0.2)).unwrap();
            assert_eq!(par, serial, "{threads} threads");
        }
    }

    #[test]
    fn out_of_range_face_is_an_error_naming_it() {
        let v = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let f = vec![[0, 1, 2], [0, 3, 1]];
        let msg = dtu_mesh_points(&v, &f, 0.2).unwrap_err().to_string();
        assert!(msg.contains("face 1") && msg.contains("vertex 3"), "{msg}");
        assert!(dtu_mesh_points_par(&v, &f, 0.2).is_err());
        assert!(sample_area_uniform_count(&v, &f, 10, 1).is_err());
        assert!(sample_area_uniform(&v, &f, 1.0, 1).is_err());
        let mut n = 0;
        assert!(dtu_mesh_points_each(&v, &f, 0.2, |_| n += 1).is_err());
        assert_eq!(n, 0, "nothing is emitted before the error");
    }

    /// Barycentric coordinates (wa, wb, wc) of `p` in triangle `t` and the
    /// distance of `p` from the triangle's plane.
    fn barycentric(t: &[[f64; 3]; 3], p: [f64; 3]) -> ([f64; 3], f64) {
        let (e1, e2) = (v(t[1]) - v(t[0]), v(t[2]) - v(t[0]));
        let n = e1.cross(e2);
        let q = v(p) - v(t[0]);
        let nn = n.length_squared();
        let plane = q.dot(n) / nn.sqrt();
        let wb = q.cross(e2).dot(n) / nn;
        let wc = e1.cross(q).dot(n) / nn;
        ([1.0 - wb - wc, wb, wc], plane)
    }

    #[test]
    fn uniform_samples_on_mesh_area_proportional_and_thread_independent() {
        // Five triangles of very different areas in general position, plus a
        // degenerate one that must never be chosen.
        let v = vec![
            [0.0, 0.0, 0.0],
            [4.0, 0.0, 1.0],
            [0.0, 3.0, -1.0],
            [5.0, 5.0, 5.0],
            [5.5, 5.2, 4.0],
            [4.1, 6.3, 5.5],
            [-3.0, 1.0, 2.0],
            [-3.0, 1.0, 2.0],
            [-1.0, -2.0, 0.5],
            [10.0, -4.0, 3.0],
        ];
        let f = vec![
            [0, 1, 2],
            [3, 4, 5],
            [6, 7, 8],
            [0, 8, 9],
            [1, 3, 9],
            [2, 5, 6],
        ];
        let areas = face_areas(&v, &f);
        assert_eq!(areas[2], 0.0);
        let total: f64 = areas.iter().sum();
        let n = 200_000;
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let (pts, ids) = one
            .install(|| sample_area_uniform_with_faces(&v, &f, n, 42))
            .unwrap();
        let (pts2, ids2) = two
            .install(|| sample_area_uniform_with_faces(&v, &f, n, 42))
            .unwrap();
        assert_eq!(pts, pts2);
        assert_eq!(ids, ids2);
        let other = sample_area_uniform_count(&v, &f, n, 43).unwrap();
        assert_ne!(other, pts);
        assert_eq!(sample_area_uniform_count(&v, &f, n, 42).unwrap(), pts);

        let mut per_face = vec![0usize; f.len()];
        let mut near_a = 0usize;
        for (p, &id) in pts.iter().zip(&ids) {
            let face = f[id as usize];
            let t = [
                v[face[0] as usize],
                v[face[1] as usize],
                v[face[2] as usize],
            ];
            let (w, plane) = barycentric(&t, *p);
            // Coordinates are O(10), so rounding in the sample and in this
            // check is O(1e-15); 1e-12 leaves margin.
            assert!(plane.abs() < 1e-12, "plane distance {plane}");
            assert!(w.iter().all(|&x| x > -1e-12), "outside: {w:?}");
            per_face[id as usize] += 1;
            if w[0] >= 0.5 {
                near_a += 1;
            }
        }
        // Binomial: count_f ~ Bin(n, A_f/A); 5σ bound (two-sided tail 6e-7
        // per face for a random seed; the seed here is fixed).
        for (k, (&c, &a)) in per_face.iter().zip(&areas).enumerate() {
            let p = a / total;
            let sigma = (n as f64 * p * (1.0 - p)).sqrt();
            assert!(
                (c as f64 - n as f64 * p).abs() <= 5.0 * sigma,
                "face {k}: {c} vs {}",
                n as f64 * p
            );
        }
        assert_eq!(per_face[2], 0);
        // Uniformity inside a triangle: the region with weight(a) >= ½ is the
        // corner triangle scaled by ½, a quarter of the area: Bin(n, ¼), 5σ.
        let sigma = (n as f64 * 0.25 * 0.75).sqrt();
        assert!(
            (near_a as f64 - 0.25 * n as f64).abs() <= 5.0 * sigma,
            "{near_a}"
        );
    }

    #[test]
    fn uniform_density_count_and_errors() {
        let v = vec![[0.0; 3], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]];
        let f = vec![[0, 1, 2]];
        // Area 3: density 10 → 30 samples; 0.1 → round(0.3) = 0.
        assert_eq!(sample_area_uniform(&v, &f, 10.0, 1).unwrap().len(), 30);
        assert!(sample_area_uniform(&v, &f, 0.1, 1).unwrap().is_empty());
        assert!(sample_area_uniform(&v, &f, -1.0, 1).is_err());
        assert!(sample_area_uniform(&v, &f, f64::NAN, 1).is_err());
        assert!(sample_area_uniform(&v, &f, 1e300, 1).is_err());
        // Zero-area mesh: no samples possible.
        let flat = vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert!(sample_area_uniform_count(&flat, &f, 5, 1).is_err());
        assert!(
            sample_area_uniform_count(&flat, &f, 0, 1)
                .unwrap()
                .is_empty()
        );
        assert!(sample_area_uniform(&flat, &f, 10.0, 1).unwrap().is_empty());
    }
}
