//! The opacity entropy loss of SuGaR's iterations 7000–9000.

/// Mean binary entropy of the opacities, `(1/n) Σ −α ln α − (1−α) ln(1−α)`
/// with α = sigmoid(logit) (nats; 0 for α ∈ {0, 1}, ln 2 at α = ½), and its
/// gradient with respect to the logits, `−x·α(1−α)/n` (since
/// dH/dα = ln((1−α)/α) = −x). Computed in f64 through softplus, so it stays
/// finite for any finite logit. An empty slice gives (0, []).
pub fn entropy(opacity_logits: &[f32]) -> (f64, Vec<f32>) {
    let n = opacity_logits.len();
    if n == 0 {
        return (0.0, Vec::new());
    }
    let inv = 1.0 / n as f64;
    let mut sum = 0.0;
    let grad = opacity_logits
        .iter()
        .map(|&x| {
            let x = x as f64;
            let a = sigmoid(x);
            // −ln α = softplus(−x), −ln(1−α) = softplus(x)
            sum += a * softplus(-x) + (1.0 - a) * softplus(x);
            (-x * a * (1.0 - a) * inv) as f32
        })
        .collect();
    (sum * inv, grad)
}

pub(super) fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// ln(1 + eˣ), stable for large |x|.
fn softplus(x: f64) -> f64 {
    x.max(0.0) + (-x.abs()).exp().ln_1p()
}
