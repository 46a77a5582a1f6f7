//! Murphy & Duchowski's degradation staircase (2001, §6.2): for each
//! depth (the object subtending 26°, 24°, 22°, 20°, 18°), how far from the
//! gaze each geometric resolution level must be shown — their Table 1.
//!
//! The seed's procedure is a "modified 2AFC (method of limits)" with a
//! staircase: the experimenter raised the resolution until the participant
//! reported no further change, then tracked back and forth across that
//! point. It gives no step rule, number of reversals or estimator; this
//! module decides them (and says so):
//!
//! - **What a level is.** Levels 5 (fine, the original mesh) … 1 (coarse)
//!   are the `lod` method's levels (`lod::Mode::MurphyDuchowski`: level L
//!   lets a node stay folded while its angular extent is at most the
//!   level's allowance, by default 0°, 0.5°, 1°, 2°, 4° for levels 5 … 1).
//! - **A trial** (at one depth and one eccentricity `e`) is a two-interval
//!   choice: the object at full resolution in one interval, and in the
//!   other the object at full resolution within `e` of the gaze and at the
//!   staircase's level beyond `e` (the degradation function with one step
//!   at `e`); the observer names the degraded interval.
//! - **The staircase** ([`LevelStaircase`]) is a transformed up-down
//!   staircase ([`crate::staircase`], Levitt 1971) on the *coarseness*
//!   `5 − level` in steps of one level, never halved: `n_down` correct in
//!   a row → one level finer, one wrong → one level coarser (1-up-`n_down`-
//!   down converges on `0.5^(1/n_down)` correct: 0.707 for 2). It starts at
//!   the coarsest level, as M&D raised the resolution from coarse. Its range
//!   includes level 5 itself (both intervals the same, the observer at
//!   chance), so a track can reverse below the finest level that differs.
//! - **The estimator** ([`LevelStaircase::threshold`]): `x̂` = the mean
//!   coarseness at the reversals after the first `discard_reversals` (all of
//!   them if too few; the current coarseness if none); the threshold level
//!   is `5 − ⌊x̂⌋`: the track oscillates between a coarseness the observer
//!   tells apart (`k`) and one it does not (`k − 1`), whose reversals average
//!   `k − ½`. At the coarse end there is no coarser level to reverse
//!   against, so when the proportion correct at level 1 over at least
//!   [`MIN_TRIALS_AT_BOUND`] trials is below the staircase's target, the
//!   threshold is level 1 (the observer cannot tell even level 1).
//! - **The table** ([`table_row`]): the threshold at eccentricity `e` is
//!   the coarsest level shown beyond `e` that the observer cannot tell from
//!   full; level `k`'s extent is the smallest grid eccentricity from which
//!   on every threshold is coarser than `k` (Table 1's reading B: the
//!   eccentricity up to which level `k` is shown). Where the threshold at
//!   the last grid point is still `k` or finer, the extent is the last grid
//!   point and marked censored. Level 1's extent is the last grid point
//!   (beyond every extent level 1 is drawn anyway).

use serde::{Deserialize, Serialize};

use crate::staircase::{Staircase, StaircaseParams};
use crate::ParamError;

/// The finest level (the original mesh).
pub const FINEST_LEVEL: u8 = 5;
/// The coarsest level.
pub const COARSEST_LEVEL: u8 = 1;
/// Trials at level 1 needed before its proportion correct can make level 1
/// the threshold (module doc).
pub const MIN_TRIALS_AT_BOUND: usize = 4;
/// Most trials one staircase may run.
pub const MAX_TRIALS: u32 = 1000;

/// The rules of one staircase over levels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelStaircaseParams {
    /// Correct answers in a row that make the level one finer (1..=10).
    pub n_down: u32,
    /// Stop after this many reversals (≥ 1).
    pub max_reversals: u32,
    /// Stop after this many trials (1..=[`MAX_TRIALS`]).
    pub max_trials: u32,
    /// Reversals left out of the estimate, from the start.
    pub discard_reversals: u32,
    /// The first trial's level (1..=5).
    pub start_level: u8,
}

impl Default for LevelStaircaseParams {
    /// 1-up-2-down from level 1, 8 reversals (the first 2 discarded) or 40
    /// trials.
    fn default() -> Self {
        Self {
            n_down: 2,
            max_reversals: 8,
            max_trials: 40,
            discard_reversals: 2,
            start_level: COARSEST_LEVEL,
        }
    }
}

impl LevelStaircaseParams {
    /// Checks every field (ranges in the field docs).
    pub fn validate(&self) -> Result<(), ParamError> {
        if !(1..=10).contains(&self.n_down) {
            return Err(ParamError::new("n_down", self.n_down, "must be 1 to 10"));
        }
        if self.max_reversals == 0 {
            return Err(ParamError::new(
                "max_reversals",
                self.max_reversals,
                "must be at least 1",
            ));
        }
        if !(1..=MAX_TRIALS).contains(&self.max_trials) {
            return Err(ParamError::new(
                "max_trials",
                self.max_trials,
                format!("must be 1 to {MAX_TRIALS}"),
            ));
        }
        if !(COARSEST_LEVEL..=FINEST_LEVEL).contains(&self.start_level) {
            return Err(ParamError::new(
                "start_level",
                self.start_level,
                "must be a level from 1 (coarse) to 5 (fine)",
            ));
        }
        Ok(())
    }

    /// The proportion correct the staircase converges on,
    /// `0.5^(1/n_down)` (one wrong answer makes it coarser).
    pub fn target(&self) -> f64 {
        0.5f64.powf(1.0 / f64::from(self.n_down.max(1)))
    }
}

/// The estimate of one staircase (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LevelThreshold {
    /// The coarsest level the observer cannot tell from full, 1..=5.
    pub level: u8,
    /// `x̂`: the mean coarseness (`5 − level`) at the reversals used;
    /// `None` without reversals.
    pub mean_reversal_coarseness: Option<f64>,
    /// Reversals the estimate used.
    pub reversals_used: usize,
    /// Trials run.
    pub trials: usize,
    /// Proportion correct at level 1 (`None` without such trials).
    pub p_correct_at_level_1: Option<f64>,
    /// Whether the coarse-end rule set the level to 1.
    pub at_coarse_bound: bool,
}

/// A transformed up-down staircase over the levels (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct LevelStaircase {
    params: LevelStaircaseParams,
    inner: Staircase,
}

impl LevelStaircase {
    /// A staircase at its start; `params` is checked.
    pub fn new(params: LevelStaircaseParams) -> Result<Self, ParamError> {
        params.validate()?;
        let inner = Staircase::new(StaircaseParams {
            start: f64::from(FINEST_LEVEL - params.start_level),
            step: 1.0,
            min_step: 1.0,
            n_down: params.n_down,
            n_up: 1,
            max_reversals: params.max_reversals,
            max_trials: params.max_trials,
            discard_reversals: params.discard_reversals,
            min_intensity: 0.0,
            max_intensity: f64::from(FINEST_LEVEL - COARSEST_LEVEL),
        })?;
        Ok(Self { params, inner })
    }

    /// The rules it was made with.
    pub fn params(&self) -> &LevelStaircaseParams {
        &self.params
    }

    /// The next trial's level, 1..=5.
    pub fn next_level(&self) -> u8 {
        coarseness_to_level(self.inner.next_intensity())
    }

    /// Has a stopping rule been met?
    pub fn is_finished(&self) -> bool {
        self.inner.is_finished()
    }

    /// Records the answer to a trial at [`Self::next_level`].
    pub fn update(&mut self, correct: bool) {
        self.inner.update(correct);
    }

    /// Trials so far: (level, correct).
    pub fn trials(&self) -> Vec<(u8, bool)> {
        self.inner
            .trials()
            .iter()
            .map(|&(x, c)| (coarseness_to_level(x), c))
            .collect()
    }

    /// Levels at the reversals so far.
    pub fn reversal_levels(&self) -> Vec<u8> {
        self.inner
            .reversals()
            .iter()
            .map(|&x| coarseness_to_level(x))
            .collect()
    }

    /// The estimate (module doc).
    pub fn threshold(&self) -> LevelThreshold {
        let used = self.inner.used_reversals();
        let x = self.inner.estimate();
        let at_1: Vec<bool> = self
            .trials()
            .into_iter()
            .filter(|&(l, _)| l == COARSEST_LEVEL)
            .map(|(_, c)| c)
            .collect();
        let p1 = (!at_1.is_empty())
            .then(|| at_1.iter().filter(|&&c| c).count() as f64 / at_1.len() as f64);
        let at_coarse_bound =
            at_1.len() >= MIN_TRIALS_AT_BOUND && p1.is_some_and(|p| p < self.params.target());
        let level = if at_coarse_bound {
            COARSEST_LEVEL
        } else {
            coarseness_to_level(x.floor())
        };
        LevelThreshold {
            level,
            mean_reversal_coarseness: (!used.is_empty()).then_some(x),
            reversals_used: used.len(),
            trials: self.inner.trials().len(),
            p_correct_at_level_1: p1,
            at_coarse_bound,
        }
    }
}

/// The level of a coarseness (`5 − level`), rounded and clamped to 1..=5.
fn coarseness_to_level(x: f64) -> u8 {
    let c = if x.is_nan() { 0.0 } else { x.round() };
    FINEST_LEVEL - c.clamp(0.0, f64::from(FINEST_LEVEL - COARSEST_LEVEL)) as u8
}

/// One depth's row of a Table-1-style table: level 5 … 1's extents.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TableRow {
    /// Extents (degrees) of levels 5, 4, 3, 2, 1.
    pub extents_deg: [f64; 5],
    /// Whether each extent is only a lower bound (the level was still
    /// needed at the grid's last eccentricity).
    pub censored: [bool; 5],
}

/// The row of a table from the thresholds at a grid of eccentricities
/// (module doc): `eccentricities_deg` strictly increasing, finite and ≥ 0,
/// one threshold level (1..=5) for each.
pub fn table_row(eccentricities_deg: &[f64], levels: &[u8]) -> Result<TableRow, ParamError> {
    if eccentricities_deg.is_empty() {
        return Err(ParamError::new(
            "eccentricities_deg",
            "[]",
            "needs at least one eccentricity",
        ));
    }
    if levels.len() != eccentricities_deg.len() {
        return Err(ParamError::new(
            "levels",
            levels.len(),
            format!(
                "must be one per eccentricity ({})",
                eccentricities_deg.len()
            ),
        ));
    }
    check_grid(eccentricities_deg)?;
    if let Some(l) = levels
        .iter()
        .find(|l| !(COARSEST_LEVEL..=FINEST_LEVEL).contains(*l))
    {
        return Err(ParamError::new("levels", l, "must be 1 to 5"));
    }
    let last = eccentricities_deg[eccentricities_deg.len() - 1];
    let mut row = TableRow {
        extents_deg: [last; 5],
        censored: [false; 5],
    };
    for k in (COARSEST_LEVEL + 1..=FINEST_LEVEL).rev() {
        let col = usize::from(FINEST_LEVEL - k);
        // The first index from which every threshold is coarser than k.
        let from = (0..levels.len())
            .rev()
            .take_while(|&i| levels[i] < k)
            .last();
        match from {
            Some(i) => row.extents_deg[col] = eccentricities_deg[i],
            None => row.censored[col] = true,
        }
    }
    Ok(row)
}

/// Checks a grid of eccentricities: 1 to 64 values, finite, ≥ 0 and at
/// most 90°, strictly increasing.
pub fn check_grid(eccentricities_deg: &[f64]) -> Result<(), ParamError> {
    if eccentricities_deg.is_empty() || eccentricities_deg.len() > 64 {
        return Err(ParamError::new(
            "eccentricities_deg",
            eccentricities_deg.len(),
            "must hold 1 to 64 eccentricities",
        ));
    }
    for (i, &e) in eccentricities_deg.iter().enumerate() {
        if !(e.is_finite() && (0.0..=90.0).contains(&e)) {
            return Err(ParamError::new(
                "eccentricities_deg",
                e,
                "must be finite and in 0..=90 degrees",
            ));
        }
        if i > 0 && e <= eccentricities_deg[i - 1] {
            return Err(ParamError::new(
                "eccentricities_deg",
                e,
                "must increase strictly",
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// An observer that tells level `l` from full exactly when `l` is
    /// coarser than `seen_from` (deterministic).
    fn run(seen_from: u8, params: LevelStaircaseParams) -> LevelStaircase {
        let mut s = LevelStaircase::new(params).unwrap();
        let mut guess = false;
        while !s.is_finished() {
            let l = s.next_level();
            let correct = if l < seen_from {
                true
            } else {
                guess = !guess;
                guess
            };
            s.update(correct);
        }
        s
    }

    #[test]
    fn the_parameters_are_checked() {
        let ok = LevelStaircaseParams::default();
        assert!(LevelStaircase::new(ok).is_ok());
        for (bad, field) in [
            (LevelStaircaseParams { n_down: 0, ..ok }, "n_down"),
            (LevelStaircaseParams { n_down: 11, ..ok }, "n_down"),
            (
                LevelStaircaseParams {
                    max_reversals: 0,
                    ..ok
                },
                "max_reversals",
            ),
            (
                LevelStaircaseParams {
                    max_trials: 0,
                    ..ok
                },
                "max_trials",
            ),
            (
                LevelStaircaseParams {
                    max_trials: MAX_TRIALS + 1,
                    ..ok
                },
                "max_trials",
            ),
            (
                LevelStaircaseParams {
                    start_level: 0,
                    ..ok
                },
                "start_level",
            ),
            (
                LevelStaircaseParams {
                    start_level: 6,
                    ..ok
                },
                "start_level",
            ),
        ] {
            assert_eq!(LevelStaircase::new(bad).unwrap_err().field, field);
        }
        assert!((ok.target() - 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn the_grid_and_the_rows_are_checked() {
        assert_eq!(check_grid(&[]).unwrap_err().field, "eccentricities_deg");
        assert!(check_grid(&[0.0, f64::NAN]).is_err());
        assert!(check_grid(&[0.0, -1.0]).is_err());
        assert!(check_grid(&[2.0, 2.0]).is_err());
        assert!(check_grid(&[0.0, 91.0]).is_err());
        assert!(check_grid(&vec![0.0; 65]).is_err());
        assert_eq!(table_row(&[0.0, 5.0], &[5]).unwrap_err().field, "levels");
        assert_eq!(table_row(&[0.0, 5.0], &[5, 0]).unwrap_err().field, "levels");
        assert_eq!(table_row(&[0.0, 5.0], &[6, 1]).unwrap_err().field, "levels");
    }

    #[test]
    fn the_estimate_lands_between_the_levels_told_apart_and_not() {
        // Seen when coarser than `seen_from`: the coarsest unseen level is
        // `seen_from` itself.
        for seen_from in 2..=5u8 {
            let s = run(seen_from, LevelStaircaseParams::default());
            let t = s.threshold();
            assert_eq!(t.level, seen_from, "{t:?} {:?}", s.trials());
            assert!(!t.at_coarse_bound);
        }
        // Nothing seen, not even level 1: the coarse-end rule.
        let s = run(0, LevelStaircaseParams::default());
        let t = s.threshold();
        assert_eq!(t.level, 1, "{t:?} {:?}", s.trials());
        assert!(t.at_coarse_bound);
        // Everything seen (a level-5 "difference" answered too): level 5.
        let s = run(6, LevelStaircaseParams::default());
        assert_eq!(s.threshold().level, 5);
    }

    #[test]
    fn a_table_row_reads_the_thresholds_as_extents() {
        let grid = [0.0, 2.5, 5.0, 7.5, 10.0];
        // Beyond 0° level 5 is needed, beyond 2.5° and 5° level 4, beyond
        // 7.5° level 2, beyond 10° level 1: level 5 up to 2.5°, 4 up to
        // 7.5°, 3 nowhere (its extent is level 4's), 2 up to 10°.
        let r = table_row(&grid, &[5, 4, 4, 2, 1]).unwrap();
        assert_eq!(r.extents_deg, [2.5, 7.5, 7.5, 10.0, 10.0]);
        assert_eq!(r.censored, [false; 5]);
        // Non-monotone: a finer threshold farther out pushes the extent.
        let r = table_row(&grid, &[3, 2, 4, 1, 1]).unwrap();
        assert_eq!(r.extents_deg, [0.0, 7.5, 7.5, 7.5, 10.0]);
        // Still level 5 at the last point: censored at 10°.
        let r = table_row(&grid, &[5, 5, 5, 5, 5]).unwrap();
        assert_eq!(r.extents_deg, [10.0; 5]);
        assert_eq!(r.censored, [true, true, true, true, false]);
    }

    proptest! {
        #[test]
        fn any_track_stays_within_the_levels(
            n_down in 1u32..=4,
            start in 1u8..=5,
            answers in proptest::collection::vec(any::<bool>(), 1..120),
        ) {
            let params = LevelStaircaseParams {
                n_down,
                start_level: start,
                max_trials: answers.len() as u32,
                max_reversals: 1000,
                ..LevelStaircaseParams::default()
            };
            let mut s = LevelStaircase::new(params).unwrap();
            for &a in &answers {
                let l = s.next_level();
                prop_assert!((1..=5).contains(&l));
                s.update(a);
            }
            prop_assert!(s.is_finished());
            let t = s.threshold();
            prop_assert!((1..=5).contains(&t.level));
            prop_assert_eq!(t.trials, answers.len());
            for l in s.reversal_levels() {
                prop_assert!((1..=5).contains(&l));
            }
        }

        #[test]
        fn extents_grow_towards_the_coarse_levels(
            levels in proptest::collection::vec(1u8..=5, 1..12),
        ) {
            let grid: Vec<f64> = (0..levels.len()).map(|i| 2.5 * i as f64).collect();
            let r = table_row(&grid, &levels).unwrap();
            for w in r.extents_deg.windows(2) {
                prop_assert!(w[0] <= w[1]);
            }
        }
    }
}
