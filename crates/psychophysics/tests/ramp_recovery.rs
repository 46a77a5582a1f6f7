//! Luebke & Hallen's ramp (`psychophysics::ramp`) against hidden simulated
//! observers answering every ramp frame by frame: the thresholds come back
//! with the bias the model predicts, and the fit recovers α and e2 (which
//! a bias shared by every condition leaves alone) and CT0 once that bias
//! is divided out. Tolerances are the guide's ("Luebke & Hallen's ramp");
//! the 30-observer figures come from `examples/ramp_survey.rs`.

use psychophysics::fit::ramp_threshold_table;
use psychophysics::observer::RAMP_LOOK_MS;
use psychophysics::ramp::{model_bias_log10, RampOutcome};

mod support;

use support::{hidden_observers, measure_ramp, ramp_condition_bias, rel};

#[test]
fn the_ramp_recovers_hidden_observers_with_the_models_bias() {
    let mut covered = [0; 2];
    let mut lapses_caught = 0;
    for (k, spec) in hidden_observers(6).into_iter().enumerate() {
        let (s, fit) = measure_ramp(spec, 8, k as u64, |_| {});
        assert!(s.is_synthetic() && fit.synthetic);
        let model = model_bias_log10(&spec, RAMP_LOOK_MS, 0.25, 300.0).unwrap();
        let bias = ramp_condition_bias(&s, &spec.csf);
        assert!(
            (bias - model).abs() < 0.05,
            "observer {k}: bias {bias} vs the model's {model}"
        );
        // Every condition ended: 8 correct trials, or 6 failed ones.
        for r in s.ramp_results() {
            assert!(r.correct == 8 || r.wrong_location + r.no_response + r.too_early == 6);
        }
        let t = spec.csf;
        let ct0 = rel(fit.ct0.estimate / 10f64.powf(model), t.ct0);
        assert!(
            ct0 < 0.2,
            "observer {k}: CT0 {} vs {}",
            fit.ct0.estimate,
            t.ct0
        );
        let a = rel(fit.alpha.estimate, t.alpha);
        assert!(
            a < 0.25,
            "observer {k}: alpha {} vs {}",
            fit.alpha.estimate,
            t.alpha
        );
        let e = rel(fit.e2_deg.estimate, t.e2_deg);
        assert!(
            e < 0.3,
            "observer {k}: e2 {} vs {}",
            fit.e2_deg.estimate,
            t.e2_deg
        );
        covered[0] += usize::from(fit.alpha.ci_low <= t.alpha && t.alpha <= fit.alpha.ci_high);
        covered[1] += usize::from(fit.e2_deg.ci_low <= t.e2_deg && t.e2_deg <= fit.e2_deg.ci_high);
        // The table holds the measured thresholds where they were used
        // (at most: it clamps those below the most sensitive frequency).
        let table = ramp_threshold_table(&s, &fit).unwrap();
        let mut same = 0;
        for r in s.results().iter().filter(|r| !r.censored && !r.abandoned) {
            let v = table.threshold(r.frequency_cpd, r.eccentricity_deg);
            assert!(v <= r.threshold * (1.0 + 1e-9), "{v} vs {r:?}");
            same += usize::from((v / r.threshold - 1.0).abs() < 1e-9);
        }
        assert!(same >= 4, "{same}");
        lapses_caught += s
            .records()
            .iter()
            .filter(|r| r.outcome == RampOutcome::WrongLocation)
            .count();
    }
    // Lapses click a random location: the location check fails some.
    assert!(lapses_caught > 0);
    assert!(covered.iter().all(|&c| c >= 4), "{covered:?} of 6");
}
