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

/// A method name that is not an identifier is refused here; whether the
/// renderer knows a well-formed name is checked where the design is run
/// (the viewer's `config::load_design`, tested in crates/viewer). A method
/// without parameters takes no inset.
#[test]
fn unknown_method_names_the_field() {
    let text = murphy_text().replacen(r#"method: "hybrid""#, r#"method: "hy bird""#, 1);
    assert_eq!(field_of(&text), "conditions[1].method");
    let text = murphy_text().replacen(r#"method: "hybrid""#, r#"method: "layers""#, 1);
    assert_eq!(field_of(&text), "conditions[1].inset_deg");
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

/// Condition names, factor names and levels that would break a TSV row,
/// a BIDS value or a path are refused, naming the field.
#[test]
fn names_that_break_tsv_bids_or_paths_are_refused() {
    let text = murphy_text();
    for bad in [
        "E\t10", "E\n10", "E\r10", "a/../b", "../E", "n/a", "N/A", "..", ".", "-E", "E,10",
        "E\"10", "E|10", "E 10", "", "Ë10", "E/10", "E\\10",
    ] {
        let name = format!("{bad:?}");
        let t = text.replacen("name: \"E10\"", &format!("name: {name}"), 1);
        assert_eq!(field_of(&t), "conditions[8].name", "{bad:?}");
        let t = text.replacen(
            "\"kept\", \"discarded\"",
            &format!("{name}, \"discarded\""),
            1,
        );
        assert_eq!(field_of(&t), "factors[1].levels[0]", "{bad:?}");
    }
    let long = "E".repeat(33);
    let t = text.replacen("name: \"E10\"", &format!("name: \"{long}\""), 1);
    assert_eq!(field_of(&t), "conditions[8].name");
    for good in ["E10", "NE2b", "ctl", "inset-2.5", "A+B", "x_1"] {
        let t = text.replacen("name: \"E10\"", &format!("name: {good:?}"), 1);
        Design::from_ron_str(&t).unwrap_or_else(|e| panic!("{good}: {e}"));
    }
}

proptest::proptest! {
    /// Whatever the name: accepted exactly when it follows the rule, and an
    /// accepted name has nothing a TSV, CSV, BIDS value or path would split
    /// or read as a separator.
    #[test]
    fn a_condition_name_is_accepted_iff_it_follows_the_rule(name in "\\PC{0,3}|[A-Za-z0-9._+/ \t\n-]{0,40}") {
        let t = murphy_text().replacen("name: \"E10\"", &format!("name: {name:?}"), 1);
        let rule = !name.is_empty()
            && name.len() <= 32
            && name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.+".contains(c))
            && name.starts_with(|c: char| c.is_ascii_alphanumeric());
        let duplicate = ["control", "NE2", "NE5", "NE10", "NE15", "NE20", "E2", "E5", "E15", "E20"].contains(&name.as_str());
        match Design::from_ron_str(&t) {
            Ok(_) => {
                proptest::prop_assert!(rule, "{:?} accepted", name);
                proptest::prop_assert!(!name.contains(['\t', '\n', '\r', '/', '\\', ',', '"', '|']));
            }
            Err(e) => proptest::prop_assert!(!rule || duplicate, "{:?}: {}", name, e),
        }
    }
}

/// The seed design with `name`, `calibration.points`,
/// `calibration.validation_points` and `drift_check` replaced.
fn variant(name: &str, points: u32, validation: u32, drift: Option<u32>) -> String {
    let text = murphy_text()
        .replace(
            "name: \"murphy2007-search\"",
            &format!("name: {}", ron::to_string(name).expect("a RON string")),
        )
        .replace("points: 9,", &format!("points: {points},"))
        .replace(
            "validation_points: 5,",
            &format!("validation_points: {validation},"),
        );
    match drift {
        None => text,
        Some(k) => text.replace(
            "drift_check: None",
            &format!("drift_check: Some((every_trials: {k}, threshold_deg: 1.5))"),
        ),
    }
}

#[test]
fn a_name_that_would_leave_the_output_folder_is_refused() {
    for bad in ["../escaped", "/tmp/abs", "a/b", ".", "..", "", "a b", "x.y"] {
        let text = variant(bad, 9, 5, None);
        assert_eq!(field_of(&text), "name", "{bad:?}");
    }
    let err = Design::from_ron_str(&variant("../escaped", 9, 5, None)).unwrap_err();
    assert!(err.to_string().contains("not allowed"), "{err}");
    assert!(Design::from_ron_str(&variant("murphy_2007-v2", 9, 5, None)).is_ok());
}

#[test]
fn point_counts_have_upper_bounds() {
    let t = variant("murphy2007-search", 1_000_000, 5, None);
    assert_eq!(field_of(&t), "calibration.points");
    let t = variant("murphy2007-search", 9, 1_000_000, None);
    assert_eq!(field_of(&t), "calibration.validation_points");
    // A drift check must fall within the session (44 trials).
    assert_eq!(
        field_of(&variant("murphy2007-search", 9, 5, Some(44))),
        "drift_check.every_trials"
    );
    assert!(Design::from_ron_str(&variant("murphy2007-search", 9, 5, Some(1))).is_ok());
    assert!(Design::from_ron_str(&variant("murphy2007-search", 9, 5, Some(43))).is_ok());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(fixtures::proptest_cases(200)))]

    /// An accepted name is exactly one plain folder under any output
    /// folder: never `..`, a root, a separator or `.`.
    #[test]
    fn an_accepted_name_is_one_folder_inside_out(
        name in "[a-zA-Z0-9_ ./\\\\:-]{0,10}|/[a-z]{1,5}|\\.\\.(/[a-z]{0,4})*|[a-z]{70}",
    ) {
        if let Ok(d) = Design::from_ron_str(&variant(&name, 9, 5, None)) {
            let out = std::path::Path::new("/data/out");
            let p = out.join(&d.name);
            let rel = p.strip_prefix(out).expect("inside out");
            let parts: Vec<_> = rel.components().collect();
            proptest::prop_assert_eq!(parts.len(), 1);
            proptest::prop_assert!(matches!(parts[0], std::path::Component::Normal(_)));
            proptest::prop_assert!(!d.name.contains(['.', '/', '\\', ':', ' ']));
        }
    }

    /// Calibration and validation targets: accepted exactly when they
    /// make one of the grids (5, or a square number 4 to 25).
    #[test]
    fn point_counts_are_grids_of_at_most_25(
        points in proptest::prop_oneof![0u32..40, 0u32..=u32::MAX],
        validation in proptest::prop_oneof![0u32..40, 0u32..=u32::MAX],
    ) {
        let grid = |n: u32| [4, 5, 9, 16, 25].contains(&n);
        let r = Design::from_ron_str(&variant("murphy2007-search", points, validation, None));
        match r {
            Ok(_) => proptest::prop_assert!(grid(points) && grid(validation)),
            Err(DesignError::Invalid { field, .. }) => {
                proptest::prop_assert!(!(grid(points) && grid(validation)));
                let want = if grid(points) { "calibration.validation_points" } else { "calibration.points" };
                proptest::prop_assert_eq!(field, want);
            }
            Err(e) => proptest::prop_assert!(false, "{e}"),
        }
    }
}

/// The seed design writes its reference out (the target mesh at the
/// centre, at full resolution), and a design without the field gets the
/// same; `None` is no reference.
#[test]
fn the_reference_defaults_to_the_seeds_and_none_turns_it_off() {
    use experiment::design::{Reference, ReferenceCell, ReferenceDetail};
    let seed = Reference {
        at: ReferenceCell::Centre,
        detail: ReferenceDetail::Full,
    };
    let d = Design::load(MURPHY).expect("valid design");
    assert_eq!(d.stimulus.reference, Some(seed));
    assert_eq!(d.stimulus.reference_cell(), Some((2, 2)));
    let text = murphy_text();
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("reference:"))
        .expect("the seed design writes the field");
    let absent = Design::from_ron_str(&text.replace(line, "")).expect("valid without it");
    assert_eq!(absent.stimulus.reference, Some(seed));
    let none = Design::from_ron_str(&text.replace(line, "reference: None,")).expect("None");
    assert_eq!(none.stimulus.reference, None);
    assert_eq!(none.stimulus.reference_cell(), None);
    let cell = text.replace(
        line,
        "reference: Some((at: Cell(4, 0), detail: AsCondition)),",
    );
    let d = Design::from_ron_str(&cell).expect("a cell");
    assert_eq!(d.stimulus.reference_cell(), Some((4, 0)));
}

/// An even grid has no centre: `Centre` (written or the default) is
/// refused naming the field and telling what to give instead; a `Cell`
/// outside the grid and a one-cell grid are refused too.
#[test]
fn a_reference_that_does_not_fit_the_grid_names_the_field() {
    let text = murphy_text();
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("reference:"))
        .expect("the field");
    let even = text.replace("grid: (5, 5)", "grid: (5, 6)");
    let err = Design::from_ron_str(&even).unwrap_err();
    assert_eq!(err.field(), Some("stimulus.reference.at"), "{err}");
    assert!(
        err.to_string().contains("no centre cell")
            && err.to_string().contains("Cell(row, column)")
            && err.to_string().contains("None"),
        "{err}"
    );
    // The default is the seed's Centre: the same error without the field.
    let err = Design::from_ron_str(&even.replace(line, "")).unwrap_err();
    assert_eq!(err.field(), Some("stimulus.reference.at"), "{err}");
    // An even grid with a cell, or none, is fine.
    let cell = even.replace(line, "reference: Some((at: Cell(2, 3), detail: Full)),");
    assert_eq!(
        Design::from_ron_str(&cell)
            .expect("valid")
            .stimulus
            .reference_cell(),
        Some((2, 3))
    );
    Design::from_ron_str(&even.replace(line, "reference: None,")).expect("valid");
    let outside = text.replace(line, "reference: Some((at: Cell(5, 0), detail: Full)),");
    let err = Design::from_ron_str(&outside).unwrap_err();
    assert_eq!(err.field(), Some("stimulus.reference.at"), "{err}");
    assert!(err.to_string().contains("outside the 5x5 grid"), "{err}");
    let one = text
        .replace("grid: (5, 5)", "grid: (1, 1)")
        .replace(line, "reference: Some((at: Cell(0, 0), detail: Full)),");
    let err = Design::from_ron_str(&one).unwrap_err();
    assert_eq!(err.field(), Some("stimulus.reference"), "{err}");
    assert!(err.to_string().contains("at least 2 cells"), "{err}");
}

/// A condition's contrast overrides the design's for the CSF methods only,
/// in (0, 1]; a triangle budget is for simplify only, 1 to 10⁹.
#[test]
fn condition_contrast_and_budget_name_the_field() {
    let text = murphy_text();
    let with = |from: &str, to: &str| text.replacen(from, to, 1);
    let ok = with(
        r#"silhouette_edges: false, levels: {"inset_deg": "2""#,
        r#"silhouette_edges: false, contrast: Some(0.5), levels: {"inset_deg": "2""#,
    );
    let d = Design::from_ron_str(&ok).expect("valid");
    assert_eq!(d.conditions[1].contrast, Some(0.5));
    assert_eq!(d.conditions[1].contrast_or(d.contrast), 0.5);
    assert_eq!(d.conditions[2].contrast_or(d.contrast), 0.25);
    for bad in ["0.0", "1.5", "-0.2"] {
        let t = ok.replace("contrast: Some(0.5)", &format!("contrast: Some({bad})"));
        let err = Design::from_ron_str(&t).unwrap_err();
        assert_eq!(err.field(), Some("conditions[1].contrast"), "{bad}: {err}");
    }
    let full = with(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "full", contrast: Some(0.5))"#,
    );
    assert_eq!(field_of(&full), "conditions[0].contrast");
    let budget = with(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "full", triangle_budget: Some(1000))"#,
    );
    assert_eq!(field_of(&budget), "conditions[0].triangle_budget");
    let simplify = with(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "simplify", triangle_budget: Some(1000))"#,
    );
    assert_eq!(
        Design::from_ron_str(&simplify).expect("valid").conditions[0].triangle_budget,
        Some(1000)
    );
    let zero = simplify.replace("Some(1000)", "Some(0)");
    assert_eq!(field_of(&zero), "conditions[0].triangle_budget");
    let lod = with(
        r#"(name: "control", method: "full")"#,
        r#"(name: "control", method: "lod", contrast: Some(0.5))"#,
    );
    assert_eq!(field_of(&lod), "conditions[0].contrast");
}

/// `config/experiments/families-comparison.ron` (Murphy 2007 §8.1's
/// comparison): it loads, plans, names only known methods, has the
/// control, and gives each CSF family an imperceptible (C = 1) and an
/// aggressive (C < 1) condition and simplify its two modes.
#[test]
fn the_families_comparison_loads_and_plans() {
    let d = Design::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/experiments/families-comparison.ron"
    ))
    .expect("valid design");
    // (That the renderer knows every method is checked by `experiment
    // plan` on this file, crates/viewer/tests/experiment_cli.rs.)
    let families = ["full", "hybrid", "image", "layers", "simplify", "lod"];
    for c in &d.conditions {
        assert!(
            families.contains(&c.method.as_str()),
            "{}: {}",
            c.name,
            c.method
        );
    }
    let of = |m: &str| -> Vec<&experiment::design::Condition> {
        d.conditions.iter().filter(|c| c.method == m).collect()
    };
    assert_eq!(of("full").len(), 1);
    for m in ["hybrid", "image", "layers"] {
        let mut k: Vec<f64> = of(m).iter().map(|c| c.contrast_or(d.contrast)).collect();
        k.sort_by(f64::total_cmp);
        assert_eq!(k, [0.25, 1.0], "{m}");
    }
    let budgets: Vec<Option<u64>> = of("simplify").iter().map(|c| c.triangle_budget).collect();
    assert_eq!(budgets.len(), 2);
    assert!(budgets.contains(&None) && budgets.iter().any(|b| b.is_some()));
    assert_eq!(of("lod").len(), 1);
    // Ten conditions: a Williams design of 10 rows; every participant's
    // plan has every condition once a run and the reference at the centre.
    assert_eq!(d.counterbalancing, Counterbalancing::Williams);
    assert_eq!(experiment::plan::orders(&d).len(), 10);
    for p in 0..10 {
        let trials = experiment::plan(&d, p).expect("plan");
        // Two practice trials on the control, then the runs.
        assert_eq!(d.practice_trials(), 2);
        assert_eq!(trials.len(), 2 + d.total_trials());
        assert!(trials[..2]
            .iter()
            .all(|t| t.practice && t.condition_name == "control"));
        let trials = &trials[2..];
        for run in trials.chunks(d.conditions.len()) {
            let mut c: Vec<usize> = run.iter().map(|t| t.condition).collect();
            c.sort();
            assert_eq!(c, (0..d.conditions.len()).collect::<Vec<_>>());
        }
        assert!(trials
            .iter()
            .all(|t| t.reference_cell == Some((2, 2)) && t.target_cell != (2, 2)));
    }
}

/// `practice` names its field when it asks for no trials, too many, or a
/// condition the design does not have.
#[test]
fn bad_practice_names_the_field() {
    let with = |practice: &str| {
        murphy_text().replace("practice: None,", &format!("practice: Some({practice}),"))
    };
    let ok = Design::from_ron_str(&with("(trials: 4, condition: \"control\")")).expect("valid");
    assert_eq!(ok.practice_trials(), 4);
    assert_eq!(ok.practice_condition(), Some(0));
    assert_eq!(ok.total_trials(), 44, "practice is not counted");
    assert_eq!(
        field_of(&with("(trials: 0, condition: \"control\")")),
        "practice.trials"
    );
    assert_eq!(
        field_of(&with("(trials: 1001, condition: \"control\")")),
        "practice.trials"
    );
    assert_eq!(
        field_of(&with("(trials: 2, condition: \"E99\")")),
        "practice.condition"
    );
}

/// The guide's design-file reference (docs/src/experiments/design-reference.md,
/// written by scripts/design-reference.py) lists exactly the fields and
/// variants the code reads: serde's own lists, captured by a deserializer
/// that records what it is asked for.
mod reference_page {
    use experiment::design::{
        BidsMetadata, Breaks, Calibration, Condition, Counterbalancing, Design, DriftCheck, Factor,
        Practice, Reference, ReferenceCell, ReferenceDetail, Response, RunOrder, Stimulus,
    };
    use serde::de::{self, DeserializeOwned, Visitor};
    use std::collections::{BTreeMap, BTreeSet};

    const PAGE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../docs/src/experiments/design-reference.md"
    );

    /// Records the name and field (or variant) list serde asks for, then
    /// stops the deserialisation.
    struct Introspect<'a>(&'a mut Option<(&'static str, &'static [&'static str])>);

    impl<'de> de::Deserializer<'de> for Introspect<'_> {
        type Error = de::value::Error;

        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
            Err(de::Error::custom("introspection only"))
        }

        fn deserialize_struct<V: Visitor<'de>>(
            self,
            name: &'static str,
            fields: &'static [&'static str],
            _: V,
        ) -> Result<V::Value, Self::Error> {
            *self.0 = Some((name, fields));
            Err(de::Error::custom("introspection only"))
        }

        fn deserialize_enum<V: Visitor<'de>>(
            self,
            name: &'static str,
            variants: &'static [&'static str],
            _: V,
        ) -> Result<V::Value, Self::Error> {
            *self.0 = Some((name, variants));
            Err(de::Error::custom("introspection only"))
        }

        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
            bytes byte_buf option unit unit_struct newtype_struct seq tuple
            tuple_struct map identifier ignored_any
        }
    }

    fn names<T: DeserializeOwned>() -> (String, BTreeSet<String>) {
        let mut seen = None;
        let _ = T::deserialize(Introspect(&mut seen));
        let (name, fields) = seen.expect("a struct or enum asks for its fields");
        (
            name.to_string(),
            fields.iter().map(|f| f.to_string()).collect(),
        )
    }

    /// `## \`Name\`` sections and the first cell of their table rows.
    fn page_sections() -> BTreeMap<String, BTreeSet<String>> {
        let text = std::fs::read_to_string(PAGE).expect("read the design-file reference page");
        let mut sections = BTreeMap::new();
        let mut current: Option<String> = None;
        for line in text.lines() {
            if let Some(name) = line.strip_prefix("## `") {
                let name = name.trim_end_matches('`').to_string();
                sections.insert(name.clone(), BTreeSet::new());
                current = Some(name);
            } else if let (Some(name), Some(row)) = (&current, line.strip_prefix("| `")) {
                let cell = row.split('`').next().unwrap_or_default();
                let ident = cell.split('(').next().unwrap_or_default().to_string();
                sections.get_mut(name).expect("section").insert(ident);
            }
        }
        sections
    }

    #[test]
    fn design_reference_lists_every_field() {
        let code: BTreeMap<String, BTreeSet<String>> = [
            names::<Design>(),
            names::<Factor>(),
            names::<Condition>(),
            names::<Stimulus>(),
            names::<Reference>(),
            names::<Response>(),
            names::<Breaks>(),
            names::<Calibration>(),
            names::<DriftCheck>(),
            names::<Practice>(),
            names::<BidsMetadata>(),
            names::<Counterbalancing>(),
            names::<RunOrder>(),
            names::<ReferenceCell>(),
            names::<ReferenceDetail>(),
        ]
        .into_iter()
        .collect();
        let page = page_sections();
        assert_eq!(
            page, code,
            "docs/src/experiments/design-reference.md is out of date with \
             crates/experiment/src/design.rs: run scripts/design-reference.py > \
             docs/src/experiments/design-reference.md"
        );
    }
}
