//! `experiment export-bids`'s dataset metadata: the design's `bids` block
//! (the session's design.ron, or `--design`), each flag laid over it, and
//! errors that name the design file's line and field, or the flag.

mod common;

use std::path::{Path, PathBuf};

use common::{gazecast, Run};
use experiment::session::{
    DisplayInfo, SampleRow, SessionInfo, TrialRow, TsvLog, DESIGN_RON, SAMPLES_TSV, SESSION_JSON,
    TRIALS_TSV,
};
use serde_json::Value;

fn seed_design() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    std::fs::read_to_string(root.join("config/experiments/murphy2007-search.ron"))
        .expect("the seed design")
}

/// The seed design with `bids: Some((block))` before its last `)`.
fn with_bids(block: &str) -> String {
    let text = seed_design();
    let end = text.rfind(')').expect("closing parenthesis");
    format!(
        "{}    bids: Some((\n{block}\n    )),\n{}",
        &text[..end],
        &text[end..]
    )
}

/// A small session folder (one sitting, 50 samples, one trial) whose
/// design.ron is `design`.
fn session(root: &Path, design: &str) -> PathBuf {
    let dir = root.join("sub-P01");
    std::fs::create_dir_all(&dir).expect("mkdir");
    std::fs::write(dir.join(DESIGN_RON), design).expect("design");
    SessionInfo {
        participant: "P01".into(),
        participant_index: 0,
        design_name: "murphy2007-search".into(),
        software: "gazecast test".into(),
        display: DisplayInfo {
            name: "LCD".into(),
            width_px: 1280,
            height_px: 1024,
            width_mm: 337.9,
            height_mm: 270.3,
            distance_mm: 540.0,
        },
        tracker: "mouse".into(),
        tracker_rate_hz: Some(100.0),
        started_unix_s: 1.7e9,
        synthetic: false,
        notes: vec![],
        sittings: Vec::new(),
    }
    .write(&dir.join(SESSION_JSON))
    .expect("session.json");
    let mut log = TsvLog::<SampleRow>::append_to(dir.join(SAMPLES_TSV)).expect("samples");
    for i in 0..50u64 {
        log.write(&SampleRow {
            sitting: 1,
            mapped_us: 1_000_000 + i * 10_000,
            device_us: Some(i * 10_000),
            arrival_us: 1_000_500 + i * 10_000,
            time_order: if i == 0 { "first" } else { "ok" }.into(),
            segment: 0,
            trial: Some(0),
            phase: "search".into(),
            raw_x: None,
            raw_y: None,
            x_px: Some(640.0),
            y_px: Some(512.0),
            left_x_px: None,
            left_y_px: None,
            left_pupil: None,
            right_x_px: None,
            right_y_px: None,
            right_pupil: None,
        })
        .expect("sample");
    }
    let mut trials = TsvLog::<TrialRow>::append_to(dir.join(TRIALS_TSV)).expect("trials");
    trials
        .write(&TrialRow {
            participant: "P01".into(),
            sitting: 1,
            run: 0,
            trial: 0,
            trial_in_run: 0,
            condition: "control".into(),
            method: "full".into(),
            inset_deg: None,
            silhouette_edges: false,
            target_mesh: 0,
            target_row: 1,
            target_col: 1,
            search_onset_us: 1_050_000,
            response_us: 1_400_000,
            rt_s: 0.35,
            clicked_row: None,
            clicked_col: None,
            correct: None,
            frames: 20,
            frames_late: 0,
            mean_rays: 1.0,
            synthetic: false,
            plan: None,
            reference_row: None,
            reference_col: None,
            mean_triangles: None,
            mean_render_ms: None,
            p95_render_ms: None,
            practice: false,
        })
        .expect("trial");
    dir
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("json")
}

const BLOCK: &str = r#"        authors: ["Design Author", "Second Author"],
        license: Some("CC-BY-4.0"),
        instructions: Some("Find the target."),
        institution_name: Some("Design University"),"#;

#[test]
fn the_designs_metadata_and_the_flags_reach_the_dataset() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = session(tmp.path(), &with_bids(BLOCK));
    let out = tmp.path().join("bids");
    gazecast()
        .args(["experiment", "export-bids"])
        .arg(&dir)
        .arg("--out")
        .arg(&out)
        .args([
            "--license",
            "CC0-1.0",
            "--institution-address",
            "1 Flag Street",
        ])
        .succeed();
    let dd = json(&out.join("dataset_description.json"));
    assert_eq!(
        dd["Authors"],
        serde_json::json!(["Design Author", "Second Author"])
    );
    assert_eq!(dd["License"], "CC0-1.0", "the flag wins");
    let side = json(&out.join("sub-P01/beh/sub-P01_task-search_run-1_recording-eye1_physio.json"));
    assert_eq!(side["InstitutionName"], "Design University");
    assert_eq!(side["InstitutionAddress"], "1 Flag Street");
    assert_eq!(side["Instructions"], "Find the target.");
    assert_eq!(side["TaskName"], "search");

    // --design takes the block from another design file; --author
    // replaces the list.
    let other = tmp.path().join("other.ron");
    std::fs::write(
        &other,
        with_bids(r#"        authors: ["Other Author"], institution_name: Some("Other Place"),"#),
    )
    .expect("write");
    gazecast()
        .args(["experiment", "export-bids"])
        .arg(&dir)
        .arg("--out")
        .arg(&out)
        .arg("--design")
        .arg(&other)
        .args(["--author", "Flag One", "--author", "Flag Two"])
        .succeed();
    let dd = json(&out.join("dataset_description.json"));
    assert_eq!(dd["Authors"], serde_json::json!(["Flag One", "Flag Two"]));
    assert!(dd.get("License").is_none(), "{dd}");
    let side = json(&out.join("sub-P01/beh/sub-P01_task-search_run-1_recording-eye1_physio.json"));
    assert_eq!(side["InstitutionName"], "Other Place");
}

#[test]
fn bad_metadata_names_the_design_line_and_field_or_the_flag() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let design = with_bids("        authors: [\"A\", \"\"],");
    let line = design
        .lines()
        .position(|l| l.contains("authors: [\"A\""))
        .expect("the line")
        + 1;
    let dir = session(tmp.path(), &design);
    let out = tmp.path().join("bids");
    let run = |extra: &[&str]| {
        gazecast()
            .args(["experiment", "export-bids"])
            .arg(&dir)
            .arg("--out")
            .arg(&out)
            .args(extra)
            .output()
            .expect("runs")
    };
    let o = run(&[]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(&format!("design.ron:{line}")) && err.contains("bids.authors[1]"),
        "{err}"
    );
    // A bad flag is named (it is checked before the design).
    let o = run(&["--dataset-doi", "10.1000/x"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--dataset-doi") && err.contains("doi:"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written");
}
