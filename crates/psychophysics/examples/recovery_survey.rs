//! The survey behind the crate docs' recovery figures (SYNTHETIC: simulated
//! observers only): `N_OBS` hidden observers (default 30) at `TPC` trials
//! per condition (default 40); `STAIRCASE=1` runs 3-down-1-up staircases
//! (at most `TPC` trials each) instead of QUEST, `UNWEIGHTED=1` fits
//! without weights. Prints each parameter's median, 90th percentile and
//! largest relative error and how often its 95 % interval held the truth.
//!
//! `N_OBS=30 TPC=80 cargo run --release -p psychophysics --example recovery_survey`

#[path = "../tests/support/mod.rs"]
mod support;

use psychophysics::staircase::StaircaseParams;
use support::{hidden_observers, measure_with, rel};

fn main() {
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let (n, tpc) = (env("N_OBS", 30), env("TPC", 40) as u32);
    let weighted = env("UNWEIGHTED", 0) != 1;
    let staircase = (env("STAIRCASE", 0) == 1).then(|| StaircaseParams {
        max_reversals: 100,
        max_trials: tpc,
        ..StaircaseParams::default()
    });
    let mut errs = [Vec::new(), Vec::new(), Vec::new()];
    let mut covered = [0; 3];
    for (k, spec) in hidden_observers(n).into_iter().enumerate() {
        let (_, fit) = measure_with(spec, tpc, k as u64, staircase, weighted);
        let t = spec.csf;
        for (i, (e, truth)) in [
            (fit.ct0, t.ct0),
            (fit.alpha, t.alpha),
            (fit.e2_deg, t.e2_deg),
        ]
        .into_iter()
        .enumerate()
        {
            errs[i].push(rel(e.estimate, truth));
            covered[i] += usize::from(e.ci_low <= truth && truth <= e.ci_high);
        }
    }
    for (i, name) in ["CT0", "alpha", "e2"].iter().enumerate() {
        errs[i].sort_by(f64::total_cmp);
        let v = &errs[i];
        println!(
            "{name}: median {:.1} %, 90th {:.1} %, max {:.1} %, truth in 95 % CI {}/{n}",
            100.0 * v[v.len() / 2],
            100.0 * v[(v.len() * 9) / 10],
            100.0 * v[v.len() - 1],
            covered[i]
        );
    }
}
