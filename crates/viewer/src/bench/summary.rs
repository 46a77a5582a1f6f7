//! The accuracy sweep's measurements: one row per configuration and gaze,
//! and per configuration the summary and whether it is on the Pareto front.

use foveation::quality::Quality;
use raycast::render::Stats;

use crate::bench::configs::Config;
use experiment::stats::tradeoff::pareto_front;

/// One row of `results.csv`.
#[derive(Debug, Clone)]
pub struct Row {
    /// The configuration.
    pub config: Config,
    /// Which gaze (index into the sweep's gazes).
    pub gaze_index: usize,
    /// The gaze, screen px.
    pub gaze_px: [f64; 2],
    /// The frame's counts and median time.
    pub stats: Stats,
    /// The frame's error against full resolution.
    pub quality: Quality,
}

/// A configuration's figures over all gazes.
#[derive(Debug, Clone)]
pub struct Summary {
    /// The configuration.
    pub config: Config,
    /// Mean over gazes of the per-gaze median frame time.
    pub time_ms: f64,
    /// Mean rays per frame over gazes.
    pub rays: f64,
    /// The error, merged over gazes.
    pub quality: Quality,
    /// Whether the configuration is on the time–error Pareto front.
    pub pareto: bool,
}

/// Per configuration, in sweep order; marks the Pareto front (no other
/// configuration is at least as fast and at least as good in foveated PSNR,
/// and strictly better in one).
pub fn summarise(rows: &[Row], configs: &[Config]) -> Vec<Summary> {
    let mut out: Vec<Summary> = configs
        .iter()
        .map(|c| {
            let mine: Vec<&Row> = rows.iter().filter(|r| r.config == *c).collect();
            let n = mine.len().max(1) as f64;
            let mut quality = Quality::default();
            mine.iter().for_each(|r| quality.merge(&r.quality));
            Summary {
                config: *c,
                time_ms: mine.iter().map(|r| r.stats.time_ms).sum::<f64>() / n,
                rays: mine.iter().map(|r| r.stats.rays_total as f64).sum::<f64>() / n,
                quality,
                pareto: false,
            }
        })
        .collect();
    let score = |s: &Summary| s.quality.foveated.psnr_db().unwrap_or(f64::NEG_INFINITY);
    let points: Vec<(f64, f64)> = out.iter().map(|s| (s.time_ms, score(s))).collect();
    for (s, on_front) in out.iter_mut().zip(pareto_front(&points)) {
        s.pareto = on_front;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::configs::configurations;

    fn row(config: Config, time_ms: f64, mse: f64) -> Row {
        let mut quality = Quality::default();
        quality.foveated.squared = mse;
        quality.foveated.weight = 1.0;
        Row {
            config,
            gaze_index: 0,
            gaze_px: [0.0, 0.0],
            stats: Stats {
                time_ms,
                ..Stats::default()
            },
            quality,
        }
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_configurations() {
        let c = configurations(true);
        // (time, mse): c1 fast and poor, c2 slow and good, c3 dominated by c2,
        // c4 equal to c1 in both (neither dominates the other).
        let rows = vec![
            row(c[1], 10.0, 100.0),
            row(c[2], 20.0, 10.0),
            row(c[3], 25.0, 20.0),
            row(c[4], 10.0, 100.0),
        ];
        let s = summarise(&rows, &c[1..5]);
        let front: Vec<bool> = s.iter().map(|x| x.pareto).collect();
        assert_eq!(front, [true, true, false, true]);
    }
}
