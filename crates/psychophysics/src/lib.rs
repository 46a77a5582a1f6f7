//! Measures a participant's contrast thresholds for Gabor patches over a
//! grid of spatial frequency × eccentricity (QUEST or staircases, with
//! gaze-contingent fixation control) and fits the Geisler–Perry CSF to them.
//!
//! **This is a procedure no person has yet run.** It was built and checked
//! against a simulated observer only; every figure below is synthetic, and
//! anything made from a simulated observer's answers is labelled so
//! (`synthetic: true` in the fit, [`session::Session::is_synthetic`]).
//!
//! It measures the threshold contrast a participant needs to see a Gabor
//! patch over a grid of spatial frequency × eccentricity, the data behind
//! `foveation::perceptibility::ThresholdTable` (Luebke & Hallen 2001, §6.1)
//! and the Geisler–Perry parameters of `foveation::csf` (CT0, α, e2).
//!
//! - [`luminance`]: 8-bit levels ↔ linear light, by a photometer
//!   [`luminance::LuminanceTable`] or a documented [`luminance::GammaCurve`];
//!   a render says which it used.
//! - [`stimulus`]: Gabor patches at a frequency in cycles/degree (pixels from
//!   `screen-geometry` at the patch's eccentricity), with unbiased random
//!   spatial dithering for contrasts below one 8-bit step (the smallest
//!   showable contrast is computed per render).
//! - [`quest`]: QUEST (Watson & Pelli 1983) with the toolbox Weibull (β, δ
//!   lapse, γ guess), grid posterior, mean/mode/quantile estimates.
//! - [`staircase`]: transformed up-down staircases (e.g. 3-down-1-up,
//!   step halving at reversals, stop after N reversals or M trials).
//! - [`session`]: interleaved staircases over the grid, a seeded generator
//!   choosing each trial's condition, stopping rules, lapse handling
//!   (δ in the likelihood; out-of-range response times not used) and
//!   censoring of thresholds beyond the display's highest contrast.
//! - [`fixation`]: gaze-contingent fixation control of a two-interval
//!   trial (a window around the target; an attempt is aborted and shown
//!   again when the gaze leaves it or a sample is invalid), no window or
//!   tracker needed.
//! - [`ramp`]: Luebke & Hallen §6.1's own procedure: a log-linear
//!   contrast ramp at one of several locations, a response, a location
//!   click (a wrong one fails the trial), the geometric mean of each
//!   condition's samples; fitted and tabled like the rest
//!   ([`fit::fit_ramp`], [`fit::ramp_threshold_table`]).
//! - [`observer`]: a simulated Geisler–Perry observer read from RON; it
//!   also answers a ramp frame by frame (probability summation over time).
//! - [`fit`]: the Geisler–Perry fit by weighted least squares on log
//!   threshold (linear in ln CT0, α, α/e2), bootstrap percentile
//!   intervals by resampling each condition's trials, and the
//!   `ThresholdTable` (serialised as RON through `ThresholdTableData`).
//! - [`validation`]: the design and analysis of Luebke & Hallen §6.2's
//!   validation (simplified against full rendering as a two-interval
//!   choice; proportion correct against chance with an exact binomial
//!   interval), and a simulated observer's model of how visible the
//!   difference between the two renderings is (Peli's band-limited
//!   contrast against its Geisler–Perry thresholds), which
//!   `gazecast thresholds validate --headless` runs. Its windowed trials
//!   are not built.
//! - [`participant`]: the file a renderer reads (`thresholds-<ID>.ron`:
//!   the measured table, the fitted CT0, α, e2, the participant and
//!   whether it is synthetic), for `gazecast … --thresholds FILE`.
//!
//! ## How it departs from the seeds
//!
//! Luebke & Hallen §6.1 let a grating fade in until the user clicks, then
//! clicks where it was (a method of adjustment with a location check);
//! Murphy & Duchowski §6.2 ran an experimenter-driven method of limits.
//! Neither gives step sizes, reversal counts or how misses count. This crate
//! uses the lab conventions instead: a forced choice (2AFC by default:
//! which interval, or which location, held the patch) driven by QUEST or an
//! up-down staircase, interleaved across conditions. The fade-in method
//! itself is [`ramp`], beside it (`--procedure luebke-hallen`), with what
//! it decided where the seed is silent.
//!
//! ## Recovery (`tests/recovery.rs`)
//!
//! Hidden observers are drawn from seed 2026: CT0 log-uniform in
//! 0.0079–0.032, α uniform in 0.07–0.14, e2 uniform in 1.5–3.5°, β 3.5,
//! lapse rate 2 %, guess rate 0.5, thresholds defined at 82 % correct. The
//! session is the default [`session::SessionSpec`]: 5 frequencies (1, 2,
//! 4, 8, 16 cpd) × 4 eccentricities (0, 2.5, 5, 10°) = 20 conditions,
//! QUEST (toolbox defaults, δ 0.01, posterior mean, prior centred on the
//! default Geisler–Perry threshold with sd 1 log10 unit), contrast at most
//! 1; conditions whose threshold is beyond contrast ≈ 0.8 are censored
//! (1–5 of the 20 here) and the fit uses the rest, weighted, with 200
//! bootstrap resamples.
//!
//! | trials (per condition) | tolerance asserted, 6 observers: CT0 / α / e2 | measured over 30 observers: median / 90th pct / max relative error, CT0; α; e2 | truth inside the 95 % interval (of 30) |
//! |---|---|---|---|
//! | 800 (40) | 20 % / 25 % / 30 % | 3.2 / 10.1 / 15.3 %; 5.4 / 16.3 / 21.4 %; 7.1 / 14.5 / 22.2 % | 30, 30, 30 |
//! | 1600 (80) | 10 % / 15 % / 15 % | 2.0 / 6.9 / 7.6 %; 2.4 / 7.4 / 10.2 %; 3.3 / 9.7 / 11.1 % | 28, 28, 29 |
//!
//! The tests also require the truth inside the 95 % interval for at least
//! 5 of the 6 observers per parameter. Both recovery tests together take
//! about 2 s in the test profile. The 30-observer figures come from the
//! `recovery_survey` example (`N_OBS=30 TPC=40 cargo run --release -p
//! psychophysics --example recovery_survey`, or `TPC=80`).
//! **Up-down staircases recover less well, and their intervals cannot be
//! trusted.** The same survey with 3-down-1-up staircases (step 0.2 log10
//! halving to 0.025, the first 2 reversals discarded, at most 80 trials a
//! condition: `STAIRCASE=1 TPC=80`) gave median / max relative errors of
//! 4.4 / 15.3 % (CT0), 3.4 / 84 % (α) and 5.3 / 120 % (e2) weighted, and
//! 5.9 / 13.1 %, 3.5 / 46.8 %, 5.3 / 47.4 % unweighted (`UNWEIGHTED=1`);
//! the 95 % intervals held the truth for only 3–15 of 30 observers. Two
//! known causes: 3-down-1-up converges on 79.4 % correct, below the 82 %
//! that defines the observer's threshold (≈ 0.018 log10, so CT0 comes out
//! ≈ 4 % low), and resampling a staircase's reversals ignores how they
//! depend on each other (intervals too narrow). Use QUEST for the fit; the
//! recovery tests cover QUEST only.
//!
//! The simulated observer's psychometric function has the same form as
//! QUEST's (only its lapse rate differs, 2 % against 1 %), so these figures
//! are a best case: a real observer's slope, criterion shifts, fatigue and
//! fixation breaks are not modelled.

#![warn(missing_docs)]

pub mod degradation;
pub mod fit;
pub mod fixation;
pub mod luminance;
pub mod observer;
pub mod participant;
pub mod quest;
pub mod ramp;
pub mod session;
pub mod staircase;
pub mod stimulus;
pub mod validation;

pub use foveation::ParamError;
