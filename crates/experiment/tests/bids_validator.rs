//! The BIDS export of a binocular, two-sitting session, checked by the
//! official validator (bids-validator-deno, from PyPI, in the virtual
//! environment `scripts/bids-venv.sh` makes): 0 errors, and no warning
//! outside [`VALIDATOR_ALLOWED_WARNINGS`]. Also what the validator does not
//! check: one recording per eye with its own gaze and pupil, the
//! physioevents (fixations, saccades, blinks, messages) on the physio
//! clock, the calibration fields from the calibration markers, and the
//! dataset metadata from a design file's `bids` block.
//!
//! The validator: `$GAZECAST_BIDS_VALIDATOR` (test.sh sets it). Unset, the
//! test says so and, as the LSL tests do for `$GAZECAST_PYLSL`, makes the
//! environment with `scripts/bids-venv.sh`; if that fails the test fails,
//! unless `GAZECAST_SKIP_BIDS_VALIDATOR=1` (then only the validator run is
//! skipped, loudly).

use experiment::bids::{export_bids, export_bids_with, BidsError, VALIDATOR_ALLOWED_WARNINGS};
use experiment::design::BidsMetadata;
use experiment::session::{
    CalibrationMarker, DisplayInfo, EventRow, MarkerRow, SampleRow, SessionInfo, Sitting, TrialRow,
    TsvLog, CALIBRATION_MARKER, DESIGN_RON, SAMPLES_TSV, SESSION_JSON,
};
use experiment::{read_tsv, Design};
use serde_json::Value;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn seed_design_text() -> String {
    std::fs::read_to_string(root().join("config/experiments/murphy2007-search.ron"))
        .expect("the seed design")
}

/// The seed design with a `bids` block (`block` is its inside).
fn design_with_bids(block: &str) -> String {
    let text = seed_design_text();
    let end = text.rfind(')').expect("the design's closing parenthesis");
    format!(
        "{}    bids: Some(({block})),\n{}",
        &text[..end],
        &text[end..]
    )
}

const BIDS_BLOCK: &str = r#"
        authors: ["Ada Example", "Ben Example"],
        license: Some("CC-BY-4.0"),
        acknowledgements: Some("The participants."),
        how_to_acknowledge: Some("Cite gazecast."),
        funding: ["Example Foundation grant 1"],
        ethics_approvals: ["Example University ethics board, approval 2026-01"],
        references_and_links: ["https://example.org/gazecast"],
        instructions: Some("Find the object that matches the target shown before the search, then press Space."),
        cog_atlas_id: Some("https://www.cognitiveatlas.org/task/id/trm_4f244ad7dcde7/"),
        cog_po_id: Some("http://www.cogpo.org/ontologies/CogPOver1.owl#COGPO_00049"),
        institution_name: Some("Example University"),
        institution_address: Some("1 Example Road, Example City"),
        institutional_department_name: Some("Department of Psychology"),
    "#;

/// A sitting's calibration as the runner writes it.
fn calibration(average_deg: f64, maximal_deg: f64) -> CalibrationMarker {
    let mut positions = Vec::new();
    for y in [102.4, 512.0, 921.6] {
        for x in [128.0, 640.0, 1152.0] {
            positions.push([x, y]);
        }
    }
    CalibrationMarker {
        targets: 9,
        positions_px: positions,
        average_deg,
        maximal_deg,
    }
}

/// The left and right eyes' offsets from the combined gaze (px).
const LEFT: [f64; 2] = [-6.5, 1.25];
const RIGHT: [f64; 2] = [6.5, -1.25];
/// 250 Hz.
const STEP_US: u64 = 4_000;

struct Made {
    dir: PathBuf,
    /// Per sitting: the samples the export keeps (not aborted).
    kept: Vec<Vec<SampleRow>>,
    /// Per sitting: its calibration markers.
    calibrations: Vec<Vec<CalibrationMarker>>,
}

/// A binocular session in two sittings, written through the session
/// writer API: sitting 1 calibrates twice (the first fails), runs trials
/// 0 and 1 and is killed in trial 2; sitting 2 (a new process: its host
/// clock restarts) calibrates and runs trial 2 again. Both eyes with gaze
/// and pupil; the right eye alone is lost now and then, both in blinks.
fn binocular_session(tmp: &Path) -> Made {
    let dir = tmp.join("session-P07");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(DESIGN_RON), seed_design_text()).unwrap();
    let sitting = |number: u32, first_trial: usize, host_anchor_us: u64| Sitting {
        number,
        first_trial,
        started_unix_us: 1_780_000_000_000_000 + number as u64 * 3_600_000_000,
        host_anchor_us,
        software: "gazecast 0.1.0-test".into(),
        tracker: "Tobii ET-1750".into(),
        tracker_settings: None,
        device_clock: "the tracker's own clock, us".into(),
        clock: None,
    };
    SessionInfo {
        participant: "P-07".into(),
        participant_index: 6,
        design_name: "murphy2007-search".into(),
        software: "gazecast 0.1.0-test".into(),
        display: DisplayInfo {
            name: "LCD".into(),
            width_px: 1280,
            height_px: 1024,
            width_mm: 337.9,
            height_mm: 270.3,
            distance_mm: 540.0,
        },
        tracker: "Tobii ET-1750".into(),
        tracker_rate_hz: Some(250.0),
        started_unix_s: 1.78e9,
        synthetic: false,
        notes: vec![],
        sittings: vec![sitting(1, 0, 4_000_000), sitting(2, 2, 1_000_000)],
    }
    .write(&dir.join(SESSION_JSON))
    .unwrap();

    let mut samples = TsvLog::<SampleRow>::append_to(dir.join(SAMPLES_TSV)).unwrap();
    let mut events = TsvLog::<EventRow>::append_to(dir.join("events.tsv")).unwrap();
    let mut markers = TsvLog::<MarkerRow>::append_to(dir.join("markers.tsv")).unwrap();
    let mut trials = TsvLog::<TrialRow>::append_to(dir.join("trials.tsv")).unwrap();
    let mut kept = vec![Vec::new(), Vec::new()];
    let mut calibrations = vec![Vec::new(), Vec::new()];

    // (sitting, host start, device start, [(trial or None, phase, samples)]).
    type Block = (Option<usize>, &'static str, u64);
    let plan: [(u32, u64, u64, Vec<Block>); 2] = [
        (
            1,
            4_200_000,
            70_000_000,
            vec![
                (None, "calibration", 300),
                (Some(0), "search", 400),
                (Some(1), "search", 400),
                (Some(2), "search", 90), // killed: aborted
            ],
        ),
        (
            2,
            1_150_000,
            91_000_000,
            vec![(None, "calibration", 200), (Some(2), "search", 450)],
        ),
    ];
    for (sitting, host0, dev0, blocks) in plan {
        let s_idx = sitting as usize - 1;
        let mut i = 0u64;
        let marker = |host_us: u64, trial: Option<usize>, event: &str, detail: String| MarkerRow {
            sitting,
            host_us,
            trial,
            event: event.into(),
            detail,
        };
        for (trial, phase, n) in blocks {
            let start_us = host0 + i * STEP_US;
            markers
                .write(&marker(
                    start_us.saturating_sub(500),
                    trial,
                    &format!("start:{phase}"),
                    trial.map_or(String::new(), |t| format!("trial {}", t + 1)),
                ))
                .unwrap();
            for k in 0..n {
                let t = i;
                i += 1;
                let combined = [
                    300.0 + (t % 200) as f64 * 3.5,
                    400.0 + (t % 90) as f64 * 2.0,
                ];
                let blink = t % 211 < 6;
                let right_lost = !blink && t.is_multiple_of(47);
                let eye = |off: [f64; 2], lost: bool| {
                    (!lost).then_some([combined[0] + off[0], combined[1] + off[1]])
                };
                let left = eye(LEFT, blink);
                let right = eye(RIGHT, blink || right_lost);
                let s = SampleRow {
                    sitting,
                    mapped_us: host0 + t * STEP_US,
                    device_us: Some(dev0 + t * STEP_US),
                    arrival_us: host0 + t * STEP_US + 1_700,
                    time_order: if t == 0 { "first" } else { "ok" }.into(),
                    segment: 0,
                    trial,
                    phase: phase.into(),
                    raw_x: (!blink).then_some(combined[0] / 1280.0),
                    raw_y: (!blink).then_some(combined[1] / 1024.0),
                    x_px: (!blink).then_some(combined[0]),
                    y_px: (!blink).then_some(combined[1]),
                    left_x_px: left.map(|p| p[0]),
                    left_y_px: left.map(|p| p[1]),
                    left_pupil: (!blink).then_some(3.25 + (t % 13) as f64 * 0.01),
                    right_x_px: right.map(|p| p[0]),
                    right_y_px: right.map(|p| p[1]),
                    right_pupil: (!(blink || right_lost)).then_some(3.5 - (t % 7) as f64 * 0.01),
                };
                samples.write(&s).unwrap();
                let aborted = sitting == 1 && trial == Some(2);
                if !aborted {
                    kept[s_idx].push(s);
                }
                // Every 40 samples: a fixation of 30, then a saccade of 10.
                if trial.is_some() && k % 40 == 39 {
                    let at = |j: u64| (host0 + j * STEP_US, dev0 + j * STEP_US);
                    let (f0, fd0) = at(t - 39);
                    let (f1, fd1) = at(t - 10);
                    let (s0, sd0) = at(t - 9);
                    let (s1, sd1) = at(t);
                    let row = |kind: &str, o: (u64, u64), e: (u64, u64), xy: [f64; 4]| EventRow {
                        sitting,
                        trial,
                        kind: kind.into(),
                        onset_us: o.0,
                        end_us: e.0,
                        onset_device_us: o.1,
                        end_device_us: e.1,
                        x_px: xy[0],
                        y_px: xy[1],
                        end_x_px: xy[2],
                        end_y_px: xy[3],
                        practice: false,
                    };
                    events
                        .write(&row(
                            "fixation",
                            (f0, fd0),
                            (f1, fd1),
                            [500.0, 420.0, 500.0, 420.0],
                        ))
                        .unwrap();
                    events
                        .write(&row(
                            "saccade",
                            (s0, sd0),
                            (s1, sd1),
                            [500.0, 420.0, 760.0, 300.0],
                        ))
                        .unwrap();
                }
                if t % 211 == 5 && trial.is_some() {
                    let (o, od) = (host0 + (t - 5) * STEP_US, dev0 + (t - 5) * STEP_US);
                    let (e, ed) = (host0 + t * STEP_US, dev0 + t * STEP_US);
                    events
                        .write(&EventRow {
                            sitting,
                            trial,
                            kind: "blink".into(),
                            onset_us: o,
                            end_us: e,
                            onset_device_us: od,
                            end_device_us: ed,
                            x_px: f64::NAN,
                            y_px: f64::NAN,
                            end_x_px: f64::NAN,
                            end_y_px: f64::NAN,
                            practice: false,
                        })
                        .unwrap();
                }
            }
            let end_us = host0 + (i - 1) * STEP_US;
            match (phase, trial) {
                ("calibration", _) => {
                    // Sitting 1: a failed calibration, then a good one.
                    let tries: &[(f64, f64)] = if sitting == 1 {
                        &[(1.8, 3.1), (0.42, 0.87)]
                    } else {
                        &[(0.55, 0.93)]
                    };
                    for (k, (avg, max)) in tries.iter().enumerate() {
                        let c = calibration(*avg, *max);
                        let at = start_us + (k as u64 + 1) * 100_000;
                        markers
                            .write(&marker(at, None, CALIBRATION_MARKER, c.to_detail()))
                            .unwrap();
                        markers
                            .write(&marker(
                                at + 10,
                                None,
                                "calibration-result",
                                format!("calibrated: validation accuracy {avg:.2} deg"),
                            ))
                            .unwrap();
                        calibrations[s_idx].push(c);
                    }
                }
                (_, Some(t)) if !(sitting == 1 && t == 2) => {
                    markers
                        .write(&marker(end_us, trial, "key", format!("space {end_us}")))
                        .unwrap();
                    trials
                        .write(&TrialRow {
                            participant: "P-07".into(),
                            sitting,
                            run: 0,
                            trial: t,
                            trial_in_run: t,
                            condition: ["control", "NE2", "E20"][t].into(),
                            method: ["full", "hybrid", "hybrid"][t].into(),
                            inset_deg: [None, Some(2.0), Some(20.0)][t],
                            silhouette_edges: t == 2,
                            target_mesh: 1,
                            target_row: t as u32,
                            target_col: 4 - t as u32,
                            search_onset_us: start_us,
                            response_us: end_us,
                            rt_s: (end_us - start_us) as f64 / 1e6,
                            clicked_row: None,
                            clicked_col: None,
                            correct: Some(true),
                            frames: 60,
                            frames_late: 0,
                            mean_rays: 1.0e5,
                            synthetic: false,
                            plan: Some("hybrid on cpu; passes: none".into()),
                            reference_row: Some(2),
                            reference_col: Some(2),
                            mean_triangles: None,
                            mean_render_ms: Some(12.5),
                            p95_render_ms: Some(21.0),
                            practice: false,
                        })
                        .unwrap();
                }
                _ => {}
            }
        }
    }
    Made {
        dir,
        kept,
        calibrations,
    }
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn gunzip(path: &Path) -> String {
    let mut s = String::new();
    flate2::read::GzDecoder::new(
        std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
    .read_to_string(&mut s)
    .unwrap();
    s
}

fn opt(cell: &str) -> Option<f64> {
    (cell != "n/a").then(|| cell.parse().unwrap_or_else(|e| panic!("{cell:?}: {e}")))
}

/// The validator's path: `$GAZECAST_BIDS_VALIDATOR`, else what
/// `scripts/bids-venv.sh` prints; `None` only when
/// `GAZECAST_SKIP_BIDS_VALIDATOR=1`.
fn validator() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("GAZECAST_BIDS_VALIDATOR").filter(|p| !p.is_empty()) {
        return Some(p.into());
    }
    eprintln!(
        "\n!!! GAZECAST_BIDS_VALIDATOR is not set (test.sh sets it to what scripts/bids-venv.sh prints)."
    );
    if std::env::var("GAZECAST_SKIP_BIDS_VALIDATOR").as_deref() == Ok("1") {
        eprintln!("!!! GAZECAST_SKIP_BIDS_VALIDATOR=1: the official BIDS validator is NOT run.\n");
        return None;
    }
    eprintln!("!!! Making it with scripts/bids-venv.sh (set GAZECAST_SKIP_BIDS_VALIDATOR=1 to skip the validator).\n");
    let out = Command::new("scripts/bids-venv.sh")
        .current_dir(root())
        .output()
        .expect("scripts/bids-venv.sh runs");
    assert!(
        out.status.success(),
        "scripts/bids-venv.sh failed (no network to PyPI?): set GAZECAST_BIDS_VALIDATOR to a bids-validator-deno, \
         or GAZECAST_SKIP_BIDS_VALIDATOR=1 to skip the validator: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = String::from_utf8_lossy(&out.stdout);
    Some(
        s.lines()
            .last()
            .expect("it prints the validator's path")
            .into(),
    )
}

/// One issue: its code, the key it names (`subCode`, may be empty), where.
type Issue = (String, String, String);

/// Runs the validator on `dataset`: its errors, its warnings, its summary.
fn validate(exe: &Path, dataset: &Path) -> (Vec<Issue>, Vec<Issue>, Value) {
    let out = Command::new(exe)
        .args(["--format", "json", "--max-rows", "-1"])
        .arg(dataset)
        .output()
        .unwrap_or_else(|e| panic!("{}: {e}", exe.display()));
    let text = String::from_utf8_lossy(&out.stdout);
    let report: Value = serde_json::from_str(&text).unwrap_or_else(|e| {
        panic!(
            "the validator's output is not JSON ({e}): {text}{}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    let mut errors = Vec::new();
    let mut warnings = Vec::new();
    for issue in report["issues"]["issues"].as_array().expect("issues") {
        let code = issue["code"].as_str().unwrap_or("?").to_string();
        let sub = issue["subCode"].as_str().unwrap_or("").to_string();
        let at = issue["location"].as_str().unwrap_or("").to_string();
        match issue["severity"].as_str() {
            Some("error") => errors.push((code, sub, at)),
            _ => warnings.push((code, sub, at)),
        }
    }
    (errors, warnings, report["summary"].clone())
}

#[test]
#[ignore = "slow tier: peer test against the official BIDS validator"]
fn a_binocular_two_sitting_export_passes_the_official_validator() {
    let tmp = tempfile::tempdir().unwrap();
    let made = binocular_session(tmp.path());
    let design = Design::from_ron_str(&design_with_bids(BIDS_BLOCK)).expect("the design loads");
    let from_design = design.bids.clone().expect("a bids block");
    // The command line overrides the design field by field.
    let dataset = from_design.overlay(&BidsMetadata {
        license: Some("CC0-1.0".into()),
        ..Default::default()
    });
    let out = tmp.path().join("bids");
    let export = export_bids_with(
        std::slice::from_ref(&made.dir),
        &out,
        "visualSearch",
        &[],
        &dataset,
    )
    .unwrap();
    assert!(
        export
            .warnings
            .iter()
            .any(|w| w.contains("90 samples of aborted trials")),
        "{:?}",
        export.warnings
    );
    let beh = out.join("sub-P07/beh");

    // dataset_description.json: the design's metadata, the flag's licence.
    let dd = json(&out.join("dataset_description.json"));
    assert_eq!(
        dd["Authors"],
        serde_json::json!(["Ada Example", "Ben Example"])
    );
    assert_eq!(dd["License"], "CC0-1.0");
    assert_eq!(dd["Funding"][0], "Example Foundation grant 1");

    for (run, kept) in made.kept.iter().enumerate() {
        let run_n = run + 1;
        let stem = format!("sub-P07_task-visualSearch_run-{run_n}");
        // One recording per eye: eye1 left, eye2 right, each its own gaze
        // and pupil, row for row the samples kept.
        for (label, eye, off) in [("eye1", "left", LEFT), ("eye2", "right", RIGHT)] {
            let side = json(&beh.join(format!("{stem}_recording-{label}_physio.json")));
            assert_eq!(side["RecordedEye"], eye);
            assert_eq!(side["TaskName"], "visualSearch");
            assert_eq!(side["InstitutionName"], "Example University");
            assert_eq!(
                side["Columns"],
                serde_json::json!([
                    "timestamp",
                    "x_coordinate",
                    "y_coordinate",
                    "pupil_size",
                    "device_timestamp",
                    "arrival_timestamp"
                ])
            );
            assert!((side["SamplingFrequency"].as_f64().unwrap() - 250.0).abs() < 1e-9);
            // Calibration fields: the sitting's last calibration, counted.
            let cals = &made.calibrations[run];
            let last = cals.last().unwrap();
            assert_eq!(side["CalibrationCount"], cals.len());
            assert_eq!(side["CalibrationType"], "HV9");
            assert_eq!(side["CalibrationUnit"], "pixel");
            assert_eq!(side["AverageCalibrationError"], last.average_deg);
            assert_eq!(side["MaximalCalibrationError"], last.maximal_deg);
            assert_eq!(
                side["CalibrationPosition"],
                serde_json::json!(last.positions_px)
            );

            let text = gunzip(&beh.join(format!("{stem}_recording-{label}_physio.tsv.gz")));
            let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split('\t').collect()).collect();
            assert_eq!(rows.len(), kept.len(), "{stem} {label}");
            let mut lost = 0;
            for (r, s) in rows.iter().zip(kept) {
                assert_eq!(r.len(), 6);
                assert_eq!(r[0], s.mapped_us.to_string());
                let (x, y, pupil) = if eye == "left" {
                    (s.left_x_px, s.left_y_px, s.left_pupil)
                } else {
                    (s.right_x_px, s.right_y_px, s.right_pupil)
                };
                assert_eq!((opt(r[1]), opt(r[2]), opt(r[3])), (x, y, pupil));
                if let (Some(x), Some(cx)) = (x, s.x_px) {
                    assert_eq!(x - cx, off[0], "the eye's own gaze, not the combined");
                }
                lost += usize::from(r[1] == "n/a");
                assert_eq!(r[4], s.device_us.unwrap().to_string());
            }
            assert!(lost > 0, "{label}: some samples lost");

            // Physioevents: fixations, saccades, blinks and messages on the
            // timestamp clock, sorted, none of the aborted trial's.
            let pe = json(&beh.join(format!("{stem}_recording-{label}_physioevents.json")));
            assert_eq!(pe["OnsetSource"], "timestamp");
            assert_eq!(pe["onset"]["Units"], "us");
            let text = gunzip(&beh.join(format!("{stem}_recording-{label}_physioevents.tsv.gz")));
            let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split('\t').collect()).collect();
            let columns = pe["Columns"].as_array().unwrap().len();
            assert!(rows.iter().all(|r| r.len() == columns));
            let onsets: Vec<u64> = rows.iter().map(|r| r[0].parse().unwrap()).collect();
            assert!(onsets.windows(2).all(|w| w[0] <= w[1]), "sorted");
            for kind in ["fixation", "saccade", "blink", "message"] {
                assert!(rows.iter().any(|r| r[2] == kind), "{stem}: no {kind}");
            }
            let (t0, t1) = (kept[0].mapped_us, kept[kept.len() - 1].mapped_us);
            for r in rows.iter().filter(|r| r[2] != "message") {
                let o: u64 = r[0].parse().unwrap();
                assert!(o >= t0 && o <= t1, "{stem}: event at {o} outside the run");
                assert!(!(run == 0 && r[3] == "2"), "an aborted trial's event");
            }
            assert!(rows
                .iter()
                .any(|r| r[2] == "message" && r[8].starts_with(CALIBRATION_MARKER)));
        }
        // No cyclopean file besides the eyes.
        assert!(!beh
            .join(format!("{stem}_recording-eye3_physio.tsv.gz"))
            .exists());
        let ej = json(&beh.join(format!("{stem}_events.json")));
        assert!(ej["Instructions"]
            .as_str()
            .unwrap()
            .starts_with("Find the object"));
        assert_eq!(ej["CogAtlasID"], dataset.cog_atlas_id.clone().unwrap());
    }

    let Some(exe) = validator() else {
        return;
    };
    let (errors, warnings, summary) = validate(&exe, &out);
    eprintln!(
        "bids-validator-deno ({}): {} errors, {} warnings: {:?}",
        summary["schemaVersion"],
        errors.len(),
        warnings.len(),
        warnings
    );
    assert!(errors.is_empty(), "validator errors: {errors:#?}");
    let allowed = |(code, sub, _): &&Issue| {
        VALIDATOR_ALLOWED_WARNINGS
            .iter()
            .any(|(c, s, _)| c == code && (s.is_empty() || s == sub))
    };
    let unexpected: Vec<&Issue> = warnings.iter().filter(|w| !allowed(w)).collect();
    assert!(
        unexpected.is_empty(),
        "validator warnings not in VALIDATOR_ALLOWED_WARNINGS: {unexpected:#?}"
    );
    assert_eq!(summary["subjects"], serde_json::json!(["P07"]));
    assert!(summary["dataTypes"]
        .as_array()
        .is_some_and(|d| d.iter().any(|t| t == "beh")));

    // The same session without the dataset metadata: the validator asks
    // for what the metadata gives (so the list above hides none of it).
    let bare = tmp.path().join("bare");
    export_bids(std::slice::from_ref(&made.dir), &bare, "visualSearch").unwrap();
    let (errors, warnings, _) = validate(&exe, &bare);
    assert!(errors.is_empty(), "validator errors: {errors:#?}");
    for key in ["Authors", "License"] {
        assert!(
            warnings.iter().any(|(_, sub, _)| sub == key),
            "no warning for a missing {key}: {warnings:#?}"
        );
        assert!(!VALIDATOR_ALLOWED_WARNINGS.iter().any(|(_, s, _)| *s == key));
    }
}

/// A session folder written before the per-eye columns (its samples.tsv
/// header stops at y_px) still loads, and exports one cyclopean
/// recording as before.
#[test]
fn a_samples_file_without_the_eye_columns_reads_and_exports_cyclopean() {
    let tmp = tempfile::tempdir().unwrap();
    let made = binocular_session(tmp.path());
    let p = made.dir.join(SAMPLES_TSV);
    let text = std::fs::read_to_string(&p).unwrap();
    let old: String = text
        .lines()
        .map(|l| {
            let cells: Vec<&str> = l.split('\t').collect();
            format!("{}\n", cells[..12].join("\t"))
        })
        .collect();
    assert!(
        old.starts_with("sitting\tmapped_us\t") && old.lines().next().unwrap().ends_with("\ty_px")
    );
    std::fs::write(&p, old).unwrap();
    let read = read_tsv::<SampleRow>(&p).unwrap();
    assert_eq!(read.rows.len(), text.lines().count() - 1);
    assert!(read.rows.iter().all(|s| !s.has_eye_data()));
    assert!(read.rows.iter().any(|s| s.x_px.is_some()));

    let out = tmp.path().join("bids");
    export_bids(std::slice::from_ref(&made.dir), &out, "search").unwrap();
    let beh = out.join("sub-P07/beh");
    let side = json(&beh.join("sub-P07_task-search_run-1_recording-eye1_physio.json"));
    assert_eq!(side["RecordedEye"], "cyclopean");
    assert_eq!(side["Columns"].as_array().unwrap().len(), 5);
    assert!(!beh
        .join("sub-P07_task-search_run-1_recording-eye2_physio.tsv.gz")
        .exists());
    // The physioevents and calibration do not depend on the eyes.
    assert!(beh
        .join("sub-P07_task-search_run-1_recording-eye1_physioevents.tsv.gz")
        .exists());
    assert_eq!(side["CalibrationCount"], 2);
}

/// The design's `bids` block: read with the design, checked field by
/// field (the error names the field), unknown keys refused, and ignored
/// when designs are compared for pooling.
#[test]
fn the_design_files_bids_block_is_read_and_checked() {
    let d = Design::from_ron_str(&design_with_bids(BIDS_BLOCK)).unwrap();
    let b = d.bids.clone().unwrap();
    assert_eq!(b.authors.len(), 2);
    assert_eq!(b.institution_name.as_deref(), Some("Example University"));
    let plain = Design::from_ron_str(&seed_design_text()).unwrap();
    assert_eq!(plain.bids, None);
    assert!(
        plain.differences(&d).is_empty(),
        "{:?}",
        plain.differences(&d)
    );

    for (block, field) in [
        (r#"authors: ["A", " "]"#, "bids.authors[1]"),
        (r#"license: Some("")"#, "bids.license"),
        (r#"dataset_doi: Some("10.1000/x")"#, "bids.dataset_doi"),
        (r#"cog_atlas_id: Some("trm_1")"#, "bids.cog_atlas_id"),
    ] {
        let e = Design::from_ron_str(&design_with_bids(block)).unwrap_err();
        assert_eq!(e.field(), Some(field), "{block}: {e}");
    }
    let e = Design::from_ron_str(&design_with_bids(r#"autors: ["A"]"#)).unwrap_err();
    assert!(e.to_string().contains("autors"), "{e}");

    // The export checks metadata given to it directly too.
    let tmp = tempfile::tempdir().unwrap();
    let made = binocular_session(tmp.path());
    let bad = BidsMetadata {
        authors: vec!["".into()],
        ..Default::default()
    };
    let err =
        export_bids_with(&[made.dir], &tmp.path().join("o"), "search", &[], &bad).unwrap_err();
    assert!(matches!(err, BidsError::Metadata { .. }), "{err}");
    assert!(err.to_string().contains("authors[0]"), "{err}");
}
