//! The precision/recall plot of a TnT evaluation ([`super::evaluate_tnt`]),
//! rasterised as 8-bit RGB; writing it as a PNG file is `io::image`'s job.

use super::TntReport;

/// An 8-bit RGB raster of [`plot_pr_curves`]: row-major, 3 bytes (R, G, B)
/// per pixel, `width × height × 3` bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PrPlot {
    /// Width in pixels (640).
    pub width: usize,
    /// Height in pixels (480).
    pub height: usize,
    /// The pixels, row by row from the top.
    pub rgb: Vec<u8>,
}

/// Plot size in pixels.
const PLOT_W: u32 = 640;
const PLOT_H: u32 = 480;
/// Margins of the plot area: left, right, top, bottom.
const MARGIN: (u32, u32, u32, u32) = (48, 16, 16, 40);

/// Pixel column of distance `x` (x axis spans [0, x_max]).
fn plot_x(x: f64, x_max: f64) -> f64 {
    let (l, r, _, _) = MARGIN;
    l as f64 + x / x_max * (PLOT_W - l - r) as f64
}

/// Pixel row of fraction `y` (0 at the bottom, 1 at the top).
fn plot_y(y: f64) -> f64 {
    let (_, _, t, b) = MARGIN;
    (PLOT_H - b) as f64 - y * (PLOT_H - t - b) as f64
}

/// Draws the precision and recall curves of `report` as a 640×480 RGB image,
/// like the toolbox's `PR_<Scene>_@d_th_0_<τ>.png` without text:
/// white background, light grey (220, 220, 220) grid lines every 10 % and
/// every τ, black axes; the **precision** curve (`cum_precision` against
/// `bin_edges[1..]`) in **red** (255, 0, 0), the **recall** curve in **blue**
/// (0, 0, 255), both 2 px wide; a **black dashed** vertical line at τ. The
/// x axis spans [0, plot_stretch·τ] (the last bin edge plus one step), the y
/// axis [0, 100 %].
pub fn plot_pr_curves(report: &TntReport) -> PrPlot {
    let (wd, ht) = (PLOT_W as usize, PLOT_H as usize);
    let mut img = vec![255u8; wd * ht * 3];
    let tau = report.tau;
    let step = tau / 100.0;
    let x_max = match report.bin_edges.last() {
        Some(&e) if report.bin_edges.len() > 1 => e + step,
        _ => 5.0 * tau,
    };
    let put = |img: &mut [u8], x: i64, y: i64, c: [u8; 3]| {
        if x >= 0 && y >= 0 && (x as usize) < wd && (y as usize) < ht {
            let o = (y as usize * wd + x as usize) * 3;
            img[o..o + 3].copy_from_slice(&c);
        }
    };
    let (l, r, t, b) = MARGIN;
    let (x0, x1, y0, y1) = (l as i64, (PLOT_W - r) as i64, t as i64, (PLOT_H - b) as i64);
    let grey = [220, 220, 220];
    for k in 1..10 {
        let y = plot_y(k as f64 / 10.0).round() as i64;
        for x in x0..=x1 {
            put(&mut img, x, y, grey);
        }
    }
    let mut gx = tau;
    while gx < x_max {
        let x = plot_x(gx, x_max).round() as i64;
        for y in y0..=y1 {
            put(&mut img, x, y, grey);
        }
        gx += tau;
    }
    let segment = |img: &mut [u8], a: (f64, f64), bpt: (f64, f64), c: [u8; 3]| {
        let len = ((bpt.0 - a.0).powi(2) + (bpt.1 - a.1).powi(2)).sqrt();
        let n = (len * 4.0).ceil().max(1.0) as usize;
        for i in 0..=n {
            let f = i as f64 / n as f64;
            let (x, y) = (a.0 + f * (bpt.0 - a.0), a.1 + f * (bpt.1 - a.1));
            // A 2×2 stamp centred on the sample.
            let (xi, yi) = ((x - 0.5).floor() as i64, (y - 0.5).floor() as i64);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                put(img, xi + dx, yi + dy, c);
            }
        }
    };
    if report.bin_edges.len() >= 2 {
        for (curve, colour) in [
            (&report.cum_precision, [255, 0, 0]),
            (&report.cum_recall, [0, 0, 255]),
        ] {
            let pts: Vec<(f64, f64)> = report.bin_edges[1..]
                .iter()
                .zip(curve.iter())
                .map(|(&x, &y)| (plot_x(x, x_max), plot_y(y.clamp(0.0, 1.0))))
                .collect();
            for pair in pts.windows(2) {
                segment(&mut img, pair[0], pair[1], colour);
            }
            if let [only] = pts[..] {
                segment(&mut img, only, only, colour);
            }
        }
    }
    let xt = plot_x(tau, x_max).round() as i64;
    for y in y0..=y1 {
        if (y - y0) % 12 < 7 {
            put(&mut img, xt, y, [0, 0, 0]);
            put(&mut img, xt + 1, y, [0, 0, 0]);
        }
    }
    for x in x0..=x1 {
        put(&mut img, x, y1, [0, 0, 0]);
    }
    for y in y0..=y1 {
        put(&mut img, x0, y, [0, 0, 0]);
    }
    PrPlot {
        width: wd,
        height: ht,
        rgb: img,
    }
}

#[cfg(test)]
mod tests {
    use super::super::histogram_edges;
    use super::*;
    use glam::DMat4;

    /// The plot is a 640×480 RGB raster with the curves where the
    /// documented colours and axis mapping put them.
    #[test]
    fn plot_draws_curves_at_their_places() {
        let tau = 0.01;
        let edges = histogram_edges(tau, 5.0);
        // Precision: 25 % below 2τ, 75 % above; recall: 50 % throughout.
        let cum_precision: Vec<f64> = edges[1..]
            .iter()
            .map(|&x| if x < 2.0 * tau { 0.25 } else { 0.75 })
            .collect();
        let cum_recall = vec![0.5; edges.len() - 1];
        let report = TntReport {
            tau,
            precision: 0.25,
            recall: 0.5,
            fscore: 1.0 / 3.0,
            transformation: DMat4::IDENTITY,
            trajectory_transformation: DMat4::IDENTITY,
            trajectory_fitness: 1.0,
            trajectory_rmse: 0.0,
            refinement: Vec::new(),
            source_points: 1,
            target_points: 1,
            source_within_tau: 0,
            target_within_tau: 0,
            bin_edges: edges,
            cum_precision,
            cum_recall,
            source_eval_points: Vec::new(),
            source_distances: Vec::new(),
            target_eval_points: Vec::new(),
            target_distances: Vec::new(),
        };
        let img = plot_pr_curves(&report);
        assert_eq!((img.width, img.height), (640, 480));
        // RGB: three bytes per pixel.
        assert_eq!(img.rgb.len(), 640 * 480 * 3);
        let buf = img.rgb;
        let px = |x: f64, y: f64| {
            let (x, y) = (x.round() as usize, y.round() as usize);
            let o = (y * 640 + x) * 3;
            [buf[o], buf[o + 1], buf[o + 2]]
        };
        let x_max = 5.0 * tau;
        assert_eq!(px(plot_x(1.3 * tau, x_max), plot_y(0.25)), [255, 0, 0]);
        assert_eq!(px(plot_x(4.3 * tau, x_max), plot_y(0.75)), [255, 0, 0]);
        assert_eq!(px(plot_x(4.3 * tau, x_max), plot_y(0.25)), [255, 255, 255]);
        assert_eq!(px(plot_x(3.3 * tau, x_max), plot_y(0.5)), [0, 0, 255]);
        // The dashed τ line: black on its dashes, and the corner of the axes.
        let xt = plot_x(tau, x_max);
        let dash = (MARGIN.2..PLOT_H - MARGIN.3)
            .filter(|&y| px(xt, y as f64) == [0, 0, 0])
            .count();
        assert!(
            dash > 150 && dash < 300,
            "{dash} black pixels on the τ line"
        );
        assert_eq!(px(MARGIN.0 as f64, (PLOT_H - MARGIN.3) as f64), [0, 0, 0]);
    }
}
