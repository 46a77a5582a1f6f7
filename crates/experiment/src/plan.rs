//! One participant's session as a list of trials.
//!
//! [`plan`] turns a validated [`Design`] and a participant index into the
//! trials in presentation order: the run, the trial's place in the run and
//! in the session, the condition (from the counterbalancing row), a
//! stimulus seed derived from the design seed, the participant and the
//! trial, the target's grid cell drawn from that seed, and the steps that
//! come before the trial (break, calibration, validation, drift check).
//! With a reference (`stimulus.reference`, the seed's: the target mesh at
//! the centre, Murphy 2007 §7.1.4), the reference cell holds the target
//! mesh too and the target's cell is drawn among the other cells, never
//! the reference's. Practice trials (`Design::practice`) come first, with
//! indices `0..practice`; the experimental trials follow and draw their
//! stimuli from their place among the experimental trials, so practice
//! changes none of them. The same inputs always give the same plan, on
//! every platform.

use crate::counterbalance::{latin_square, williams};
use crate::design::{Counterbalancing, Design, DesignError, RunOrder};
use serde::{Deserialize, Serialize};

/// Something the runner does before a trial, in the order listed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Step {
    /// Rest break between runs.
    RunBreak,
    /// Rest break within a run (after `break_after_trials` trials).
    Break,
    /// Full calibration (`calibration.points` targets).
    Calibration,
    /// Validation (`calibration.validation_points` targets); above
    /// `calibration.accuracy_threshold_deg` the runner recalibrates.
    Validation,
    /// Validation at the session's mid-point, same rule as [`Step::Validation`].
    MidpointValidation,
    /// Single-point drift check; above `drift_check.threshold_deg` the
    /// runner recalibrates.
    DriftCheck,
    /// The practice trials are over: a screen says so (the seed's pause
    /// for questions, Murphy 2007 §7.1.5) before the first experimental
    /// trial.
    PracticeOver,
}

/// One trial of a participant's session.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Trial {
    /// Position in the session, from 0.
    pub index: usize,
    /// Run (repetition), from 0.
    pub run: usize,
    /// Position within the run, from 0.
    pub trial_in_run: usize,
    /// Index into `Design::conditions`.
    pub condition: usize,
    /// `Design::conditions[condition].name`, for logs.
    pub condition_name: String,
    /// Stimulus seed: [`trial_seed`]`(stimulus.seed, participant, i)` with
    /// `i` the trial's place among the experimental trials (`index` minus
    /// the practice trials); a practice trial's comes from a stream of its
    /// own (see [`plan`]).
    pub seed: u64,
    /// Target cell (row, column) in the search grid, drawn from `seed`
    /// uniformly among the cells other than the reference's (among all
    /// cells without a reference).
    pub target_cell: (u32, u32),
    /// The reference's cell (`Design::stimulus.reference_cell`), which
    /// holds the target mesh too; `None` without a reference (and in a
    /// plan written before the field existed).
    #[serde(default)]
    pub reference_cell: Option<(u32, u32)>,
    /// The target mesh, `0..stimulus.meshes`: drawn without replacement
    /// from the participant's pre-seeded pool in which every mesh appears
    /// equally often (Murphy 2007 §7.1.4), so each mesh is the target
    /// `total / meshes` times (± 1 when that does not divide).
    pub target_mesh: u32,
    /// The mesh in every grid cell, row-major (`grid.0 × grid.1`): the
    /// target at `target_cell` and at `reference_cell`, every other cell
    /// one of the non-target meshes drawn uniformly from `seed`.
    pub cells: Vec<u32>,
    /// Steps to run before this trial, in order.
    pub before: Vec<Step>,
    /// A practice trial (`Design::practice`): before the first run, marked
    /// in every file, never analysed. Its `run` is 0 and its
    /// `trial_in_run` its place among the practice trials.
    #[serde(default)]
    pub practice: bool,
}

/// The counterbalancing rows the design uses.
pub fn orders(design: &Design) -> Vec<Vec<usize>> {
    let n = design.conditions.len();
    match design.counterbalancing {
        Counterbalancing::LatinSquare => latin_square(n),
        Counterbalancing::Williams => williams(n),
    }
}

/// The participant's session. Validates the design first.
pub fn plan(design: &Design, participant: usize) -> Result<Vec<Trial>, DesignError> {
    design.validate()?;
    let rows = orders(design);
    let per_run = design.trials_per_run();
    let total = design.total_trials();
    let practice = design.practice_trials();
    let midpoint = total / 2;
    let base = design.stimulus.seed;
    let who = participant as u64;
    let pool = target_pool(base, who, design.stimulus.meshes, total);
    let mut trials = Vec::with_capacity(practice + total);
    if let Some(condition) = design.practice_condition() {
        let pool = pool_from(
            trial_seed(base, who, PRACTICE_POOL),
            design.stimulus.meshes,
            practice,
        );
        for (k, &mesh) in pool.iter().enumerate() {
            let seed = trial_seed(base, who, PRACTICE_POOL - 1 - k as u64);
            let mut before = Vec::new();
            if k == 0 && design.calibration.at_start {
                before.extend([Step::Calibration, Step::Validation]);
            }
            trials.push(draw_trial(
                design, seed, mesh, condition, before, k, 0, k, true,
            ));
        }
    }
    for run in 0..design.runs as usize {
        let row = match design.run_order {
            RunOrder::Repeat => participant % rows.len(),
            RunOrder::Rotate => (participant % rows.len() + run) % rows.len(),
        };
        for (trial_in_run, &condition) in rows[row].iter().enumerate() {
            // The place among the experimental trials: what the stimulus
            // and the schedule follow, practice or not.
            let i = run * per_run + trial_in_run;
            let seed = trial_seed(base, who, i as u64);
            let mut before = Vec::new();
            if i == 0 && practice > 0 {
                before.push(Step::PracticeOver);
            }
            if i > 0 && trial_in_run == 0 && design.breaks.between_runs {
                before.push(Step::RunBreak);
            }
            if let Some(k) = design.breaks.break_after_trials {
                if trial_in_run == k as usize {
                    before.push(Step::Break);
                }
            }
            if i == 0 && practice == 0 && design.calibration.at_start {
                before.push(Step::Calibration);
                before.push(Step::Validation);
            }
            if i == midpoint && i > 0 && design.calibration.validate_at_midpoint {
                before.push(Step::MidpointValidation);
            }
            if let Some(d) = &design.drift_check {
                let validating = before
                    .iter()
                    .any(|s| matches!(s, Step::Validation | Step::MidpointValidation));
                if i > 0 && i.is_multiple_of(d.every_trials as usize) && !validating {
                    before.push(Step::DriftCheck);
                }
            }
            trials.push(draw_trial(
                design,
                seed,
                pool[i],
                condition,
                before,
                practice + i,
                run,
                trial_in_run,
                false,
            ));
        }
    }
    Ok(trials)
}

/// The `trial` argument of [`trial_seed`] that seeds the practice trials'
/// target pool; practice trial k's stimulus seed uses `PRACTICE_POOL − 1 − k`
/// (far above any experimental trial's index, and below the experimental
/// pool's `u64::MAX`).
const PRACTICE_POOL: u64 = u64::MAX - 1;

/// One trial's stimulus drawn from its `seed`: the target's cell (uniform
/// over the cells other than the reference's, or over every cell without
/// one) and every other cell's distractor mesh.
#[allow(clippy::too_many_arguments)]
fn draw_trial(
    design: &Design,
    seed: u64,
    target_mesh: u32,
    condition: usize,
    before: Vec<Step>,
    index: usize,
    run: usize,
    trial_in_run: usize,
    practice: bool,
) -> Trial {
    let (grid_rows, grid_cols) = design.stimulus.grid;
    let cells = u64::from(grid_rows) * u64::from(grid_cols);
    let meshes = design.stimulus.meshes;
    let reference_cell = design.stimulus.reference_cell();
    let reference = reference_cell.map(|(r, c)| u64::from(r) * u64::from(grid_cols) + u64::from(c));
    let mut rng = SplitMix64(seed);
    // Validation keeps at least one cell besides the reference's.
    let cell = match reference {
        Some(k) => {
            let x = rng.below(cells - 1);
            if x >= k {
                x + 1
            } else {
                x
            }
        }
        None => rng.below(cells),
    };
    let target_cell = (
        (cell / u64::from(grid_cols)) as u32,
        (cell % u64::from(grid_cols)) as u32,
    );
    let layout: Vec<u32> = (0..cells)
        .map(|c| {
            if c == cell || Some(c) == reference {
                target_mesh
            } else {
                // One of the meshes - 1 others, uniformly.
                let k = rng.below(u64::from(meshes - 1)) as u32;
                if k >= target_mesh {
                    k + 1
                } else {
                    k
                }
            }
        })
        .collect();
    Trial {
        index,
        run,
        trial_in_run,
        condition,
        condition_name: design.conditions[condition].name.clone(),
        seed,
        target_cell,
        reference_cell,
        target_mesh,
        cells: layout,
        before,
        practice,
    }
}

/// The participant's target pool: `total` entries in which each of the
/// `meshes` meshes appears `total / meshes` times (the first
/// `total % meshes` once more), shuffled by Fisher–Yates with a generator
/// seeded from the design seed and the participant alone, so the pool
/// does not depend on the order of conditions.
pub fn target_pool(base: u64, participant: u64, meshes: u32, total: usize) -> Vec<u32> {
    pool_from(trial_seed(base, participant, u64::MAX), meshes, total)
}

/// A balanced pool of `total` target meshes shuffled from `seed`.
fn pool_from(seed: u64, meshes: u32, total: usize) -> Vec<u32> {
    let meshes = meshes.max(1);
    let mut pool: Vec<u32> = (0..total).map(|i| (i % meshes as usize) as u32).collect();
    let mut rng = SplitMix64(seed);
    for i in (1..pool.len()).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        pool.swap(i, j);
    }
    pool
}

/// A trial's stimulus seed: SplitMix64's finaliser applied to the design
/// seed, then mixed with the participant, then with the trial index, so
/// that nearby inputs give unrelated seeds. Stable across platforms and
/// crate versions (no `rand` involved).
///
/// Source: Steele, Lea & Flood (2014), "Fast splittable pseudorandom number
/// generators", OOPSLA '14 (the `mix64` finaliser, constants as in
/// `java.util.SplittableRandom`).
pub fn trial_seed(base: u64, participant: u64, trial: u64) -> u64 {
    let a = mix64(base ^ 0x6761_7a65_6361_7374); // "gazecast"
    let b = mix64(a ^ participant.wrapping_mul(GOLDEN_GAMMA));
    mix64(b ^ trial.wrapping_mul(GOLDEN_GAMMA).wrapping_add(1))
}

const GOLDEN_GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// SplitMix64 generator (Steele, Lea & Flood 2014).
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(GOLDEN_GAMMA);
        mix64(self.0)
    }

    /// Uniform integer in `0..n` (`n > 0`), without modulo bias: Lemire's
    /// multiply-and-reject method (Lemire 2019, "Fast random integer
    /// generation in an interval", ACM TOMACS 29(1), algorithm 5).
    fn below(&mut self, n: u64) -> u64 {
        debug_assert!(n > 0);
        let threshold = n.wrapping_neg() % n;
        loop {
            let m = u128::from(self.next()) * u128::from(n);
            if (m as u64) >= threshold {
                return (m >> 64) as u64;
            }
        }
    }
}
