//! The continuous Nyquist bound: how many rays a perfect sampler would need.

use rayon::prelude::*;

use crate::sampling::SamplingModel;

/// Side of the integration cells, pixels. The integrand is smooth except at
/// the fovea edge, where it reaches 1; 2×2 midpoint cells stay within 0.1 %
/// of the per-pixel sum on every shipped display (see the tests).
const CELL_PX: u32 = 2;

/// `∫ min(1, (2·f_c(e)/ppd)²) dA` over the screen, in rays: the fewest rays
/// any layout that meets the Nyquist spacing could cast for this POR.
pub fn nyquist_bound_rays(model: &SamplingModel, por_px: [f64; 2]) -> f64 {
    integrate(model, por_px, CELL_PX)
}

/// The same integral with integration cells of `cell_px` pixels (1 = one
/// evaluation per pixel centre).
pub fn integrate(model: &SamplingModel, por_px: [f64; 2], cell_px: u32) -> f64 {
    let cell = cell_px.max(1);
    let (w, h) = (model.geometry.width_px, model.geometry.height_px);
    let rows = h.div_ceil(cell);
    (0..rows)
        .into_par_iter()
        .map(|row| {
            let y0 = row * cell;
            let ch = cell.min(h - y0);
            let mut sum = 0.0;
            let mut x0 = 0;
            while x0 < w {
                let cw = cell.min(w - x0);
                let centre = [
                    f64::from(x0) + f64::from(cw) / 2.0,
                    f64::from(y0) + f64::from(ch) / 2.0,
                ];
                sum += model.required_density(por_px, centre) * f64::from(cw * ch);
                x0 += cell;
            }
            sum
        })
        .sum()
}
