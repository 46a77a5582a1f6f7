//! The seed's POR box (Murphy 2007's figures): a 2-px yellow square, 64 px
//! across, around the point of regard.

use raycast::Frame;

use super::{Pass, PassInput};

/// Draws the POR box.
#[derive(Debug, Clone, Copy)]
pub struct PorOverlay {
    /// Half the box's size in pixels (the scene's `PorOverlay(half_px: …)`).
    pub half_px: i64,
}

impl Default for PorOverlay {
    /// The seed's 64-px box.
    fn default() -> Self {
        Self {
            half_px: i64::from(raycast::scene::POR_HALF_PX),
        }
    }
}

impl Pass for PorOverlay {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn name(&self) -> &'static str {
        "POR box"
    }

    fn into_gpu(self: Box<Self>) -> Result<Box<dyn super::GpuPass>, Box<dyn Pass>> {
        crate::gpu::GpuPor::new(*self)
            .map(|g| Box::new(g) as Box<dyn super::GpuPass>)
            .ok_or(self)
    }

    fn run(&mut self, frame: &mut Frame, input: &PassInput<'_>) {
        draw_box(
            &mut frame.rgb,
            frame.width_px,
            frame.height_px,
            input.gaze_px,
            self.half_px,
        );
    }
}

/// A 2-px yellow square outline of half-size `half_px` around `centre`,
/// clipped to the `w` × `h` RGB image. A centre that is not finite or lies
/// far off the image draws nothing.
pub fn draw_box(rgb: &mut [u8], w: u32, h: u32, centre: [f64; 2], half_px: i64) {
    let reach = half_px as f64 + 2.0;
    let near = |c: f64, n: u32| c.is_finite() && c > -reach && c < f64::from(n) + reach;
    if !near(centre[0], w) || !near(centre[1], h) || rgb.len() < 3 * w as usize * h as usize {
        return;
    }
    let (cx, cy) = (centre[0].round() as i64, centre[1].round() as i64);
    let mut put = |x: i64, y: i64| {
        if (0..i64::from(w)).contains(&x) && (0..i64::from(h)).contains(&y) {
            let i = 3 * (y as usize * w as usize + x as usize);
            rgb[i..i + 3].copy_from_slice(&[255, 220, 0]);
        }
    };
    let r = half_px;
    for d in -r..=r {
        for t in [-r, -r + 1, r - 1, r] {
            put(cx + d, cy + t);
            put(cx + t, cy + d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_box_is_drawn_around_the_gaze_and_clipped() {
        let (w, h) = (100u32, 80u32);
        let mut rgb = vec![0u8; 3 * 100 * 80];
        draw_box(&mut rgb, w, h, [10.0, 10.0], 32);
        let px = |x: usize, y: usize| &rgb[3 * (y * 100 + x)..3 * (y * 100 + x) + 3];
        assert_eq!(px(42, 10), &[255, 220, 0]);
        assert_eq!(px(10, 42), &[255, 220, 0]);
        assert_eq!(px(10, 10), &[0, 0, 0]);
    }

    #[test]
    fn a_far_or_non_finite_gaze_draws_nothing() {
        for c in [
            [f64::NAN, 1.0],
            [1e300, 5.0],
            [-1e9, -1e9],
            [f64::INFINITY, 0.0],
        ] {
            let mut rgb = vec![0u8; 3 * 50 * 50];
            draw_box(&mut rgb, 50, 50, c, 32);
            assert!(rgb.iter().all(|&b| b == 0), "{c:?}");
        }
    }
}
