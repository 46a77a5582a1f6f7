//! How the sweeps measure: one frame timed through the frame pipeline, and
//! the progress bar they show meanwhile.

use indicatif::{ProgressBar, ProgressStyle};
use pipeline::Renderer;
use raycast::render::Stats;
use raycast::Frame;

use experiment::stats::nearest_rank::median;

/// One frame's timing through the frame pipeline: median of `repeats`
/// after one warm-up, with the last frame and its counts.
pub fn timed(
    renderer: &mut Renderer<'_>,
    gaze: [f64; 2],
    repeats: u32,
) -> Result<(Frame, Stats), String> {
    let mut times = Vec::new();
    let mut last = renderer.render(gaze).map_err(|e| e.to_string())?;
    for _ in 0..repeats.max(1) {
        // The last frame's buffers serve the next one, as in a live loop.
        renderer.recycle(std::mem::take(&mut last.0));
        last = renderer.render(gaze).map_err(|e| e.to_string())?;
        times.push(last.1.time_ms);
    }
    last.1.time_ms = median(&times);
    Ok(last)
}

/// A progress bar of `total` steps on stderr, labelled `what`.
pub fn progress(total: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(total);
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}
