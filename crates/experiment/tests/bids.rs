//! BIDS export: the files, the gzip recording (decodes, one row per
//! sample, n/a for invalid samples), the sidecars' REQUIRED keys, the
//! events, the labels, and the refusals.

use experiment::bids::{bids_label, export_bids, export_bids_described, BidsError, BIDS_VERSION};
use experiment::session::{
    DisplayInfo, SampleRow, SessionInfo, TrialRow, TsvLog, DESIGN_RON, SAMPLES_TSV, SESSION_JSON,
    TRIALS_TSV,
};
use serde_json::Value;
use std::io::Read;
use std::path::{Path, PathBuf};

const SEED_DESIGN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../config/experiments/murphy2007-search.ron"
);

struct Made {
    dir: PathBuf,
    samples: Vec<SampleRow>,
    trials: Vec<TrialRow>,
}

/// A session with `n_samples` samples at a nominal 50 Hz (20 ms, with a
/// few jittered and one dropped), every 7th invalid, and 3 trials.
fn make(root: &Path, participant: &str, synthetic: bool, n_samples: usize) -> Made {
    let dir = root.join(format!("in-{}", participant.replace('/', "_")));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(SEED_DESIGN, dir.join(DESIGN_RON)).unwrap();
    SessionInfo {
        participant: participant.into(),
        participant_index: 2,
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
        tracker_rate_hz: Some(50.0),
        started_unix_s: 1.7e9,
        synthetic,
        notes: vec![],
        sittings: Vec::new(),
    }
    .write(&dir.join(SESSION_JSON))
    .unwrap();
    let mut log = TsvLog::<SampleRow>::append_to(dir.join(SAMPLES_TSV)).unwrap();
    let mut samples = Vec::new();
    let mut t = 7_000_000u64;
    for i in 0..n_samples {
        let jitter = [0, 1_000, 0, 0, 2_000, 0][i % 6];
        t += 20_000 + jitter - if i % 6 == 5 { 3_000 } else { 0 };
        if i == 10 {
            t += 20_000; // a dropped sample
        }
        let valid = i % 7 != 3;
        let s = SampleRow {
            sitting: 1,
            mapped_us: 1_000_000_000 + t + 1_000,
            device_us: Some(t),
            arrival_us: 1_000_000_000 + t + 1_500,
            time_order: if i == 0 { "first" } else { "ok" }.into(),
            segment: 0,
            trial: Some(i / 100),
            phase: "search".into(),
            raw_x: Some(0.5),
            raw_y: Some(0.25),
            x_px: valid.then_some(100.25 + i as f64),
            y_px: valid.then_some(200.5),
            left_x_px: None,
            left_y_px: None,
            left_pupil: None,
            right_x_px: None,
            right_y_px: None,
            right_pupil: None,
        };
        log.write(&s).unwrap();
        samples.push(s);
    }
    drop(log);
    let mut log = TsvLog::<TrialRow>::append_to(dir.join(TRIALS_TSV)).unwrap();
    let first = samples.first().map_or(1_000_000_000, |s| s.mapped_us);
    let trials: Vec<TrialRow> = (0..3)
        .map(|k| TrialRow {
            participant: participant.into(),
            sitting: 1,
            run: 0,
            trial: k,
            trial_in_run: k,
            condition: ["control", "NE2", "E20"][k].into(),
            method: ["full", "hybrid", "hybrid"][k].into(),
            inset_deg: [None, Some(2.0), Some(20.0)][k],
            silhouette_edges: k == 2,
            target_mesh: 1,
            target_row: k as u32,
            target_col: 4 - k as u32,
            search_onset_us: first + 250_000 + k as u64 * 2_000_000,
            response_us: first + 1_750_000 + k as u64 * 2_000_000,
            rt_s: 1.5,
            clicked_row: None,
            clicked_col: None,
            correct: [Some(true), Some(false), None][k],
            frames: 1,
            frames_late: 0,
            mean_rays: 1.0,
            synthetic,
            plan: [
                Some("full on cpu; passes: none"),
                Some("foveated on gpu; passes: POR box (cpu)"),
                None,
            ][k]
                .map(String::from),
            reference_row: None,
            reference_col: None,
            mean_triangles: None,
            mean_render_ms: None,
            p95_render_ms: None,
            practice: false,
        })
        .collect();
    for t in &trials {
        log.write(t).unwrap();
    }
    Made {
        dir,
        samples,
        trials,
    }
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn gunzip(path: &Path) -> String {
    let mut s = String::new();
    flate2::read::GzDecoder::new(std::fs::File::open(path).unwrap())
        .read_to_string(&mut s)
        .unwrap();
    s
}

#[test]
fn export_writes_a_bids_eyetracking_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P-01", false, 250);
    let b = make(tmp.path(), "P02", false, 40);
    let out = tmp.path().join("bids");
    let export = export_bids(&[a.dir.clone(), b.dir.clone()], &out, "visualSearch").unwrap();
    assert_eq!(export.labels, vec!["P01", "P02"]);
    assert_eq!(export.samples, vec![250, 40]);
    for f in &export.files {
        assert!(f.is_file(), "{}", f.display());
    }

    let dd = json(&out.join("dataset_description.json"));
    assert_eq!(dd["BIDSVersion"], BIDS_VERSION);
    assert!(dd["Name"].as_str().unwrap().contains("murphy2007-search"));
    assert!(!dd["Name"].as_str().unwrap().contains("SYNTHETIC"));
    assert_eq!(dd["DatasetType"], "raw");
    assert_eq!(dd["GeneratedBy"][0]["Name"], "gazecast");

    let parts = std::fs::read_to_string(out.join("participants.tsv")).unwrap();
    let lines: Vec<&str> = parts.lines().collect();
    assert_eq!(lines[0].split('\t').next(), Some("participant_id"));
    assert_eq!(lines.len(), 3);
    assert!(lines[1].starts_with("sub-P01\tP-01\t2\tfalse"));
    assert!(lines[2].starts_with("sub-P02\tP02\t"));

    let beh = out.join("sub-P01/beh");
    let gz = beh.join("sub-P01_task-visualSearch_run-1_recording-eye1_physio.tsv.gz");
    let text = gunzip(&gz);
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split('\t').collect()).collect();
    assert_eq!(rows.len(), a.samples.len(), "one row per sample, no header");
    for (r, s) in rows.iter().zip(&a.samples) {
        assert_eq!(r.len(), 5);
        assert_eq!(r[0], s.mapped_us.to_string());
        assert_eq!(r[3], s.device_us.unwrap().to_string());
        assert_eq!(r[4], s.arrival_us.to_string());
        match s.x_px {
            Some(x) => {
                assert_eq!(r[1].parse::<f64>().unwrap(), x);
                assert_eq!(r[2].parse::<f64>().unwrap(), s.y_px.unwrap());
            }
            None => assert_eq!((r[1], r[2]), ("n/a", "n/a")),
        }
    }
    assert!(rows.iter().any(|r| r[1] == "n/a"));
    let b_rows = gunzip(
        &out.join("sub-P02/beh/sub-P02_task-visualSearch_run-1_recording-eye1_physio.tsv.gz"),
    );
    assert_eq!(b_rows.lines().count(), 40);

    let side = json(&beh.join("sub-P01_task-visualSearch_run-1_recording-eye1_physio.json"));
    // REQUIRED (BIDS 1.11 physio + eyetrack).
    for key in [
        "SamplingFrequency",
        "StartTime",
        "Columns",
        "PhysioType",
        "RecordedEye",
        "SampleCoordinateSystem",
    ] {
        assert!(side.get(key).is_some(), "physio.json lacks {key}");
    }
    assert_eq!(side["PhysioType"], "eyetrack");
    assert_eq!(side["SampleCoordinateSystem"], "gaze-on-screen");
    assert!(["left", "right", "cyclopean"].contains(&side["RecordedEye"].as_str().unwrap()));
    assert_eq!(side["Columns"][0], "timestamp");
    assert_eq!(side["Columns"][1], "x_coordinate");
    assert_eq!(side["Columns"][2], "y_coordinate");
    assert_eq!(side["Columns"].as_array().unwrap().len(), 5);
    assert_eq!(side["Columns"][3], "device_timestamp");
    assert_eq!(side["TaskName"], "visualSearch");
    assert_eq!(side["x_coordinate"]["Units"], "pixel");
    assert_eq!(side["y_coordinate"]["Units"], "pixel");
    assert_eq!(side["Manufacturer"], "Tobii ET-1750");
    assert_eq!(side["ScreenResolution"], serde_json::json!([1280, 1024]));
    assert!((side["ScreenDistance"].as_f64().unwrap() - 0.54).abs() < 1e-12);
    assert!((side["ScreenSize"][0].as_f64().unwrap() - 0.3379).abs() < 1e-12);
    // Median interval 20 ms → 50 Hz, and the sidecar says it was estimated.
    assert!((side["SamplingFrequency"].as_f64().unwrap() - 50.0).abs() < 1e-9);
    assert!(side["SamplingFrequencyEstimate"]
        .as_str()
        .unwrap()
        .contains("median"));

    let events =
        std::fs::read_to_string(beh.join("sub-P01_task-visualSearch_run-1_events.tsv")).unwrap();
    let lines: Vec<&str> = events.lines().collect();
    let header: Vec<&str> = lines[0].split('\t').collect();
    assert_eq!(&header[..3], &["onset", "duration", "trial_type"]);
    for col in [
        "trial",
        "target_row",
        "target_col",
        "response_time",
        "correct",
    ] {
        assert!(header.contains(&col), "events.tsv lacks {col}");
    }
    assert_eq!(lines.len(), 1 + a.trials.len());
    let col = |row: &str, name: &str| -> String {
        let i = header.iter().position(|h| *h == name).unwrap();
        row.split('\t').nth(i).unwrap().to_string()
    };
    let t0 = a.samples[0].mapped_us;
    for (l, t) in lines[1..].iter().zip(&a.trials) {
        let onset: f64 = col(l, "onset").parse().unwrap();
        assert!((onset - (t.search_onset_us - t0) as f64 / 1e6).abs() < 1e-6);
        let duration: f64 = col(l, "duration").parse().unwrap();
        assert!((duration - 1.5).abs() < 1e-6);
        assert_eq!(col(l, "trial_type"), t.condition);
        assert_eq!(col(l, "trial"), t.trial.to_string());
        assert_eq!(col(l, "target_row"), t.target_row.to_string());
        assert_eq!(col(l, "target_col"), t.target_col.to_string());
        assert_eq!(col(l, "response_time"), "1.5");
    }
    assert_eq!(col(lines[1], "correct"), "1");
    assert_eq!(col(lines[2], "correct"), "0");
    assert_eq!(col(lines[3], "correct"), "n/a");
    assert_eq!(col(lines[1], "inset_deg"), "n/a");
    // What rendered each trial, from trials.tsv's plan (n/a without one).
    assert_eq!(col(lines[1], "plan"), "full on cpu; passes: none");
    assert_eq!(
        col(lines[2], "plan"),
        "foveated on gpu; passes: POR box (cpu)"
    );
    assert_eq!(col(lines[3], "plan"), "n/a");

    let ej = json(&beh.join("sub-P01_task-visualSearch_run-1_events.json"));
    let sp = &ej["StimulusPresentation"];
    for key in [
        "ScreenDistance",
        "ScreenOrigin",
        "ScreenResolution",
        "ScreenSize",
    ] {
        assert!(
            sp.get(key).is_some(),
            "events.json StimulusPresentation lacks {key}"
        );
    }
    assert_eq!(sp["ScreenOrigin"], serde_json::json!(["top", "left"]));
    for h in &header {
        assert!(ej.get(*h).is_some(), "events.json does not describe {h}");
    }
    // Every method a design may name is a described level.
    for m in experiment::design::METHODS {
        assert!(
            ej["method"]["Levels"].get(*m).is_some(),
            "events.json's method has no level {m}"
        );
    }
    // Nothing but what the export lists (and no temporary files).
    let mut on_disk = Vec::new();
    let mut stack = vec![out.clone()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                on_disk.push(p);
            }
        }
    }
    on_disk.sort();
    let mut listed = export.files.clone();
    listed.sort();
    assert_eq!(on_disk, listed);
}

#[test]
fn synthetic_sessions_are_labelled() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "sim01", true, 30);
    let out = tmp.path().join("bids");
    export_bids(&[a.dir], &out, "search").unwrap();
    let dd = json(&out.join("dataset_description.json"));
    assert!(dd["Name"].as_str().unwrap().starts_with("SYNTHETIC DATA"));
    let readme = std::fs::read_to_string(out.join("README.md")).unwrap();
    assert!(readme.lines().next().unwrap().contains("SYNTHETIC DATA"));
    let parts = std::fs::read_to_string(out.join("participants.tsv")).unwrap();
    assert!(parts.lines().nth(1).unwrap().ends_with("\ttrue"));
    let side =
        json(&out.join("sub-sim01/beh/sub-sim01_task-search_run-1_recording-eye1_physio.json"));
    assert_eq!(side["SyntheticData"], true);
}

#[test]
fn the_method_levels_describe_every_method_the_renderer_names() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 30);
    let out = tmp.path().join("bids");
    let methods = [
        ("layers", "Guenter et al. 2012's nested layers"),
        ("full", "not used: full keeps its own description"),
    ];
    export_bids_described(&[a.dir], &out, "search", &methods).unwrap();
    let side = json(&out.join("sub-P01/beh/sub-P01_task-search_run-1_events.json"));
    let levels = &side["method"]["Levels"];
    assert_eq!(levels["layers"], "Guenter et al. 2012's nested layers");
    assert_eq!(levels["full"], "full-resolution ray casting (control)");
    assert!(levels["hybrid"].is_string() && levels["image"].is_string());
}

#[test]
fn labels_are_the_alphanumerics_and_must_be_unique() {
    assert_eq!(bids_label("P-01").as_deref(), Some("P01"));
    assert_eq!(bids_label(" sub_7 (pilot) ").as_deref(), Some("sub7pilot"));
    assert_eq!(bids_label("--"), None);
    assert_eq!(bids_label("ü"), None);

    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bids");
    let bad = make(tmp.path(), "--", false, 5);
    let err = export_bids(std::slice::from_ref(&bad.dir), &out, "search").unwrap_err();
    assert!(matches!(err, BidsError::BadLabel { .. }));
    assert!(
        err.to_string()
            .contains(&bad.dir.join(SESSION_JSON).display().to_string()),
        "{err}"
    );

    let a = make(tmp.path(), "P-1", false, 5);
    let b = make(tmp.path(), "P1", false, 5);
    let err = export_bids(&[a.dir.clone(), b.dir.clone()], &out, "search").unwrap_err();
    assert!(matches!(err, BidsError::DuplicateLabel { .. }));
    let msg = err.to_string();
    assert!(
        msg.contains(&a.dir.display().to_string()) && msg.contains(&b.dir.display().to_string()),
        "{msg}"
    );
    assert!(!out.exists(), "nothing written");

    for task in ["", "visual-search", "a b"] {
        assert!(matches!(
            export_bids(std::slice::from_ref(&a.dir), &out, task),
            Err(BidsError::BadTask(_))
        ));
    }
    assert!(matches!(
        export_bids(&[], &out, "x"),
        Err(BidsError::NoInputs)
    ));
}

#[test]
fn output_inside_an_input_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 5);
    for out in [a.dir.clone(), a.dir.join("bids")] {
        let err = export_bids(std::slice::from_ref(&a.dir), &out, "search").unwrap_err();
        assert!(matches!(err, BidsError::Output { .. }), "{err}");
        assert!(err.to_string().contains("inside"), "{err}");
    }
    assert!(!a.dir.join("bids").exists());
    assert!(!a.dir.join("dataset_description.json").exists());
}

#[test]
fn missing_or_corrupt_samples_are_errors_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 5);
    let p = a.dir.join(SAMPLES_TSV);
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, text.replacen("\tsearch\t", "\tsearch\tx\t", 1)).unwrap();
    let err = export_bids(
        std::slice::from_ref(&a.dir),
        &tmp.path().join("o"),
        "search",
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains(&p.display().to_string()) && msg.contains("line 2"),
        "{msg}"
    );
    // No half-written recording is left behind.
    let gz = tmp
        .path()
        .join("o/sub-P01/beh/sub-P01_task-search_run-1_recording-eye1_physio.tsv.gz");
    assert!(!gz.exists());
    std::fs::remove_file(&p).unwrap();
    let msg = export_bids(
        std::slice::from_ref(&a.dir),
        &tmp.path().join("o"),
        "search",
    )
    .unwrap_err()
    .to_string();
    assert!(msg.contains(&p.display().to_string()), "{msg}");
}

#[test]
fn without_samples_events_are_still_written_and_a_warning_says_why() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 0);
    let out = tmp.path().join("o");
    let export = export_bids(std::slice::from_ref(&a.dir), &out, "search").unwrap();
    assert_eq!(export.samples, vec![0]);
    assert!(
        export.warnings.iter().any(|w| w.contains("no samples")),
        "{:?}",
        export.warnings
    );
    assert!(!out
        .join("sub-P01/beh/sub-P01_task-search_run-1_recording-eye1_physio.tsv.gz")
        .exists());
    let ev = std::fs::read_to_string(out.join("sub-P01/beh/sub-P01_task-search_run-1_events.tsv"))
        .unwrap();
    assert_eq!(ev.lines().count(), 4);
    assert!(ev.lines().nth(1).unwrap().starts_with("0.000000\t"));
}

/// A session resumed after a crash: sitting 1 completed trials 0–1 and was
/// killed in trial 2; sitting 2 (a new process: its host clock starts near
/// zero again) ran trial 2 again. Each sitting is one run, every run's
/// timestamps increase strictly and keep the tracker's intervals, the
/// aborted trial's samples are left out, and each run's events are on its
/// own clock.
#[test]
fn a_two_sitting_session_exports_one_monotonic_run_per_sitting() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 0);
    let mut log = TsvLog::<SampleRow>::append_to(a.dir.join(SAMPLES_TSV)).unwrap();
    let sample = |sitting: u32, i: u64, trial: usize, host0: u64, dev0: u64| SampleRow {
        sitting,
        mapped_us: host0 + i * 8_333,
        device_us: Some(dev0 + i * 8_333),
        arrival_us: host0 + i * 8_333 + 700,
        time_order: if i == 0 { "first" } else { "ok" }.into(),
        segment: 0,
        trial: Some(trial),
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
    };
    // Sitting 1: trials 0 and 1 (120 samples each), trial 2 aborted (57).
    for i in 0..297u64 {
        log.write(&sample(1, i, (i / 120) as usize, 26_950_933, 9_000_000_000))
            .unwrap();
    }
    // Sitting 2: trial 2 again, on a host clock that restarted.
    for i in 0..150u64 {
        log.write(&sample(2, i, 2, 2_012, 9_400_000_000)).unwrap();
    }
    drop(log);
    let mut trials = a.trials.clone();
    trials[2].sitting = 2;
    trials[2].search_onset_us = 2_012 + 50_000;
    trials[2].response_us = 2_012 + 1_000_000;
    for (k, t) in trials.iter_mut().enumerate().take(2) {
        t.search_onset_us = 26_950_933 + k as u64 * 1_000_000 + 10_000;
        t.response_us = t.search_onset_us + 900_000;
    }
    std::fs::remove_file(a.dir.join(TRIALS_TSV)).unwrap();
    let mut tl = TsvLog::<TrialRow>::append_to(a.dir.join(TRIALS_TSV)).unwrap();
    for t in &trials {
        tl.write(t).unwrap();
    }
    drop(tl);
    let out = tmp.path().join("bids");
    let export = export_bids(std::slice::from_ref(&a.dir), &out, "search").unwrap();
    assert!(
        export
            .warnings
            .iter()
            .any(|w| w.contains("57 samples of aborted trials")),
        "{:?}",
        export.warnings
    );
    let beh = out.join("sub-P01/beh");
    for (run, n, first_onset) in [(1, 240, 10_000.0), (2, 150, 50_000.0)] {
        let text = gunzip(&beh.join(format!(
            "sub-P01_task-search_run-{run}_recording-eye1_physio.tsv.gz"
        )));
        let rows: Vec<Vec<u64>> = text
            .lines()
            .map(|l| {
                let c: Vec<&str> = l.split('\t').collect();
                vec![c[0].parse().unwrap(), c[3].parse().unwrap()]
            })
            .collect();
        assert_eq!(rows.len(), n, "run {run}");
        for w in rows.windows(2) {
            assert!(w[1][0] > w[0][0], "run {run}: timestamps increase");
            // Intervals equal the tracker's own (device_timestamp).
            assert_eq!(w[1][0] - w[0][0], w[1][1] - w[0][1], "run {run}");
        }
        let ev =
            std::fs::read_to_string(beh.join(format!("sub-P01_task-search_run-{run}_events.tsv")))
                .unwrap();
        let onset: f64 = ev
            .lines()
            .nth(1)
            .unwrap()
            .split('\t')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(
            (onset - first_onset / 1e6).abs() < 1e-6,
            "run {run}: {onset}"
        );
        assert!(
            ev.lines().all(|l| !l.starts_with('-')),
            "no negative onsets"
        );
    }
}

/// Every file under `dir`, relative, sorted.
fn files_under(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}

fn temporaries(dir: &Path) -> Vec<String> {
    files_under(dir)
        .into_iter()
        .filter(|f| f.contains(".tmp-"))
        .collect()
}

/// `participants.tsv`'s participant_id column.
fn participant_ids(out: &Path) -> Vec<String> {
    std::fs::read_to_string(out.join("participants.tsv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split('\t').next().unwrap().to_string())
        .collect()
}

/// Exporting into an existing dataset merges: the participants already
/// there keep their rows, a participant exported again replaces its own
/// row (never a second one), and every `sub-*` folder has its row.
#[test]
fn exporting_into_a_dataset_merges_its_participants() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 20);
    let b = make(tmp.path(), "P02", true, 20);
    let out = tmp.path().join("bids");
    export_bids(std::slice::from_ref(&a.dir), &out, "search").unwrap();
    export_bids(std::slice::from_ref(&b.dir), &out, "search").unwrap();
    assert_eq!(participant_ids(&out), ["sub-P01", "sub-P02"]);
    assert!(out.join("sub-P01").is_dir() && out.join("sub-P02").is_dir());
    // P02 was simulated: the merged dataset says so, though P01 was first.
    let dd = json(&out.join("dataset_description.json"));
    assert!(
        dd["Name"].as_str().unwrap().starts_with("SYNTHETIC"),
        "{dd}"
    );
    // The same participant again (alone, then with the other): one row each.
    export_bids(std::slice::from_ref(&a.dir), &out, "search").unwrap();
    export_bids(&[b.dir.clone(), a.dir.clone()], &out, "search").unwrap();
    assert_eq!(participant_ids(&out), ["sub-P01", "sub-P02"]);
    let rows = std::fs::read_to_string(out.join("participants.tsv")).unwrap();
    assert!(rows.contains("sub-P02\tP02\t2\ttrue\n"), "{rows}");
    assert_eq!(
        json(&out.join("participants.json"))
            .as_object()
            .unwrap()
            .len(),
        3
    );
    assert!(temporaries(&out).is_empty());
}

/// A dataset the export cannot merge into is refused before anything is
/// written, naming the file and the reason: other columns, another
/// design, a folder without its row, a label that is another id's.
#[test]
fn a_dataset_that_cannot_be_merged_is_refused_untouched() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 20);
    let b = make(tmp.path(), "P02", false, 20);
    let c = make(tmp.path(), "P-02", false, 20);
    let fresh = |name: &str| {
        let out = tmp.path().join(name);
        export_bids(std::slice::from_ref(&a.dir), &out, "search").unwrap();
        out
    };
    let cases: Vec<(PathBuf, &str, &str)> = vec![
        {
            let out = fresh("columns");
            let p = out.join("participants.tsv");
            let t = std::fs::read_to_string(&p).unwrap();
            std::fs::write(&p, t.replacen("\tsynthetic\n", "\tsynthetic\tage\n", 1)).unwrap();
            (out, "participants.tsv", "columns")
        },
        {
            let out = fresh("design");
            let p = out.join("dataset_description.json");
            let t = std::fs::read_to_string(&p).unwrap();
            std::fs::write(&p, t.replace("murphy2007-search", "other-design")).unwrap();
            (out, "dataset_description.json", "other-design")
        },
        {
            let out = fresh("orphan");
            std::fs::create_dir_all(out.join("sub-X9/beh")).unwrap();
            (out, "participants.tsv", "sub-X9 has no row")
        },
        {
            let out = fresh("label");
            export_bids(std::slice::from_ref(&b.dir), &out, "search").unwrap();
            (out, "participants.tsv", "is participant \"P02\"")
        },
    ];
    for (out, file, says) in cases {
        let before: Vec<(String, Vec<u8>)> = files_under(&out)
            .into_iter()
            .map(|f| {
                let bytes = std::fs::read(out.join(&f)).unwrap();
                (f, bytes)
            })
            .collect();
        let input = if says.contains("P02") { &c.dir } else { &b.dir };
        let err = export_bids(std::slice::from_ref(input), &out, "search")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(file) && err.contains(says),
            "{}: {err}",
            out.display()
        );
        let after: Vec<(String, Vec<u8>)> = files_under(&out)
            .into_iter()
            .map(|f| {
                let bytes = std::fs::read(out.join(&f)).unwrap();
                (f, bytes)
            })
            .collect();
        assert_eq!(before, after, "{}: nothing written", out.display());
    }
}

/// A write that fails (the target is a folder, so the rename fails even
/// for root) leaves no temporary file behind.
#[test]
fn a_failed_commit_leaves_no_temporary_file() {
    let tmp = tempfile::tempdir().unwrap();
    let a = make(tmp.path(), "P01", false, 20);
    let out = tmp.path().join("bids");
    let blocker = out.join("sub-P01/beh/sub-P01_task-search_run-1_events.tsv");
    std::fs::create_dir_all(&blocker).unwrap();
    std::fs::write(blocker.join("keep"), "x").unwrap();
    let err = export_bids(std::slice::from_ref(&a.dir), &out, "search").unwrap_err();
    assert!(err.to_string().contains("_events.tsv"), "{err}");
    assert_eq!(temporaries(&out), Vec::<String>::new());
}

/// On a full disk no temporary file is left behind. The export runs in a
/// child process of this test binary whose file-size limit is 1 KiB
/// (`ulimit -f 1`, SIGXFSZ ignored): a write past it fails (EFBIG) as a
/// write to a full disk does, root or not. The first file over 1 KiB is
/// a JSON sidecar, buffered whole: it fails when the buffer is flushed.
#[test]
fn a_full_disk_leaves_no_temporary_file() {
    const CHILD: &str = "GAZECAST_TEST_FULL_DISK";
    if let Some(spec) = std::env::var_os(CHILD) {
        let spec = PathBuf::from(spec);
        let input = spec.join("in-P01");
        let r = export_bids(std::slice::from_ref(&input), &spec.join("bids"), "search");
        match r {
            Err(e) => println!("EXPORT FAILED: {e}"),
            Ok(_) => println!("EXPORT SUCCEEDED"),
        }
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    make(tmp.path(), "P01", false, 5);
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new("bash")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 1; exec \"$0\" \"$@\"")
        .arg(exe)
        .args([
            "--exact",
            "a_full_disk_leaves_no_temporary_file",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD, tmp.path())
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{log}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        log.contains("EXPORT FAILED") && log.contains("too large"),
        "{log}"
    );
    assert_eq!(temporaries(&tmp.path().join("bids")), Vec::<String>::new());
}
