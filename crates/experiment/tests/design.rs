//! Design files: the shipped Murphy 2007 design and validation errors.

use experiment::design::{Counterbalancing, Design, DesignError};

const MURPHY: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../config/experiments/murphy2007-search.ron"
);

fn murphy_text() -> String {
    std::fs::read_to_string(MURPHY).expect("read murphy2007-search.ron")
}

fn field_of(text: &str) -> String {
    match Design::from_ron_str(text) {
        Err(DesignError::Invalid { field, .. }) => field,
        other => panic!("expected a validation error, got {other:?}"),
    }
}

#[test]
fn murphy_design_reproduces_chapter_7() {
    let d = Design::load(MURPHY).expect("valid design");
    assert_eq!(d.conditions.len(), 11, "11 scene types");
    assert_eq!(d.runs, 4, "4 runs");
    assert_eq!(d.total_trials(), 44, "44 trials per subject");
    assert_eq!(d.counterbalancing, Counterbalancing::LatinSquare);
    assert_eq!(d.breaks.break_after_trials, Some(6));
    assert!(d.calibration.at_start && d.calibration.validate_at_midpoint);
    assert_eq!(d.calibration.points, 9);
    assert_eq!(d.calibration.validation_points, 5);
    assert_eq!(d.stimulus.grid, (5, 5));
    let full: Vec<_> = d.conditions.iter().filter(|c| c.method == "full").collect();
    assert_eq!(full.len(), 1, "one full-resolution control");
    let mut cells: Vec<(u64, bool)> = d
        .conditions
        .iter()
        .filter(|c| c.method == "hybrid")
        .map(|c| (c.inset_deg.unwrap() as u64, c.silhouette_edges))
        .collect();
    cells.sort();
    let mut want: Vec<(u64, bool)> = [2, 5, 10, 15, 20]
        .iter()
        .flat_map(|&i| [(i, false), (i, true)])
        .collect();
    want.sort();
    assert_eq!(cells, want, "inset 2/5/10/15/20 x edges kept/discarded");
}

#[test]
fn unknown_field_is_a_parse_error() {
    let text = murphy_text().replace("runs: 4,", "runs: 4, repetitions: 4,");
    let err = Design::from_ron_str(&text).unwrap_err();
    assert!(matches!(err, DesignError::Parse(_)), "{err}");
    assert!(err.to_string().contains("repetitions"), "{err}");
}

#[test]
fn hybrid_without_inset_names_the_field() {
    let text = murphy_text().replacen("inset_deg: Some(5.0), ", "", 1);
    // NE5 is conditions[2].
    assert_eq!(field_of(&text), "conditions[2].inset_deg");
}

#[test]
fn full_with_inset_names_the_field() {
    let text = murphy_text().replace(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "full", inset_deg: Some(3.0))"#,
    );
    assert_eq!(field_of(&text), "conditions[0].inset_deg");
}

#[test]
fn negative_inset_names_the_field() {
    let text = murphy_text().replace(
        "Some(15.0), silhouette_edges: true",
        "Some(-15.0), silhouette_edges: true",
    );
    // E15 is conditions[9].
    let err = Design::from_ron_str(&text).unwrap_err();
    assert_eq!(err.field(), Some("conditions[9].inset_deg"), "{err}");
    assert!(err.to_string().contains("-15"), "{err}");
}

#[test]
fn unknown_method_names_the_field() {
    let text = murphy_text().replacen(r#"method: "hybrid""#, r#"method: "hybird""#, 1);
    assert_eq!(field_of(&text), "conditions[1].method");
}

#[test]
fn unknown_level_names_the_field() {
    let text = murphy_text().replacen(r#""inset_deg": "2","#, r#""inset_deg": "3","#, 1);
    assert_eq!(field_of(&text), "conditions[1].levels.inset_deg");
}

#[test]
fn duplicate_condition_name_names_the_field() {
    let text = murphy_text().replacen(r#"name: "E20""#, r#"name: "E15""#, 1);
    assert_eq!(field_of(&text), "conditions[10].name");
}

#[test]
fn break_after_whole_run_is_rejected() {
    let text = murphy_text().replace("Some(6)", "Some(11)");
    assert_eq!(field_of(&text), "breaks.break_after_trials");
}

#[test]
fn zero_runs_and_bad_threshold_are_rejected() {
    assert_eq!(
        field_of(&murphy_text().replace("runs: 4", "runs: 0")),
        "runs"
    );
    assert_eq!(
        field_of(
            &murphy_text().replace("accuracy_threshold_deg: 1.0", "accuracy_threshold_deg: 0.0")
        ),
        "calibration.accuracy_threshold_deg"
    );
    assert_eq!(
        field_of(&murphy_text().replace(
            "drift_check: None",
            "drift_check: Some((every_trials: 0, threshold_deg: 1.0))"
        )),
        "drift_check.every_trials"
    );
}

#[test]
fn design_round_trips_through_ron() {
    let d = Design::load(MURPHY).expect("valid design");
    let text = ron::ser::to_string(&d).expect("serialise");
    assert_eq!(Design::from_ron_str(&text).expect("reparse"), d);
}

/// A design's trial count is bounded before a plan allocates it.
#[test]
fn too_many_runs_names_the_field() {
    let text = murphy_text().replace("runs: 4,", "runs: 4000000000,");
    assert_eq!(field_of(&text), "runs");
    let ok = murphy_text().replace("runs: 4,", "runs: 9000,");
    assert!(
        Design::from_ron_str(&ok).is_ok(),
        "99 000 trials are allowed"
    );
}

#[test]
fn an_image_condition_takes_an_inset_but_no_edges() {
    let image = murphy_text().replace(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "image", inset_deg: Some(5.0))"#,
    );
    let d = Design::from_ron_str(&image).expect("an image condition with an inset is valid");
    assert_eq!(d.conditions[0].method, "image");
    let edges = murphy_text().replace(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "image", silhouette_edges: true)"#,
    );
    assert_eq!(field_of(&edges), "conditions[0].silhouette_edges");
    let bad = murphy_text().replace(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "image", inset_deg: Some(-1.0))"#,
    );
    assert_eq!(field_of(&bad), "conditions[0].inset_deg");
}
