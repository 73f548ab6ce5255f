//! SuGaR's coarse-stage prune as a [`Strategy`]: once, after reference
//! iteration 9,000 (between the opacity-entropy phase and the surface
//! regulariser), every Gaussian of opacity below 0.5 is removed — unless
//! that would remove them all (a run too short to recover from its last
//! opacity reset keeps everything). It keeps no state.

use crate::model::Gaussians;
use crate::train::groups::kept;
use crate::train::strategy::{Edit, Moments, StepContext, Strategy};

/// The prune of SuGaR's coarse stage (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct SugarPrune {
    /// The iteration after which it prunes (reference 9,000, scaled).
    pub at: u64,
}

impl Strategy<Gaussians> for SugarPrune {
    fn name(&self) -> &'static str {
        "sugar"
    }

    fn edit(&mut self, ctx: StepContext, g: &mut Gaussians) -> Vec<Edit> {
        if ctx.iteration != self.at {
            return Vec::new();
        }
        // α ≥ 0.5 ⇔ logit ≥ 0
        let mut keep: Vec<bool> = g.opacity_logits.iter().map(|&o| o >= 0.0).collect();
        let detail = if keep.contains(&true) {
            "opacity < 0.5 removed".to_string()
        } else {
            keep.fill(true);
            "every opacity < 0.5: all kept".to_string()
        };
        let idx: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
        *g = g.gather(&idx);
        vec![Edit {
            kind: "prune",
            detail,
            moments: Moments::Remap(kept(&keep)),
        }]
    }
}
