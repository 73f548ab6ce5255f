//! Adam over a flat parameter buffer with per-group learning rates and the
//! 3DGS exponential (log-linear) schedule.

use std::ops::Range;

use rayon::prelude::*;

/// Elements per parallel task of [`Adam::step`].
const CHUNK: usize = 1 << 14;

/// A learning rate that may change with the step.
#[derive(Clone, Copy, Debug)]
pub enum LrSchedule {
    Constant(f64),
    /// exp((1 − t)·ln(init) + t·ln(end)), t = min(step / steps, 1): the
    /// `get_expon_lr_func` of 3DGS without its delay.
    Exponential {
        init: f64,
        end: f64,
        steps: u64,
    },
}

impl LrSchedule {
    /// The learning rate at `step` (0-based).
    pub fn at(&self, step: u64) -> f64 {
        match *self {
            LrSchedule::Constant(v) => v,
            LrSchedule::Exponential { init, end, steps } => {
                let t = (step as f64 / steps.max(1) as f64).clamp(0.0, 1.0);
                ((1.0 - t) * init.ln() + t * end.ln()).exp()
            }
        }
    }
}

/// A slice of the flat buffer with its own learning rate.
#[derive(Clone, Debug)]
pub struct ParamGroup {
    pub name: String,
    pub range: Range<usize>,
    pub lr: LrSchedule,
}

/// Adam (Kingma & Ba) with bias correction; β1 0.9, β2 0.999 and ε 1e-15 as
/// 3DGS and Triangle Splatting use.
#[derive(Clone, Debug)]
pub struct Adam {
    pub groups: Vec<ParamGroup>,
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
    m: Vec<f32>,
    v: Vec<f32>,
    step: u64,
}

impl Adam {
    /// An optimiser for a buffer of `len` parameters.
    pub fn new(len: usize, groups: Vec<ParamGroup>) -> Self {
        Adam {
            groups,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-15,
            m: vec![0.0; len],
            v: vec![0.0; len],
            step: 0,
        }
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        self.step
    }

    /// The first and second moment buffers (for checkpoints).
    pub fn moments(&self) -> (&[f32], &[f32]) {
        (&self.m, &self.v)
    }

    /// Restores a checkpointed state: moments of the buffer's length and the
    /// step count; `Err` when the lengths disagree.
    pub fn restore(&mut self, m: Vec<f32>, v: Vec<f32>, step: u64) -> Result<(), String> {
        if m.len() != self.m.len() || v.len() != self.v.len() {
            return Err(format!(
                "optimiser state holds {} / {} moments, the model needs {}",
                m.len(),
                v.len(),
                self.m.len()
            ));
        }
        self.m = m;
        self.v = v;
        self.step = step;
        Ok(())
    }

    /// One update of `params` with `grads` (same length as at creation),
    /// in parallel over chunks (element-wise: the result does not depend on
    /// the thread count).
    pub fn step(&mut self, params: &mut [f32], grads: &[f32]) {
        assert_eq!(params.len(), self.m.len(), "parameter buffer changed size");
        assert_eq!(
            grads.len(),
            self.m.len(),
            "gradient buffer of the wrong size"
        );
        let t = self.step + 1;
        let bc1 = 1.0 - self.beta1.powi(t as i32);
        let bc2 = 1.0 - self.beta2.powi(t as i32);
        for g in &self.groups {
            let lr = g.lr.at(self.step);
            let step_size = (lr / bc1) as f32;
            let (b1, b2) = (self.beta1 as f32, self.beta2 as f32);
            let sb2 = bc2.sqrt() as f32;
            let eps = self.eps as f32;
            let r = g.range.clone();
            // element-wise, so the parallel split cannot change a result
            params[r.clone()]
                .par_chunks_mut(CHUNK)
                .zip(grads[r.clone()].par_chunks(CHUNK))
                .zip(self.m[r.clone()].par_chunks_mut(CHUNK))
                .zip(self.v[r].par_chunks_mut(CHUNK))
                .for_each(|(((p, gr), m), v)| {
                    for (((p, &gi), m), v) in p.iter_mut().zip(gr).zip(m).zip(v) {
                        *m = b1 * *m + (1.0 - b1) * gi;
                        *v = b2 * *v + (1.0 - b2) * gi * gi;
                        *p -= step_size * *m / (v.sqrt() / sb2 + eps);
                    }
                });
        }
        self.step = t;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The schedule hits its ends and is log-linear between them.
    #[test]
    fn exponential_schedule() {
        let s = LrSchedule::Exponential {
            init: 1e-2,
            end: 1e-4,
            steps: 100,
        };
        assert!((s.at(0) - 1e-2).abs() < 1e-15);
        assert!((s.at(50) - 1e-3).abs() < 1e-12);
        assert!((s.at(100) - 1e-4).abs() < 1e-15);
        assert!((s.at(1000) - 1e-4).abs() < 1e-15);
    }

    /// The first Adam step moves every parameter by lr·sign(g) (bias
    /// correction makes m̂/√v̂ = g/|g|); Adam minimises a quadratic.
    #[test]
    fn first_step_and_convergence() {
        let mut p = vec![1.0f32, -2.0, 3.0];
        let groups = vec![
            ParamGroup {
                name: "a".into(),
                range: 0..2,
                lr: LrSchedule::Constant(0.1),
            },
            ParamGroup {
                name: "b".into(),
                range: 2..3,
                lr: LrSchedule::Constant(0.01),
            },
        ];
        let mut adam = Adam::new(3, groups);
        let g: Vec<f32> = p.iter().map(|v| 2.0 * v).collect();
        adam.step(&mut p, &g);
        assert!((p[0] - 0.9).abs() < 1e-6 && (p[1] + 1.9).abs() < 1e-6);
        assert!((p[2] - 2.99).abs() < 1e-6);
        for _ in 0..2000 {
            let g: Vec<f32> = p.iter().map(|v| 2.0 * v).collect();
            adam.step(&mut p, &g);
        }
        assert!(p[0].abs() < 1e-2 && p[1].abs() < 1e-2, "{p:?}");
    }
}
