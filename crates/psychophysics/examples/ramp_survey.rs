//! The survey behind the guide's figures for Luebke & Hallen's ramp
//! (SYNTHETIC: simulated observers only): `N_OBS` hidden observers
//! (default 30), `REPS` correct trials per condition (default 8), the
//! default ramp (0.25 log10/s, 300 ms allowance; `RATE_MILLI=500` for
//! 0.5 log10/s, `ALLOWANCE_MS=0`). Prints the mean bias of the measured
//! thresholds against the truth (log10) beside the model's
//! (`psychophysics::ramp::model_bias_log10`), each parameter's median,
//! 90th percentile and largest relative error (CT0 also after dividing by
//! 10^bias of the model), how often its 95 % interval held the truth, and
//! the trials and failures.
//!
//! `N_OBS=30 REPS=8 cargo run --release -p psychophysics --example ramp_survey`

#[path = "../tests/support/mod.rs"]
mod support;

use psychophysics::observer::RAMP_LOOK_MS;
use psychophysics::ramp::{model_bias_log10, RampOutcome};
use support::{hidden_observers, measure_ramp, ramp_condition_bias, rel};

fn main() {
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let (n, reps) = (env("N_OBS", 30), env("REPS", 8) as u32);
    let rate = env("RATE_MILLI", 250) as f64 / 1000.0;
    let allowance = env("ALLOWANCE_MS", 300) as f64;
    let mut errs = [Vec::new(), Vec::new(), Vec::new(), Vec::new()];
    let mut covered = [0; 3];
    let (mut biases, mut trials, mut failed, mut wrong, mut censored) = (0.0, 0, 0, 0, 0);
    let mut model = 0.0;
    for (k, spec) in hidden_observers(n).into_iter().enumerate() {
        let (s, fit) = measure_ramp(spec, reps, k as u64, |d| {
            d.rate_log10_per_s = rate;
            d.reaction_allowance_ms = allowance;
        });
        model = model_bias_log10(&spec, RAMP_LOOK_MS, rate, allowance).unwrap();
        biases += ramp_condition_bias(&s, &spec.csf);
        trials += s.records().len();
        failed += s
            .records()
            .iter()
            .filter(|r| r.outcome != RampOutcome::Correct)
            .count();
        wrong += s
            .records()
            .iter()
            .filter(|r| r.outcome == RampOutcome::WrongLocation)
            .count();
        censored += s.results().iter().filter(|r| r.censored).count();
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
        errs[3].push(rel(fit.ct0.estimate / 10f64.powf(model), t.ct0));
    }
    println!(
        "rate {rate} log10/s, allowance {allowance} ms, {reps} correct trials a condition: \
         mean bias {:.3} log10 (model {model:.3}); {:.0} trials an observer, {:.1} % failed \
         ({:.1} % wrong location); {:.1} censored conditions an observer",
        biases / n as f64,
        trials as f64 / n as f64,
        100.0 * failed as f64 / trials as f64,
        100.0 * wrong as f64 / trials as f64,
        censored as f64 / n as f64,
    );
    for (i, name) in ["CT0", "alpha", "e2", "CT0/10^model"].iter().enumerate() {
        errs[i].sort_by(f64::total_cmp);
        let v = &errs[i];
        println!(
            "{name}: median {:.1} %, 90th {:.1} %, max {:.1} %{}",
            100.0 * v[v.len() / 2],
            100.0 * v[(v.len() * 9) / 10],
            100.0 * v[v.len() - 1],
            if i < 3 {
                format!(", truth in 95 % CI {}/{n}", covered[i])
            } else {
                String::new()
            }
        );
    }
}
