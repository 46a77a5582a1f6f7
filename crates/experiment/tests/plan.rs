//! Trial plans for the Murphy 2007 design.

use experiment::design::{Counterbalancing, Design, RunOrder};
use experiment::plan::{plan, trial_seed, Step};
use std::collections::HashSet;

fn murphy() -> Design {
    Design::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/experiments/murphy2007-search.ron"
    ))
    .expect("valid design")
}

#[test]
fn murphy_plan_has_44_trials_with_breaks_and_midpoint_validation() {
    let d = murphy();
    let trials = plan(&d, 0).expect("plan");
    assert_eq!(trials.len(), 44);
    for (i, t) in trials.iter().enumerate() {
        assert_eq!(t.index, i);
        assert_eq!(t.run, i / 11);
        assert_eq!(t.trial_in_run, i % 11);
        assert_eq!(t.condition_name, d.conditions[t.condition].name);
        assert!(t.target_cell.0 < 5 && t.target_cell.1 < 5);
    }
    assert_eq!(trials[0].before, vec![Step::Calibration, Step::Validation]);
    // Break after 6 trials of every run: before trial_in_run 6.
    for run in 0..4 {
        assert_eq!(trials[run * 11 + 6].before, vec![Step::Break]);
    }
    assert_eq!(trials[11].before, vec![Step::RunBreak]);
    assert_eq!(
        trials[22].before,
        vec![Step::RunBreak, Step::MidpointValidation]
    );
    assert_eq!(trials[33].before, vec![Step::RunBreak]);
    let marked: usize = trials.iter().filter(|t| !t.before.is_empty()).count();
    assert_eq!(marked, 1 + 4 + 3, "start, 4 in-run breaks, 3 run breaks");
    // Each run shows every condition once.
    for run in trials.chunks(11) {
        let set: HashSet<usize> = run.iter().map(|t| t.condition).collect();
        assert_eq!(set.len(), 11);
    }
}

#[test]
fn participants_follow_latin_square_rows() {
    let d = murphy();
    // Position j across 11 participants holds every condition once.
    let plans: Vec<_> = (0..11).map(|p| plan(&d, p).expect("plan")).collect();
    for j in 0..11 {
        let set: HashSet<usize> = plans.iter().map(|t| t[j].condition).collect();
        assert_eq!(set.len(), 11, "position {j}");
    }
    // Participant 11 wraps to row 0.
    let p11: Vec<usize> = plan(&d, 11).unwrap().iter().map(|t| t.condition).collect();
    let p0: Vec<usize> = plans[0].iter().map(|t| t.condition).collect();
    assert_eq!(p11, p0);
    // Repeat: every run uses the same order.
    assert_eq!(p0[..11], p0[11..22]);
}

#[test]
fn rotate_and_williams_change_the_orders() {
    let mut d = murphy();
    d.run_order = RunOrder::Rotate;
    let c: Vec<usize> = plan(&d, 0).unwrap().iter().map(|t| t.condition).collect();
    assert_ne!(c[..11], c[11..22]);
    d.counterbalancing = Counterbalancing::Williams;
    // 11 is odd: 22 rows, so participants 0 and 11 differ.
    let a: Vec<usize> = plan(&d, 0).unwrap().iter().map(|t| t.condition).collect();
    let b: Vec<usize> = plan(&d, 11).unwrap().iter().map(|t| t.condition).collect();
    assert_ne!(a, b);
}

#[test]
fn seeds_are_deterministic_and_distinct() {
    let d = murphy();
    let a = plan(&d, 3).unwrap();
    assert_eq!(a, plan(&d, 3).unwrap(), "same inputs, same plan");
    let b = plan(&d, 4).unwrap();
    let seeds: HashSet<u64> = a.iter().chain(b.iter()).map(|t| t.seed).collect();
    assert_eq!(
        seeds.len(),
        88,
        "no seed repeats across trials or participants"
    );
    assert_eq!(a[5].seed, trial_seed(d.stimulus.seed, 3, 5));
    // Pinned value: the seed derivation must not change silently.
    assert_eq!(trial_seed(2007, 0, 0), 8_695_258_141_008_405_908);
    assert_eq!(trial_seed(0, 0, 0), 7_043_161_839_319_721_933);
    assert_ne!(trial_seed(2007, 0, 1), trial_seed(2007, 1, 0));
}

/// With the seed's reference at the centre the target's cell is drawn
/// uniformly among the 24 other cells, never the centre.
#[test]
fn target_cells_cover_the_grid_but_the_reference() {
    let d = murphy();
    let mut count = [0usize; 25];
    for p in 0..100 {
        for t in plan(&d, p).unwrap() {
            assert_eq!(t.reference_cell, Some((2, 2)));
            count[(t.target_cell.0 * 5 + t.target_cell.1) as usize] += 1;
        }
    }
    assert_eq!(count[12], 0, "the centre is never the target's cell");
    // 4400 draws, 183 expected per other cell; a fair draw stays well
    // within ±40%.
    assert!(
        count
            .iter()
            .enumerate()
            .all(|(k, &c)| k == 12 || (110..=257).contains(&c)),
        "{count:?}"
    );
}

/// Without a reference (`reference: None`) every cell, the centre
/// included, may be the target's, as before the field existed.
#[test]
fn without_a_reference_the_centre_may_be_the_target() {
    let mut d = murphy();
    d.stimulus.reference = None;
    let mut centre = 0;
    for p in 0..100 {
        for t in plan(&d, p).unwrap() {
            assert_eq!(t.reference_cell, None);
            centre += usize::from(t.target_cell == (2, 2));
            // The target mesh at the target's cell only.
            let at = (t.target_cell.0 * 5 + t.target_cell.1) as usize;
            for (c, &m) in t.cells.iter().enumerate() {
                assert_eq!(m == t.target_mesh, c == at);
            }
        }
    }
    assert!((106..=246).contains(&centre), "{centre}");
}

/// A reference at another cell (`Cell(r, c)`) holds the target mesh and is
/// never the target's cell.
#[test]
fn a_reference_cell_holds_the_target_mesh_and_is_never_the_target() {
    use experiment::design::{Reference, ReferenceCell, ReferenceDetail};
    let mut d = murphy();
    d.stimulus.reference = Some(Reference {
        at: ReferenceCell::Cell(0, 3),
        detail: ReferenceDetail::AsCondition,
    });
    for p in 0..50 {
        for t in plan(&d, p).unwrap() {
            assert_eq!(t.reference_cell, Some((0, 3)));
            assert_ne!(t.target_cell, (0, 3));
            assert_eq!(t.cells[3], t.target_mesh);
        }
    }
}

/// A plan written before `reference_cell` existed still loads (no
/// reference).
#[test]
fn an_old_plan_without_the_reference_loads() {
    let t = &plan(&murphy(), 0).unwrap()[0];
    let mut v = serde_json::to_value(t).unwrap();
    v.as_object_mut().unwrap().remove("reference_cell");
    let old: experiment::Trial = serde_json::from_value(v).expect("an old plan loads");
    assert_eq!(old.reference_cell, None);
    assert_eq!(old.target_cell, t.target_cell);
}

#[test]
fn drift_checks_skip_validated_trials() {
    let mut d = murphy();
    d.drift_check = Some(experiment::design::DriftCheck {
        every_trials: 11,
        threshold_deg: 1.0,
    });
    let t = plan(&d, 0).unwrap();
    assert_eq!(t[11].before, vec![Step::RunBreak, Step::DriftCheck]);
    assert_eq!(t[22].before, vec![Step::RunBreak, Step::MidpointValidation]);
    assert_eq!(t[33].before, vec![Step::RunBreak, Step::DriftCheck]);
    assert!(!t[0].before.contains(&Step::DriftCheck));
}

#[test]
fn invalid_design_is_rejected_by_plan() {
    let mut d = murphy();
    d.runs = 0;
    assert!(plan(&d, 0).is_err());
}

proptest::proptest! {
    /// Any participant, either design, either run order: every run shows
    /// every condition exactly once and the plan is reproducible.
    #[test]
    fn every_run_is_a_permutation(participant in 0usize..10_000, williams in proptest::bool::ANY, rotate in proptest::bool::ANY) {
        let mut d = murphy();
        if williams { d.counterbalancing = Counterbalancing::Williams; }
        if rotate { d.run_order = RunOrder::Rotate; }
        let trials = plan(&d, participant).unwrap();
        proptest::prop_assert_eq!(trials.len(), 44);
        for run in trials.chunks(11) {
            let mut c: Vec<usize> = run.iter().map(|t| t.condition).collect();
            c.sort();
            proptest::prop_assert_eq!(c, (0..11).collect::<Vec<_>>());
        }
        proptest::prop_assert_eq!(trials, plan(&d, participant).unwrap());
    }
}

/// Murphy 2007 §7.1.4: each mesh is the target the same number of times;
/// the target mesh sits at the target cell and at the reference (the
/// centre) and nowhere else: exactly two cells, the others drawn from the
/// non-targets.
#[test]
fn each_mesh_is_the_target_equally_often_and_only_once_per_display() {
    let d = murphy();
    for participant in [0usize, 1, 7, 123] {
        let trials = plan(&d, participant).expect("plan");
        let mut counts = [0usize; 4];
        for t in &trials {
            counts[t.target_mesh as usize] += 1;
            assert_eq!(t.cells.len(), 25);
            let at = (t.target_cell.0 * 5 + t.target_cell.1) as usize;
            assert_ne!(at, 12, "trial {}: the centre is the reference", t.index);
            for (c, &m) in t.cells.iter().enumerate() {
                assert!(m < 4);
                assert_eq!(
                    m == t.target_mesh,
                    c == at || c == 12,
                    "trial {} cell {c}",
                    t.index
                );
            }
            assert_eq!(t.cells.iter().filter(|&&m| m == t.target_mesh).count(), 2);
        }
        assert_eq!(counts, [11, 11, 11, 11], "participant {participant}");
    }
    // The pool is shuffled: not the same target order for two participants.
    let a: Vec<u32> = plan(&d, 0)
        .expect("plan")
        .iter()
        .map(|t| t.target_mesh)
        .collect();
    let b: Vec<u32> = plan(&d, 1)
        .expect("plan")
        .iter()
        .map(|t| t.target_mesh)
        .collect();
    assert_ne!(a, b);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(fixtures::proptest_cases(64)))]

    /// Any mesh count and trial count: the pool's counts differ by at most
    /// one, and the distractors use every non-target mesh over many cells.
    #[test]
    fn target_pool_is_balanced(meshes in 2u32..9, total in 0usize..200, seed in proptest::num::u64::ANY) {
        let pool = experiment::plan::target_pool(seed, 3, meshes, total);
        proptest::prop_assert_eq!(pool.len(), total);
        let mut counts = vec![0usize; meshes as usize];
        for &m in &pool {
            proptest::prop_assert!(m < meshes);
            counts[m as usize] += 1;
        }
        let (lo, hi) = (counts.iter().min().copied().unwrap_or(0), counts.iter().max().copied().unwrap_or(0));
        proptest::prop_assert!(hi - lo <= 1, "{:?}", counts);
    }
}

/// Practice trials (Murphy 2007 §7.1.5's demonstration, `practice`): they
/// come first, show the practice condition, carry the session's first
/// calibration, and are marked; the experimental trials that follow keep
/// exactly the stimuli, conditions and schedule they have without
/// practice, shifted by the practice count, with the "practice over"
/// screen before the first.
#[test]
fn practice_trials_come_first_and_leave_the_experiment_unchanged() {
    let d = murphy();
    let mut p = d.clone();
    p.practice = Some(experiment::design::Practice {
        trials: 5,
        condition: "control".into(),
    });
    for participant in [0, 3, 17] {
        let without = plan(&d, participant).expect("plan");
        let with = plan(&p, participant).expect("plan with practice");
        assert_eq!(with.len(), without.len() + 5);
        for (k, t) in with[..5].iter().enumerate() {
            assert!(t.practice);
            assert_eq!((t.index, t.run, t.trial_in_run), (k, 0, k));
            assert_eq!(t.condition_name, "control");
            assert_eq!(t.reference_cell, Some((2, 2)));
            assert_ne!(t.target_cell, (2, 2));
            let calibration = if k == 0 {
                vec![Step::Calibration, Step::Validation]
            } else {
                vec![]
            };
            assert_eq!(t.before, calibration, "practice trial {k}");
            // Its seed is none of the experimental trials'.
            assert!(without.iter().all(|e| e.seed != t.seed));
        }
        // Four meshes over five practice trials: every mesh is shown.
        let shown: HashSet<u32> = with[..5].iter().map(|t| t.target_mesh).collect();
        assert_eq!(shown.len(), 4);
        for (a, b) in without.iter().zip(&with[5..]) {
            assert!(!b.practice);
            assert_eq!(b.index, a.index + 5);
            let expected_before: Vec<Step> = if a.index == 0 {
                vec![Step::PracticeOver]
            } else {
                a.before.clone()
            };
            assert_eq!(b.before, expected_before, "trial {}", a.index);
            assert_eq!(
                (
                    a.run,
                    a.trial_in_run,
                    a.condition,
                    a.seed,
                    a.target_cell,
                    a.target_mesh,
                    &a.cells
                ),
                (
                    b.run,
                    b.trial_in_run,
                    b.condition,
                    b.seed,
                    b.target_cell,
                    b.target_mesh,
                    &b.cells
                )
            );
        }
    }
}
