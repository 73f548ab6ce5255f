//! Uniform B-splines of degree 1 (the FEM basis) and degree 2 (the normal
//! field and the density kernel), and the 1-D Galerkin integrals the solver
//! needs, all in cell units of one level (a level-ℓ cell has width
//! h = 2^-ℓ of the unit cube; physical integrals are these times powers of h).
//!
//! Conventions:
//! - degree 1 ("hat") functions are centred on nodes (cell corners) with
//!   support [-1, 1];
//! - degree 2 functions are centred on cell centres, support [-1.5, 1.5],
//!   value-normalised (peak 0.75) so that they sum to one and integrate to one;
//! - integrals are restricted to the domain [0, 2^ℓ] (Neumann boundary: the
//!   basis is folded at the cube faces), which only changes rows of nodes on
//!   the cube boundary. [`NodeSide`] says which part of a hat lies inside.

/// Degree-1 B-spline (hat) centred at 0.
#[inline]
pub fn b1(u: f64) -> f64 {
    (1.0 - u.abs()).max(0.0)
}

/// Derivative of [`b1`] (0 outside the support, ±1 inside).
#[inline]
pub fn db1(u: f64) -> f64 {
    if u <= -1.0 || u >= 1.0 || u == 0.0 {
        0.0
    } else if u < 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Degree-2 B-spline centred at 0.
#[inline]
pub fn b2(u: f64) -> f64 {
    let a = u.abs();
    if a <= 0.5 {
        0.75 - a * a
    } else if a < 1.5 {
        let t = 1.5 - a;
        0.5 * t * t
    } else {
        0.0
    }
}

/// The three degree-2 weights of the cells `i-1, i, i+1` around a point at
/// cell coordinate `t` (in cell units of its level), with `i = floor(t)`.
/// They sum to one.
#[inline]
pub fn b2_weights(t: f64) -> (i32, [f64; 3]) {
    let i = t.floor();
    let f = t - i; // in [0, 1)
    // distances to the centres of cells i-1, i, i+1
    let w = [b2(f + 0.5), b2(f - 0.5), b2(f - 1.5)];
    (i as i32, w)
}

/// Which part of a node's hat lies in the domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeSide {
    /// Node 0: only u ∈ [0, 1] is inside.
    Low = 0,
    /// Interior node: the whole support.
    Interior = 1,
    /// Node 2^ℓ: only u ∈ [-1, 0] is inside.
    High = 2,
}

impl NodeSide {
    /// The side of node `n` on a level with `res` cells per axis.
    #[inline]
    pub fn of(n: i32, res: i32) -> NodeSide {
        if n <= 0 {
            NodeSide::Low
        } else if n >= res {
            NodeSide::High
        } else {
            NodeSide::Interior
        }
    }

    fn range(self) -> (f64, f64) {
        match self {
            NodeSide::Low => (0.0, 1.0),
            NodeSide::Interior => (-1.0, 1.0),
            NodeSide::High => (-1.0, 0.0),
        }
    }
}

/// ∫ f over [lo, hi], f piecewise polynomial of degree ≤ 5 with breaks on
/// multiples of 1/2: 3-point Gauss–Legendre on each half-unit piece (exact).
fn integrate(lo: f64, hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    const X: [f64; 3] = [-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4];
    const W: [f64; 3] = [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0];
    let n = ((hi - lo) / 0.5).round() as usize;
    let mut s = 0.0;
    for k in 0..n {
        let a = lo + 0.5 * k as f64;
        let c = a + 0.25;
        for q in 0..3 {
            s += W[q] * 0.25 * f(c + 0.25 * X[q]);
        }
    }
    s
}

/// 1-D tables, indexed `[side][offset]`.
#[derive(Clone, Debug)]
pub struct Tables {
    /// Mass ⟨b1_n, b1_{n+o}⟩ for o = -1, 0, 1 (index o+1), cell units.
    pub mass: [[f64; 3]; 3],
    /// Stiffness ⟨b1'_n, b1'_{n+o}⟩ for o = -1, 0, 1.
    pub stiff: [[f64; 3]; 3],
    /// ⟨b1_n, b2_{cell n+δ}⟩ for δ = -2..=1 (index δ+2).
    pub val: [[f64; 4]; 3],
    /// ⟨b1'_n, b2_{cell n+δ}⟩ for δ = -2..=1.
    pub der: [[f64; 4]; 3],
}

impl Tables {
    /// Computes the tables by exact quadrature.
    pub fn new() -> Self {
        let mut t = Tables {
            mass: [[0.0; 3]; 3],
            stiff: [[0.0; 3]; 3],
            val: [[0.0; 4]; 3],
            der: [[0.0; 4]; 3],
        };
        for side in [NodeSide::Low, NodeSide::Interior, NodeSide::High] {
            let (lo, hi) = side.range();
            let s = side as usize;
            for o in -1i32..=1 {
                let of = o as f64;
                t.mass[s][(o + 1) as usize] = integrate(lo, hi, |u| b1(u) * b1(u - of));
                t.stiff[s][(o + 1) as usize] = integrate(lo, hi, |u| db1(u) * db1(u - of));
            }
            for d in -2i32..=1 {
                let c = d as f64 + 0.5;
                t.val[s][(d + 2) as usize] = integrate(lo, hi, |u| b1(u) * b2(u - c));
                t.der[s][(d + 2) as usize] = integrate(lo, hi, |u| db1(u) * b2(u - c));
            }
        }
        // Neighbours outside the domain do not exist.
        t.mass[NodeSide::Low as usize][0] = 0.0;
        t.stiff[NodeSide::Low as usize][0] = 0.0;
        t.mass[NodeSide::High as usize][2] = 0.0;
        t.stiff[NodeSide::High as usize][2] = 0.0;
        t
    }
}

impl Default for Tables {
    fn default() -> Self {
        Self::new()
    }
}

/// The density-kernel normaliser: Σ_j b2(½ − c_j)², what splatting a
/// co-dimension-1 sheet with one sample per cell area through cell centres
/// and evaluating on the sheet gives. Dividing splatted weights by it makes
/// such a sheet read one "sample per node". This is the rule of Open3D 0.20's
/// PoissonRecon (`GetScaleValue`, the degree-2 values at the centre, 0.59375);
/// PoissonRecon 18.x averages the sheet over offsets inside the cell instead
/// (0.55), which reads 8 % more samples per node (depth estimates 0.055
/// higher) and splats more samples one level finer: 25 % more vertices than
/// Open3D on the Stanford bunny at depth 9 (docs/poisson.md).
pub fn kernel_scale() -> f64 {
    let (_, w) = b2_weights(0.5);
    w.iter().map(|x| x * x).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interior_tables_match_closed_forms() {
        // Degree-1 Galerkin integrals are M = (1/6, 2/3, 1/6), K = (-1, 2, -1).
        let t = Tables::new();
        let i = NodeSide::Interior as usize;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(t.mass[i][1], 2.0 / 3.0) && close(t.mass[i][0], 1.0 / 6.0));
        assert!(close(t.stiff[i][1], 2.0) && close(t.stiff[i][2], -1.0));
        // Boundary halves: M = 1/3, K = 1 on the diagonal.
        let l = NodeSide::Low as usize;
        assert!(close(t.mass[l][1], 1.0 / 3.0) && close(t.stiff[l][1], 1.0));
        // The hat integrates to 1 and b2 is a partition of unity: Σ_δ val = 1.
        assert!(close(t.val[i].iter().sum::<f64>(), 1.0));
        // ∫ b1' · (Σ b2) = ∫ b1' = 0.
        assert!(close(t.der[i].iter().sum::<f64>(), 0.0));
        // Antisymmetry of the derivative table about the node.
        assert!(close(t.der[i][0], -t.der[i][3]) && close(t.der[i][1], -t.der[i][2]));
    }

    #[test]
    fn b2_weights_partition_of_unity() {
        for k in 0..50 {
            let t = -3.0 + k as f64 * 0.137;
            let (_, w) = b2_weights(t);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
        // At the cell centre the weights are (1/8, 3/4, 1/8): Σ b2² = 19/32.
        assert!(
            (kernel_scale() - 19.0 / 32.0).abs() < 1e-15,
            "{}",
            kernel_scale()
        );
    }
}
