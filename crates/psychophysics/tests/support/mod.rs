//! What the recovery tests and the recovery survey example share: hidden
//! simulated observers, and one whole measurement (session, simulated
//! answers, fit) of one of them. Everything here is synthetic. Each
//! includer uses part of it.
#![allow(dead_code)]

use foveation::GeislerPerry;
use psychophysics::fit::{fit_ramp, fit_session, FitOptions, GeislerPerryFit};
use psychophysics::observer::{ObserverSpec, SimulatedObserver};
use psychophysics::ramp::{RampSession, RampSpec};
use psychophysics::session::{Procedure, Session, SessionSpec};
use psychophysics::staircase::StaircaseParams;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Hidden observers (drawn from seed 2026): CT0 log-uniform 0.0079–0.032, α 0.07–0.14, e2
/// 1.5–3.5°, β 3.5, lapses 2 %, 2AFC.
pub fn hidden_observers(n: u64) -> Vec<ObserverSpec> {
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    (0..n)
        .map(|k| ObserverSpec {
            csf: GeislerPerry {
                ct0: 10f64.powf(rng.random_range(-2.1..-1.5)),
                alpha: rng.random_range(0.07..0.14),
                e2_deg: rng.random_range(1.5..3.5),
            },
            beta: 3.5,
            lapse_rate: 0.02,
            guess_rate: 0.5,
            p_threshold: 0.82,
            rt_median_ms: 550.0,
            rt_log_sd: 0.3,
            seed: 100 + k,
        })
        .collect()
}

pub fn measure(
    spec: ObserverSpec,
    trials_per_condition: u32,
    seed: u64,
) -> (Session, GeislerPerryFit) {
    measure_with(spec, trials_per_condition, seed, None, true)
}

pub fn measure_with(
    spec: ObserverSpec,
    trials_per_condition: u32,
    seed: u64,
    staircase: Option<StaircaseParams>,
    weighted: bool,
) -> (Session, GeislerPerryFit) {
    let mut obs = SimulatedObserver::new(spec).unwrap();
    let mut design = SessionSpec {
        seed,
        trials_per_condition,
        ..SessionSpec::default()
    };
    if let Some(p) = staircase {
        design.procedure = Procedure::Staircase(p);
    }
    let mut s = Session::new(design).unwrap();
    while let Some(t) = s.next_trial() {
        let r = obs
            .respond(t.frequency_cpd, t.eccentricity_deg, t.contrast)
            .unwrap();
        s.record_synthetic(&t, r).unwrap();
    }
    let fit = fit_session(
        &s,
        &FitOptions {
            weighted,
            ..FitOptions::default()
        },
    )
    .unwrap();
    (s, fit)
}

pub fn rel(est: f64, truth: f64) -> f64 {
    (est / truth - 1.0).abs()
}

/// One Luebke & Hallen ramp measurement of a hidden observer: the default
/// [`RampSpec`] with `repetitions` correct trials per condition, the
/// simulated observer answering every ramp frame by frame, the fit.
pub fn measure_ramp(
    spec: ObserverSpec,
    repetitions: u32,
    seed: u64,
    tweak: impl FnOnce(&mut RampSpec),
) -> (RampSession, GeislerPerryFit) {
    let mut obs = SimulatedObserver::new(spec).unwrap();
    let mut design = RampSpec {
        seed,
        repetitions,
        ..RampSpec::default()
    };
    tweak(&mut design);
    let mut s = RampSession::new(design).unwrap();
    while let Some(t) = s.next_trial() {
        let r = obs.respond_ramp(&t, s.spec().frame_ms).unwrap();
        s.record_synthetic(&t, r).unwrap();
    }
    let fit = fit_ramp(&s, &FitOptions::default()).unwrap();
    (s, fit)
}

/// The mean over a ramp session's used conditions of measured minus true
/// log10 threshold.
pub fn ramp_condition_bias(s: &RampSession, truth: &GeislerPerry) -> f64 {
    let used: Vec<f64> = s
        .results()
        .iter()
        .filter(|r| !r.censored && !r.abandoned)
        .map(|r| {
            r.log10_threshold
                - truth
                    .contrast_threshold(r.frequency_cpd, r.eccentricity_deg)
                    .log10()
        })
        .collect();
    used.iter().sum::<f64>() / used.len().max(1) as f64
}
