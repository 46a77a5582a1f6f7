//! The visual-search experiment end to end: two simulated participants
//! run the 11 scene types in a real window (Xvfb, lavapipe presents),
//! through the mouse tracker's device path; one is stopped after 4 trials
//! and resumed; then the analysis and the BIDS export run on the session
//! folders. The search times are synthetic (the simulated participant's).

mod common;

use std::path::{Path, PathBuf};

use common::{windowed, Run, Xvfb};

fn run_session(x: &Xvfb, out: &Path, id: &str, seed: u64, extra: &[&str]) -> std::process::Output {
    let mut c = windowed(x);
    c.args([
        "experiment",
        "run",
        "tests/data/experiment/design-small.ron",
        "--participant",
        id,
        "--tracker",
        "tests/data/mouse-participant.ron",
        "--display",
        "tests/data/experiment/display-small.ron",
        "--backend",
        "cpu",
        "--out",
    ])
    .arg(out)
    .args(["--simulate-participant", &seed.to_string()])
    .args(extra);
    c.output().expect("the binary runs")
}

fn lines(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(str::to_string)
        .collect()
}

/// Column `name` of a TSV file's rows.
fn column(path: &Path, name: &str) -> Vec<String> {
    let l = lines(path);
    let header: Vec<&str> = l[0].split('\t').collect();
    let k = header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
    l[1..]
        .iter()
        .map(|r| r.split('\t').nth(k).unwrap_or("").to_string())
        .collect()
}

#[test]
#[ignore = "slow tier: two windowed experiment sessions under Xvfb, resumed and analysed"]
fn two_simulated_participants_run_resume_and_are_analysed() {
    let x = Xvfb::start();
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("data");
    // P01: 4 trials, stopped, then resumed to the end.
    let first = run_session(&x, &out, "P01", 1, &["--max-trials", "4"]);
    let log = String::from_utf8_lossy(&first.stdout);
    assert!(
        first.status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&first.stderr)
    );
    assert!(log.contains("SIMULATED participant"), "{log}");
    assert!(log.contains("stopping after 4 trials"), "{log}");
    let p01: PathBuf = out.join("small-search").join("sub-P01");
    assert_eq!(lines(&p01.join("trials.tsv")).len(), 1 + 4);
    // Running it again without --resume is refused and changes nothing.
    let before = std::fs::read(p01.join("trials.tsv")).expect("trials");
    let again = run_session(&x, &out, "P01", 1, &[]);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("--resume"));
    assert_eq!(
        std::fs::read(p01.join("trials.tsv")).expect("trials"),
        before
    );
    let resumed = run_session(&x, &out, "P01", 2, &["--resume"]);
    let log = String::from_utf8_lossy(&resumed.stdout);
    assert!(
        resumed.status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert!(log.contains("trial 5 of 11"), "{log}");
    assert!(log.contains("session complete"), "{log}");
    // P02 in one sitting.
    let second = run_session(&x, &out, "P02", 3, &[]);
    let log = String::from_utf8_lossy(&second.stdout);
    assert!(
        second.status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&second.stderr)
    );
    let p02 = out.join("small-search").join("sub-P02");

    for (dir, sittings) in [(&p01, 2), (&p02, 1)] {
        let trials = dir.join("trials.tsv");
        let t = column(&trials, "trial");
        assert_eq!(t, (0..11).map(|k| k.to_string()).collect::<Vec<_>>());
        // Every condition once (one run of the Latin square's row).
        let mut c = column(&trials, "condition");
        c.sort();
        assert_eq!(c.len(), 11);
        c.dedup();
        assert_eq!(c.len(), 11, "{c:?}");
        for rt in column(&trials, "rt_s") {
            let v: f64 = rt.parse().expect("rt");
            // The model's search: 3-8 fixations of 200-400 ms and the target's.
            assert!((0.5..30.0).contains(&v), "rt {v}");
        }
        assert!(column(&trials, "correct")
            .iter()
            .all(|c| c == "true" || c == "false"));
        assert!(column(&trials, "synthetic").iter().all(|s| s == "true"));
        assert!(column(&trials, "frames")
            .iter()
            .all(|f| f.parse::<u64>().expect("frames") > 0));
        // Foveated conditions cast fewer rays than the control.
        let rays: Vec<f64> = column(&trials, "mean_rays")
            .iter()
            .map(|r| r.parse().expect("rays"))
            .collect();
        let conds = column(&trials, "condition");
        let control = conds.iter().position(|c| c == "control").expect("control");
        let ne2 = conds.iter().position(|c| c == "NE2").expect("NE2");
        assert!(rays[ne2] < 0.8 * rays[control], "{rays:?}");
        assert!((rays[control] - 640.0 * 512.0).abs() < 1.0, "{rays:?}");
        // Samples, events, markers, frames and the raw recordings.
        assert!(lines(&dir.join("samples.tsv")).len() > 500);
        let kinds = column(&dir.join("events.tsv"), "kind");
        assert!(
            kinds.iter().filter(|k| *k == "fixation").count() >= 11 * 3,
            "{kinds:?}"
        );
        let markers = column(&dir.join("markers.tsv"), "event");
        assert_eq!(markers.iter().filter(|m| *m == "search-onset").count(), 11);
        assert!(markers.iter().any(|m| m == "calibration-result"));
        assert!(lines(&dir.join("frames.tsv")).len() > 11);
        for k in 1..=sittings {
            let rec = dir.join(format!("gaze-{k}.gzrec"));
            assert!(
                std::fs::metadata(&rec).map(|m| m.len()).unwrap_or(0) > 1000,
                "{}",
                rec.display()
            );
        }
        times_increase_within_each_sitting(dir, sittings);
        assert!(dir.join("stimuli").join("trial-010.png").exists());
        assert!(std::fs::read_to_string(dir.join("session.json"))
            .expect("json")
            .contains("\"synthetic\": true"));
    }

    // The analysis of both sessions.
    let report_dir = tmp.path().join("analysis");
    let mut a = common::gazecast();
    a.args(["experiment", "analyze"])
        .arg(&p01)
        .arg(&p02)
        .arg("--out")
        .arg(&report_dir);
    a.succeed();
    let report = std::fs::read_to_string(report_dir.join("report.md")).expect("report");
    assert!(report.to_lowercase().contains("synthetic"), "{report}");
    assert!(report.contains("F(10,"), "{report}");
    for f in [
        "fig-7.3.png",
        "fig-7.4.png",
        "table-7.1.csv",
        "conditions.csv",
    ] {
        assert!(report_dir.join(f).exists(), "{f}");
    }
    // BIDS.
    let bids = tmp.path().join("bids");
    let mut b = common::gazecast();
    b.args(["experiment", "export-bids"])
        .arg(&p01)
        .arg(&p02)
        .arg("--out")
        .arg(&bids);
    b.succeed();
    assert!(bids.join("dataset_description.json").exists());
    assert!(bids.join("participants.tsv").exists());
    // One run per sitting, each strictly increasing: nothing goes backwards.
    for (id, sittings) in [("P01", 2), ("P02", 1)] {
        let beh = bids.join(format!("sub-{id}")).join("beh");
        let runs: Vec<_> = std::fs::read_dir(&beh)
            .unwrap_or_else(|e| panic!("{}: {e}", beh.display()))
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.to_string_lossy().ends_with("_physio.tsv.gz"))
            .collect();
        assert_eq!(runs.len(), sittings, "{runs:?}");
        for run in runs {
            let mut text = String::new();
            let file = std::fs::File::open(&run).expect("physio");
            std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(file), &mut text)
                .expect("gzip");
            let t: Vec<f64> = text
                .lines()
                .map(|l| {
                    l.split('\t')
                        .next()
                        .unwrap_or("")
                        .parse()
                        .expect("timestamp")
                })
                .collect();
            assert!(t.len() > 100, "{}", run.display());
            assert!(t.windows(2).all(|w| w[1] > w[0]), "{}", run.display());
        }
    }
}

/// Within each sitting the timed samples' mapped times increase strictly
/// and their intervals equal the device intervals within 0.1 ms; the
/// session holds exactly the sittings it ran.
fn times_increase_within_each_sitting(dir: &Path, sittings: u32) {
    let path = dir.join("samples.tsv");
    let col = |name| column(&path, name);
    let (sitting, mapped, device, order) = (
        col("sitting"),
        col("mapped_us"),
        col("device_us"),
        col("time_order"),
    );
    let mut seen = std::collections::BTreeSet::new();
    let mut last: Option<(u32, u32, u64, u64)> = None;
    let segment = col("segment");
    for k in 0..mapped.len() {
        let s: u32 = sitting[k].parse().expect("sitting");
        seen.insert(s);
        if matches!(order[k].as_str(), "repeated" | "backwards" | "ahead") {
            continue;
        }
        let m: u64 = mapped[k].parse().expect("mapped_us");
        let d: u64 = device[k].parse().expect("device_us");
        let g: u32 = segment[k].parse().expect("segment");
        if let Some((ls, lg, lm, ld)) = last.filter(|l| l.0 == s) {
            assert!(m > lm, "row {k}: mapped {m} after {lm}");
            if lg == g && order[k] != "reset" {
                let (dm, dd) = (m - lm, d.saturating_sub(ld));
                assert!(
                    dm.abs_diff(dd) <= 100,
                    "row {k}: interval {dm} µs against {dd} µs on the device ({ls})"
                );
            }
        }
        last = Some((s, g, m, d));
    }
    assert_eq!(seen, (1..=sittings).collect(), "{}", dir.display());
}

/// The same protocol with an ISCAN on a pseudo-terminal that reports the
/// raw units of an uncalibrated tracker: the session's calibration must
/// find the mapping before the trials can use the gaze.
#[test]
#[ignore = "slow tier: a windowed experiment session under Xvfb"]
fn a_simulated_participant_on_an_uncalibrated_iscan_is_calibrated_and_searches() {
    let x = Xvfb::start();
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("data");
    let mut c = windowed(&x);
    c.args([
        "experiment",
        "run",
        "tests/data/experiment/design-small.ron",
        "--participant",
        "S07",
        "--tracker",
        "config/trackers/iscan-binary.ron",
        "--display",
        "tests/data/experiment/display-small.ron",
        "--backend",
        "cpu",
        "--simulate-participant",
        "4",
        "--max-trials",
        "2",
        "--no-stimulus-pictures",
        "--out",
    ])
    .arg(&out);
    let run = c.output().expect("runs");
    let log = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        !log.contains("lost") && !log.contains("reconnecting"),
        "{log}"
    );
    let dir = out.join("small-search").join("sub-S07");
    assert_eq!(lines(&dir.join("trials.tsv")).len(), 1 + 2);
    // Calibrated within the design's 1 deg.
    let results: Vec<String> = lines(&dir.join("markers.tsv"))
        .into_iter()
        .filter(|l| l.contains("calibration-result"))
        .collect();
    assert!(
        results
            .iter()
            .any(|l| l.contains("calibrated: validation accuracy")),
        "{results:?}"
    );
    // Raw samples are in the ISCAN's 512-unit frame, mapped ones on the
    // 640x512 screen, and they differ (the mapping is not the identity).
    let samples = dir.join("samples.tsv");
    let search: Vec<bool> = column(&samples, "phase")
        .iter()
        .map(|p| p == "search")
        .collect();
    let pick = |name: &str| -> Vec<f64> {
        column(&samples, name)
            .iter()
            .zip(&search)
            .filter(|(_, s)| **s)
            .filter_map(|(v, _)| v.parse().ok())
            .collect()
    };
    let (raw, x_px) = (pick("raw_x"), pick("x_px"));
    assert!(
        raw.len() > 60 && raw.len() == x_px.len(),
        "{} {}",
        raw.len(),
        x_px.len()
    );
    assert!(raw.iter().all(|r| (0.0..=512.0).contains(r)));
    assert!(x_px.iter().all(|x| (-64.0..=704.0).contains(x)));
    assert!(raw.iter().zip(&x_px).any(|(r, x)| (r - x).abs() > 20.0));
    // The binocular ISCAN's eyes each have their own mapped gaze, and the
    // BIDS export gives one recording per eye with the calibration.
    let (left, right) = (pick("left_x_px"), pick("right_x_px"));
    assert!(left.len() > 60 && right.len() > 60, "{left:?} {right:?}");
    let bids = tmp.path().join("bids");
    common::gazecast()
        .args(["experiment", "export-bids"])
        .arg(&dir)
        .arg("--out")
        .arg(&bids)
        .succeed();
    let beh = bids.join("sub-S07/beh");
    for (k, eye) in [(1, "left"), (2, "right")] {
        let path = beh.join(format!(
            "sub-S07_task-search_run-1_recording-eye{k}_physio.json"
        ));
        let side: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).expect("sidecar")).expect("json");
        assert_eq!(side["RecordedEye"], eye, "{side}");
        assert!(side["CalibrationCount"].as_u64() >= Some(1), "{side}");
        assert!(
            side["AverageCalibrationError"]
                .as_f64()
                .is_some_and(|a| a <= 1.0),
            "{side}"
        );
        assert!(beh
            .join(format!(
                "sub-S07_task-search_run-1_recording-eye{k}_physioevents.tsv.gz"
            ))
            .exists());
    }
}

/// A bad design names its file, line and field; `plan` lists a
/// participant's trials with each mesh the target 11 times.
#[test]
fn plan_lists_the_trials_and_a_bad_design_names_file_line_and_field() {
    let out = common::gazecast()
        .args([
            "experiment",
            "plan",
            "config/experiments/murphy2007-search.ron",
            "--participant-index",
            "3",
        ])
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 44);
    for mesh in 0..4 {
        let n = rows
            .iter()
            .filter(|r| r.split('\t').nth(5) == Some(&mesh.to_string()))
            .count();
        assert_eq!(n, 11, "mesh {mesh}");
    }
    let tmp = tempfile::tempdir().expect("tempdir");
    let bad = tmp.path().join("bad.ron");
    let good = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/experiments/murphy2007-search.ron"),
    )
    .expect("design");
    std::fs::write(
        &bad,
        good.replace("inset_deg: Some(5.0)", "inset_deg: Some(-5.0)"),
    )
    .expect("write");
    let out = common::gazecast()
        .args(["experiment", "plan"])
        .arg(&bad)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.ron:") && err.contains("field `conditions[2].inset_deg`"),
        "{err}"
    );
    let line: usize = err
        .split("bad.ron:")
        .nth(1)
        .and_then(|s| s.split(':').next())
        .and_then(|s| s.parse().ok())
        .expect("a line number");
    assert!(
        good.lines()
            .nth(line - 1)
            .is_some_and(|l| l.contains("NE5")),
        "line {line}"
    );
}

/// `plan` on the shipped designs: every method of §8.1's comparison is one
/// the renderer knows (the check `run` makes), and each trial lists the
/// reference at the centre cell, which is never the target's.
#[test]
fn plan_accepts_the_families_comparison_and_lists_the_reference() {
    for (design, trials, practice) in [
        ("config/experiments/families-comparison.ron", 42, 2),
        ("config/experiments/murphy2007-search.ron", 44, 0),
    ] {
        let out = common::gazecast()
            .args(["experiment", "plan", design])
            .succeed();
        let text = String::from_utf8_lossy(&out.stdout);
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().expect("a header").split('\t').collect();
        let at = |name: &str| {
            header
                .iter()
                .position(|h| *h == name)
                .unwrap_or_else(|| panic!("{design}: no column {name}"))
        };
        let rows: Vec<Vec<&str>> = lines.map(|l| l.split('\t').collect()).collect();
        assert_eq!(rows.len(), trials, "{design}");
        for (k, r) in rows.iter().enumerate() {
            assert_eq!(r[at("practice")], (k < practice).to_string(), "{design}");
            assert_eq!(
                (r[at("reference_row")], r[at("reference_col")]),
                ("2", "2"),
                "{design}"
            );
            assert_ne!(
                (r[at("target_row")], r[at("target_col")]),
                ("2", "2"),
                "{design}"
            );
        }
    }
}

/// A session killed with SIGKILL in the middle keeps every trial it had
/// finished, and `--resume` completes it without a gap or a repeat.
#[test]
#[ignore = "slow tier: windowed experiment sessions under Xvfb, killed and resumed"]
fn a_killed_session_loses_no_finished_trial_and_resumes() {
    let x = Xvfb::start();
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("data");
    let mut c = windowed(&x);
    c.args([
        "experiment",
        "run",
        "tests/data/experiment/design-small.ron",
        "--participant",
        "K01",
        "--tracker",
        "tests/data/mouse-participant.ron",
        "--display",
        "tests/data/experiment/display-small.ron",
        "--backend",
        "cpu",
        "--simulate-participant",
        "8",
        "--no-stimulus-pictures",
        "--out",
    ])
    .arg(&out)
    .stdout(std::process::Stdio::null())
    .stderr(std::process::Stdio::null());
    let mut child = c.spawn().expect("starts");
    let dir = out.join("small-search").join("sub-K01");
    let trials = dir.join("trials.tsv");
    let started = std::time::Instant::now();
    // Kill it once two trials are in the table (or fail after 3 minutes).
    loop {
        let n = std::fs::read_to_string(&trials)
            .map(|t| t.lines().count())
            .unwrap_or(0);
        if n >= 3 {
            break;
        }
        assert!(
            started.elapsed().as_secs() < 180,
            "no trial written in time"
        );
        assert!(
            child.try_wait().expect("wait").is_none(),
            "ended before it was killed"
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    child.kill().expect("SIGKILL");
    let _ = child.wait();
    let kept = lines(&trials).len() - 1;
    assert!(kept >= 2);
    let resumed = run_session(&x, &out, "K01", 9, &["--resume", "--no-stimulus-pictures"]);
    let log = String::from_utf8_lossy(&resumed.stdout);
    assert!(
        resumed.status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert!(log.contains(&format!("trial {} of 11", kept + 1)), "{log}");
    let t = column(&trials, "trial");
    assert_eq!(t, (0..11).map(|k| k.to_string()).collect::<Vec<_>>());
    // Both sittings' raw recordings are there; the killed one may be
    // unclosed, and says so when read.
    assert!(dir.join("gaze-1.gzrec").exists() && dir.join("gaze-2.gzrec").exists());
}

/// A design is checked against the display it runs on before the session
/// folder exists (and before any window): a grid wider than the screen,
/// objects of 1e-42°, a stimulus scene over the triangle limit are each
/// refused with the design field and the real reason, by `run` (exit 1 in
/// well under a second, no `sub-*` folder left) and by `plan --display`.
#[test]
fn a_design_that_does_not_fit_its_display_is_refused_before_the_session_folder() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let good = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/experiments/murphy2007-search.ron"),
    )
    .expect("design");
    let cases = [
        (
            "wide",
            good.replace("grid_deg: 20.0", "grid_deg: 60.0"),
            "stimulus.grid_deg",
            "off the screen",
        ),
        (
            "tiny",
            good.replace("object_deg: 3.5", "object_deg: 1e-42"),
            "stimulus.object_deg",
            "8 px",
        ),
        (
            "big",
            // 31×33 (odd, so the seed's reference has a centre): 1023
            // cells of 20 480 triangles.
            good.replace("grid: (5, 5)", "grid: (31, 33)")
                .replace("object_deg: 3.5", "object_deg: 0.5"),
            "`stimulus`",
            "20000000 triangles",
        ),
    ];
    for (name, text, field, reason) in cases {
        let design = tmp.path().join(format!("{name}.ron"));
        std::fs::write(&design, text).expect("write");
        let out_dir = tmp.path().join(format!("data-{name}"));
        let started = std::time::Instant::now();
        let out = common::gazecast()
            .args(["experiment", "run"])
            .arg(&design)
            .args([
                "--participant",
                "P01",
                "--tracker",
                "tests/data/mouse-participant.ron",
                "--out",
            ])
            .arg(&out_dir)
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{name}: {err}");
        assert!(
            err.contains(&format!("{name}.ron:")) && err.contains(field) && err.contains(reason),
            "{name}: {err}"
        );
        assert!(!out_dir.exists(), "{name}: no session folder");
        assert!(
            started.elapsed().as_secs_f64() < 10.0,
            "{name}: refused at once"
        );
        let out = common::gazecast()
            .args(["experiment", "plan"])
            .arg(&design)
            .output()
            .expect("runs");
        assert_eq!(out.status.code(), Some(1), "plan {name}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(field),
            "plan {name}"
        );
    }
    // The seed design fits the seed display but not a screen of under 6°.
    let small = tmp.path().join("small.ron");
    std::fs::write(
        &small,
        "Display(name: \"small\", resolution_px: (320, 240), size_mm: (100.0, 75.0), eye_distance_mm: 1000.0)",
    )
    .expect("write");
    let out = common::gazecast()
        .args([
            "experiment",
            "plan",
            "config/experiments/murphy2007-search.ron",
            "--display",
        ])
        .arg(&small)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("stimulus.grid_deg") && err.contains("320×240"),
        "{err}"
    );
}

fn small_design() -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/experiment/design-small.ron"),
    )
    .expect("design")
}

/// The 1-based line of `text` that contains `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    1 + text
        .lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("no line has {needle:?}"))
}

/// Designs that must never run are refused by `plan` and by `run` alike,
/// at load, naming the file, the line and the field, before any folder
/// exists: a name that would put the session folder outside `--out`
/// (`../escaped`, an absolute path) and point counts past their bounds
/// (a million calibration or validation targets, a 6×6 grid).
#[test]
fn plan_and_run_refuse_escaping_names_and_unbounded_point_counts() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let good = small_design();
    let abs = tmp.path().join("abs");
    let abs_name = format!("name: {:?}", abs.display().to_string());
    let cases = [
        (
            "escape",
            good.replace("name: \"small-search\"", "name: \"../escaped\""),
            "name: \"../escaped\"",
            "name",
        ),
        (
            "absolute",
            good.replace("name: \"small-search\"", &abs_name),
            abs_name.as_str(),
            "name",
        ),
        (
            "million",
            good.replace("        points: 5,", "        points: 1000000,"),
            "points: 1000000",
            "calibration.points",
        ),
        (
            "thirtysix",
            good.replace("        points: 5,", "        points: 36,"),
            "points: 36",
            "calibration.points",
        ),
        (
            "validation",
            good.replace("validation_points: 5,", "validation_points: 1000000,"),
            "validation_points: 1000000",
            "calibration.validation_points",
        ),
    ];
    for (name, text, at, field) in cases {
        assert_ne!(text, good, "{name}: the case changes the design");
        let design = tmp.path().join(format!("{name}.ron"));
        std::fs::write(&design, &text).expect("write");
        let line = line_of(&text, at);
        let out_dir = tmp.path().join("nest").join(format!("data-{name}"));
        let started = std::time::Instant::now();
        let run = common::gazecast()
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .args(["experiment", "run"])
            .arg(&design)
            .args([
                "--participant",
                "P01",
                "--tracker",
                "tests/data/mouse-participant.ron",
                "--display",
                "tests/data/experiment/display-small.ron",
                "--simulate-participant",
                "1",
                "--out",
            ])
            .arg(&out_dir)
            .output()
            .expect("runs");
        let plan = common::gazecast()
            .args(["experiment", "plan"])
            .arg(&design)
            .args(["--display", "tests/data/experiment/display-small.ron"])
            .output()
            .expect("runs");
        for (what, out) in [("run", run), ("plan", plan)] {
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{what} {name}: {err}");
            let file_line = format!("{name}.ron:{line}:");
            assert!(
                err.contains(&file_line) && err.contains(&format!("field `{field}`")),
                "{what} {name}: wants {file_line} and field `{field}`: {err}"
            );
        }
        assert!(
            started.elapsed().as_secs_f64() < 20.0,
            "{name}: refused at once"
        );
        assert!(!out_dir.exists(), "{name}: no session folder");
        assert!(!tmp.path().join("nest").join("escaped").exists());
        assert!(!abs.exists(), "{name}: nothing outside --out");
    }
}

/// `gazecast calibrate` has the design file's bounds on its target
/// counts: a million targets are refused before any window opens.
#[test]
fn calibrate_refuses_point_counts_past_their_bounds() {
    for (args, says) in [
        (vec!["--points", "1000000"], "--points"),
        (vec!["--points", "36"], "--points"),
        (
            vec!["--validation-points", "1000000"],
            "--validation-points",
        ),
    ] {
        let out = common::gazecast()
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .args([
                "calibrate",
                "--tracker",
                "config/trackers/mouse.ron",
                "--display",
                "tests/data/experiment/display-small.ron",
                "--out",
                "/nonexistent/never-written.ron",
            ])
            .args(&args)
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(
            err.contains(says) && err.contains("at most 25"),
            "{args:?}: {err}"
        );
        // The simulator's calibration script plans the same targets.
        let dir = tempfile::tempdir().expect("tempdir");
        let out = common::gazecast()
            .args([
                "simulate",
                "--tracker",
                "config/trackers/mouse.ron",
                "--script",
                "calibration",
                "--display",
                "tests/data/experiment/display-small.ron",
                "--out",
            ])
            .arg(dir.path().join("never.gzrec"))
            .args(&args)
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "simulate {args:?}");
        assert!(
            err.contains(says) && err.contains("at most 25"),
            "simulate {args:?}: {err}"
        );
    }
}

/// A drift check before every trial (`every_trials: 1`), which `plan`
/// accepts, `run` accepts and performs: a simulated participant's first
/// trials each have a drift check after the first.
#[test]
#[ignore = "slow tier: a windowed experiment session under Xvfb"]
fn a_drift_check_that_plan_accepts_run_performs() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let design = tmp.path().join("drift.ron");
    std::fs::write(
        &design,
        small_design().replace(
            "drift_check: None",
            "drift_check: Some((every_trials: 1, threshold_deg: 3.0))",
        ),
    )
    .expect("write");
    let plan = common::gazecast()
        .args(["experiment", "plan"])
        .arg(&design)
        .args(["--display", "tests/data/experiment/display-small.ron"])
        .succeed();
    let listed = String::from_utf8_lossy(&plan.stdout);
    assert!(listed.contains("DriftCheck"), "{listed}");
    let x = Xvfb::start();
    let out = tmp.path().join("data");
    let run = windowed(&x)
        .args(["experiment", "run"])
        .arg(&design)
        .args([
            "--participant",
            "D01",
            "--tracker",
            "tests/data/mouse-participant.ron",
            "--display",
            "tests/data/experiment/display-small.ron",
            "--backend",
            "cpu",
            "--simulate-participant",
            "4",
            "--no-stimulus-pictures",
            "--max-trials",
            "3",
            "--out",
        ])
        .arg(&out)
        .output()
        .expect("runs");
    let log = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let markers = out.join("small-search/sub-D01/markers.tsv");
    let drift_checks = column(&markers, "event")
        .iter()
        .filter(|e| *e == "start:drift-check")
        .count();
    assert!(drift_checks >= 2, "{drift_checks} drift checks");
}

/// Every frame records what drew it: a design whose conditions are the
/// full control, the hybrid method and `method: "image"` runs with a
/// simulated participant; `frames.tsv`'s `plan` says image-based for the
/// image condition's search frames (foveated and full for the others, the
/// preview's full-resolution renderer for the preview, `n/a` for text and
/// targets) and `trials.tsv`'s `plan` the same per trial. The first
/// sitting's files are then cut back to the columns an older gazecast
/// wrote: the resume adds the column (`n/a` in the old rows, a marker
/// says so), and the BIDS export carries the plans into `events.tsv`.
#[test]
#[ignore = "slow tier: windowed experiment sessions under Xvfb"]
fn an_image_condition_renders_image_based_and_its_frames_say_so() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let design = tmp.path().join("plans.ron");
    let small = small_design();
    let start = small.find("    conditions: [").expect("conditions");
    let end = start + small[start..].find("    ],\n").expect("end") + "    ],\n".len();
    let text = format!(
        "{}{}{}",
        &small[..start],
        r#"    conditions: [
        (name: "control", method: "full"),
        (name: "NE2", method: "hybrid", inset_deg: Some(2.0), silhouette_edges: false, levels: {"inset_deg": "2", "silhouette_edges": "discarded"}),
        (name: "IMG", method: "image"),
    ],
"#,
        &small[end..]
    )
    .replace("break_after_trials: Some(6)", "break_after_trials: None");
    std::fs::write(&design, text).expect("write");
    let x = Xvfb::start();
    let out = tmp.path().join("data");
    let run = |seed: &str, extra: &[&str]| {
        let o = windowed(&x)
            .args(["experiment", "run"])
            .arg(&design)
            .args([
                "--participant",
                "P01",
                "--tracker",
                "tests/data/mouse-participant.ron",
                "--display",
                "tests/data/experiment/display-small.ron",
                "--backend",
                "cpu",
                "--simulate-participant",
                seed,
                "--no-stimulus-pictures",
                "--out",
            ])
            .arg(&out)
            .args(extra)
            .output()
            .expect("runs");
        let log = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            o.status.success(),
            "{log}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        log
    };
    let dir = out.join("small-search/sub-P01");
    let (trials, frames) = (dir.join("trials.tsv"), dir.join("frames.tsv"));
    const FULL: &str = "full on cpu; passes: none";

    // Sitting 1: the first trial (the control, row 0 of the Latin square).
    run("5", &["--max-trials", "1"]);
    assert_eq!(column(&trials, "condition"), ["control"]);
    assert_eq!(column(&trials, "plan"), [FULL]);
    let phases = column(&frames, "phase");
    let plans = column(&frames, "plan");
    for (phase, plan) in phases.iter().zip(&plans) {
        match phase.as_str() {
            "search" | "preview" | "confirm" => assert_eq!(plan, FULL, "{phase}"),
            _ => assert_eq!(plan, "n/a", "{phase}"),
        }
    }
    assert!(phases.iter().any(|p| p == "search"));

    // As a gazecast before the plan column wrote them (in trials.tsv the
    // reference and cost columns came after it).
    for (f, n) in [(&trials, 7), (&frames, 6)] {
        let cut: String = lines(f)
            .iter()
            .map(|l| {
                let mut l = l.as_str();
                for _ in 0..n {
                    l = l.rsplit_once('\t').expect("a tab").0;
                }
                l.to_string() + "\n"
            })
            .collect();
        assert!(!cut.contains("plan") && !cut.contains("on cpu"));
        std::fs::write(f, cut).expect("write");
    }

    // Sitting 2: the rest, on the old files.
    let log = run("6", &["--resume"]);
    assert!(
        log.contains(
            "trials.tsv: written before its columns plan, reference_row, reference_col, \
             mean_triangles, mean_render_ms, p95_render_ms, practice existed"
        ) && log.contains(
            "frames.tsv: written before its columns plan, gpu_uploaded_bytes, \
             gpu_read_back_bytes, gpu_dispatches, gpu_draws, gpu_submits existed"
        ),
        "{log}"
    );
    assert_eq!(
        column(&dir.join("markers.tsv"), "event")
            .iter()
            .filter(|e| *e == "file-columns-added")
            .count(),
        2
    );
    let conditions = column(&trials, "condition");
    assert_eq!(conditions, ["control", "NE2", "IMG"]);
    let trial_plans = column(&trials, "plan");
    assert_eq!(
        trial_plans[0], "n/a",
        "the first sitting's row, from before"
    );
    assert!(
        trial_plans[1].starts_with("hybrid on cpu; passes: "),
        "{trial_plans:?}"
    );
    // The done-when: the image condition rendered image-based foveation.
    assert!(
        trial_plans[2].starts_with("image on cpu; passes: "),
        "{trial_plans:?}"
    );
    let (sitting, trial, phases, plans) = (
        column(&frames, "sitting"),
        column(&frames, "trial"),
        column(&frames, "phase"),
        column(&frames, "plan"),
    );
    let mut search_frames = [0usize; 3];
    for k in 0..phases.len() {
        let (phase, plan) = (phases[k].as_str(), plans[k].as_str());
        if sitting[k] == "1" {
            assert_eq!(plan, "n/a", "row {k}: an old row gets n/a");
            continue;
        }
        match phase {
            "search" | "confirm" => {
                let t: usize = trial[k].parse().expect("a trial");
                assert_eq!(plan, trial_plans[t], "row {k}: {phase} of trial {t}");
                if phase == "search" {
                    search_frames[t] += 1;
                }
            }
            "preview" => assert_eq!(plan, FULL, "row {k}"),
            _ => assert_eq!(plan, "n/a", "row {k}: {phase}"),
        }
    }
    assert!(
        search_frames[1] > 0 && search_frames[2] > 0,
        "{search_frames:?}"
    );

    // The BIDS export: each trial's plan in events.tsv, described in events.json.
    let bids = tmp.path().join("bids");
    common::gazecast()
        .args(["experiment", "export-bids"])
        .arg(&dir)
        .arg("--out")
        .arg(&bids)
        .succeed();
    let beh = bids.join("sub-P01/beh");
    let events = |run: u32| beh.join(format!("sub-P01_task-search_run-{run}_events.tsv"));
    assert_eq!(column(&events(1), "plan"), ["n/a"]);
    assert_eq!(column(&events(2), "plan"), &trial_plans[1..]);
    let sidecar =
        std::fs::read_to_string(beh.join("sub-P01_task-search_run-2_events.json")).expect("json");
    assert!(sidecar.contains("\"plan\""), "{sidecar}");
}

/// A headless simulated session (`--headless`): no window and no display
/// (DISPLAY unset), seven trials of the small design (calibration,
/// validation, a break, the mid-point validation) on the virtual clock. Its
/// samples, events and responses depend on the seeds alone: two runs give
/// the same files byte for byte but for the render times, whatever the
/// machine's load; every file says synthetic and the sitting's clock says
/// virtual. Without a simulated participant `--headless` is refused.
#[test]
#[ignore = "slow tier: whole seven-trial sessions run twice to compare (headless and in a window under Xvfb)"]
fn a_headless_session_runs_on_a_virtual_clock_and_repeats_exactly() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let run = |out: &Path, extra: &[&str]| {
        common::small_session(common::SMALL_DESIGN.as_ref(), "cpu", out, extra)
    };
    let refused = run(&tmp.path().join("none"), &["--headless"]);
    assert!(!refused.status.success());
    assert!(!tmp.path().join("none").exists());
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    for out in [&a, &b] {
        let o = run(
            out,
            &[
                "--headless",
                "--simulate-participant",
                "4",
                "--max-trials",
                "7",
            ],
        );
        let log = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{log}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(log.contains("stopping after 7 trials"), "{log}");
    }
    let (da, db) = (
        a.join("small-search").join("sub-P01"),
        b.join("small-search").join("sub-P01"),
    );
    for file in ["samples.tsv", "events.tsv"] {
        assert_eq!(
            std::fs::read(da.join(file)).expect("a"),
            std::fs::read(db.join(file)).expect("b"),
            "{file} differs between two headless runs"
        );
    }
    for col in [
        "condition",
        "rt_s",
        "correct",
        "target_row",
        "target_col",
        "clicked_row",
        "clicked_col",
        "search_onset_us",
    ] {
        assert_eq!(
            column(&da.join("trials.tsv"), col),
            column(&db.join("trials.tsv"), col),
            "trials.tsv {col}"
        );
    }
    // Seven trials: the break after six and its screens ran too.
    assert_eq!(column(&da.join("trials.tsv"), "trial").len(), 7);
    assert!(column(&da.join("trials.tsv"), "synthetic")
        .iter()
        .all(|s| s == "true"));
    // Frames are one refresh period apart on the virtual clock.
    let intervals = column(&da.join("frames.tsv"), "interval_ms");
    assert!(
        intervals[1..].iter().all(|i| i == "16.667"),
        "{intervals:?}"
    );
    let info = std::fs::read_to_string(da.join("session.json")).expect("info");
    assert!(
        info.contains("virtual clock of a headless simulation"),
        "{info}"
    );
    // The gaze tolerance (0.5° by default headless) kept frames, and says so.
    let markers = std::fs::read_to_string(da.join("markers.tsv")).expect("markers");
    assert!(markers.contains("frames-kept"), "{markers}");

    // The observer model that sees the rendering runs headless too; a bad
    // model file is refused naming its line and field, before any folder.
    let model =
        std::fs::read_to_string("../../config/participants/search-observer.ron").expect("model");
    let bad = tmp.path().join("bad-observer.ron");
    std::fs::write(&bad, model.replace("lapse: 0.05", "lapse: 2.0")).expect("write");
    let o = run(
        &tmp.path().join("bad"),
        &[
            "--headless",
            "--simulate-participant",
            "4",
            "--participant-model",
        ],
    );
    assert!(!o.status.success(), "a missing model path is refused");
    let o = run(
        &tmp.path().join("bad"),
        &[
            "--headless",
            "--simulate-participant",
            "4",
            "--participant-model",
            bad.to_str().expect("a UTF-8 temporary path"),
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("lapse") && err.contains("bad-observer.ron:"),
        "{err}"
    );
    assert!(!tmp.path().join("bad").exists());
    let m = tmp.path().join("m");
    let o = run(
        &m,
        &[
            "--headless",
            "--simulate-participant",
            "4",
            "--participant-model",
            "config/participants/search-observer.ron",
            "--max-trials",
            "3",
        ],
    );
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let dm = m.join("small-search").join("sub-P01");
    assert_eq!(column(&dm.join("trials.tsv"), "trial").len(), 3);
    // It searches differently from the stand-in with the same seed.
    assert_ne!(
        column(&dm.join("trials.tsv"), "rt_s"),
        column(&da.join("trials.tsv"), "rt_s")[..3].to_vec()
    );
}

/// An RGB PNG's size and bytes.
fn read_rgb(path: &Path) -> ((u32, u32), Vec<u8>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("a frame");
    assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
    buf.truncate(info.buffer_size());
    ((info.width, info.height), buf)
}

/// The small design with an NE2 (hybrid) and a control condition, and a
/// full-resolution reference at the corner cell (0, 0); its text.
fn reference_design(path: &Path) -> String {
    let small = small_design();
    let start = small.find("    conditions: [").expect("conditions");
    let end = start + small[start..].find("    ],\n").expect("end") + "    ],\n".len();
    let text = format!(
        "{}{}{}",
        &small[..start],
        r#"    conditions: [
        (name: "NE2", method: "hybrid", inset_deg: Some(2.0), silhouette_edges: false, levels: {"inset_deg": "2", "silhouette_edges": "discarded"}),
        (name: "control", method: "full"),
    ],
"#,
        &small[end..]
    )
    .replace("break_after_trials: Some(6)", "break_after_trials: None")
    .replace(
        "grid_deg: 20.0)",
        "grid_deg: 20.0, reference: Some((at: Cell(0, 0), detail: Full)))",
    );
    std::fs::write(path, &text).expect("write");
    text
}

/// Within a cell's face (the full-resolution picture's pixels that are
/// not background, within 1.2 radii of the cell's centre) of `full`, how
/// many pixels there are and how many of `shown` differ.
fn face_pixels_differing(
    design_text: &str,
    (size, full): (&(u32, u32), &[u8]),
    shown: &[u8],
    cell: (u32, u32),
) -> (usize, usize) {
    let d = experiment::Design::from_ron_str(design_text).expect("design");
    let geometry = foveation::Display {
        name: "small".into(),
        resolution_px: (640, 512),
        size_mm: (168.95, 135.15),
        eye_distance_mm: 270.0,
        eye_point_px: None,
    }
    .geometry()
    .expect("geometry");
    let layout = experiment::run::layout::Layout::new(&d, &geometry);
    let background = &full[0..3];
    let c = layout.centre_px(cell);
    let r = layout.radius_px * 1.2;
    let (mut face, mut differ) = (0, 0);
    for y in 0..size.1 {
        for x in 0..size.0 {
            let (fx, fy) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            if (fx - c[0]).hypot(fy - c[1]) > r {
                continue;
            }
            let i = 3 * (y * size.0 + x) as usize;
            if &full[i..i + 3] == background {
                continue;
            }
            face += 1;
            differ += usize::from(shown[i..i + 3] != full[i..i + 3]);
        }
    }
    (face, differ)
}

/// One trial of `design` on `backend` in a window on `x`, a simulated
/// participant answering, its screens saved in `shots`, its data in `out`.
fn one_reference_trial(
    x: &Xvfb,
    design: &Path,
    backend: &str,
    shots: &Path,
    out: &Path,
) -> std::process::Command {
    let mut c = windowed(x);
    c.args(["experiment", "run"])
        .arg(design)
        .args([
            "--participant",
            "P01",
            "--tracker",
            "tests/data/mouse-participant.ron",
            "--display",
            "tests/data/experiment/display-small.ron",
            "--backend",
            backend,
            "--simulate-participant",
            "4",
            "--max-trials",
            "1",
            "--screenshots",
        ])
        .arg(shots)
        .arg("--out")
        .arg(out);
    c
}

/// The reference with `detail: Full` is drawn at full resolution whatever
/// the method: a reference at the corner cell (0, 0), 12° from the gaze at
/// the centre, in an NE2 search frame equals the full-resolution stimulus
/// picture pixel for pixel over the face, while the face in the other top
/// corner (0, 4), as far out, is the hybrid method's degraded one.
#[test]
#[ignore = "slow tier: a windowed experiment session under Xvfb at full resolution"]
fn a_full_reference_is_drawn_at_full_resolution_under_the_hybrid_method() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let design = tmp.path().join("reference.ron");
    let text = reference_design(&design);
    let shots = tmp.path().join("shots");
    std::fs::create_dir(&shots).expect("mkdir");
    let x = Xvfb::start();
    let out = tmp.path().join("data");
    let o = one_reference_trial(&x, &design, "cpu", &shots, &out)
        .output()
        .expect("runs");
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let dir = out.join("small-search/sub-P01");
    assert_eq!(column(&dir.join("trials.tsv"), "condition"), ["NE2"]);
    assert_eq!(column(&dir.join("trials.tsv"), "reference_row"), ["0"]);
    assert_eq!(column(&dir.join("trials.tsv"), "reference_col"), ["0"]);
    let (size, search) = read_rgb(&shots.join("search.png"));
    let (full_size, full) = read_rgb(&dir.join("stimuli/trial-000.png"));
    assert_eq!(size, full_size);
    let compare = |cell| face_pixels_differing(&text, (&size, &full), &search, cell);
    let (face, differ) = compare((0, 0));
    assert!(face > 500, "the reference face: {face} px");
    assert_eq!(
        differ, 0,
        "the reference differs from full resolution at {differ} px"
    );
    let (face, differ) = compare((0, 4));
    assert!(face > 500, "the corner face: {face} px");
    assert!(
        differ > face / 20,
        "the non-reference corner face should be degraded by NE2: {differ} of {face} px differ"
    );
}

/// On the GPU backend the experiment's window and every trial's renderer
/// share one device, and the search frames are drawn into the window from
/// the GPU with the trial's reference object as an overlay: frames.tsv
/// says a rendered search frame read back 16 B at most (a foveated
/// frame's ray counters) where it read back 4 B a pixel before; what the
/// window showed (Xvfb's screen, read while the session runs) has the
/// reference at full resolution pixel for pixel at its corner; and the
/// search screenshot, read back on demand, is the same picture the CPU
/// path saves (the reference exact, the other corner degraded).
#[test]
#[ignore = "slow tier: a windowed experiment session under Xvfb on lavapipe"]
fn gpu_search_frames_are_drawn_into_the_experiment_window_without_a_read_back() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let design = tmp.path().join("reference.ron");
    // No confirming click: its screen (the last search frame read back,
    // the reference drawn on the CPU) must not stand in for the window's
    // search frames below.
    let text = reference_design(&design).replace("confirm_click: true", "confirm_click: false");
    std::fs::write(&design, &text).expect("write");
    let shots = tmp.path().join("shots");
    std::fs::create_dir(&shots).expect("mkdir");
    let x = Xvfb::start_with_screen_file();
    let out = tmp.path().join("data");
    let mut child = one_reference_trial(&x, &design, "gpu", &shots, &out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("runs");
    // What the window shows, every 50 ms until the session ends.
    let mut screens = Vec::new();
    let status = loop {
        if let Some(status) = child.try_wait().expect("waits") {
            break status;
        }
        screens.push(x.screen((640, 512)));
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let o = child.wait_with_output().expect("output");
    let log = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(log.contains("presenting on the renderer's GPU"), "{log}");
    let dir = out.join("small-search/sub-P01");
    assert_eq!(column(&dir.join("trials.tsv"), "condition"), ["NE2"]);
    let frames = dir.join("frames.tsv");
    let phase = column(&frames, "phase");
    let read = column(&frames, "gpu_read_back_bytes");
    let mut rendered = 0;
    for (k, (p, r)) in phase.iter().zip(&read).enumerate() {
        if p == "search" {
            let bytes: u64 = r.parse().expect("a count on a search frame");
            assert!(bytes <= 16, "row {k}: {bytes} B read back");
            rendered += usize::from(bytes > 0);
        }
    }
    assert!(rendered >= 1, "no rendered search frame: {read:?}");
    let (size, full) = read_rgb(&dir.join("stimuli/trial-000.png"));
    // The screenshot, read back on demand with the reference drawn over.
    let (_, search) = read_rgb(&shots.join("search.png"));
    let compare = |shown: &[u8], cell| face_pixels_differing(&text, (&size, &full), shown, cell);
    assert_eq!(compare(&search, (0, 0)).1, 0, "the screenshot's reference");
    let (face, differ) = compare(&search, (0, 4));
    assert!(differ > face / 20, "{differ} of {face} px");
    // The window: a search frame was shown (its corner face degraded) with
    // the reference exact at its corner.
    let shown = screens.iter().find(|s| {
        let (face, differ) = compare(s, (0, 4));
        differ > face / 20 && compare(s, (0, 0)).1 == 0
    });
    assert!(
        shown.is_some(),
        "no screen of {} showed the search frame with the exact reference",
        screens.len()
    );
}

/// A design with practice (Murphy 2007 §7.1.5), run headless: the practice
/// trials come first on the practice condition and every file marks them
/// (trials and events: `practice`; samples, frames and markers: the
/// `practice-` phases; the BIDS events: `practice`); the screen that ends
/// practice comes before the first experimental trial; the analysis
/// counts them and leaves them out.
#[test]
fn practice_trials_run_first_and_are_marked_in_every_file() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let design = tmp.path().join("practice.ron");
    let text =
        std::fs::read_to_string("../../tests/data/experiment/design-small.ron").expect("design");
    let text = text.replace(
        "drift_check: None,",
        "drift_check: None,\n    practice: Some((trials: 2, condition: \"E20\")),",
    );
    assert!(text.contains("practice: Some"));
    std::fs::write(&design, text).expect("write design");
    let out = tmp.path().join("data");
    let o = common::small_session(
        design.as_os_str(),
        "cpu",
        &out,
        &[
            "--headless",
            "--simulate-participant",
            "5",
            "--max-trials",
            "5",
        ],
    );
    let log = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{log}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(log.contains("practice trial 1 E20"), "{log}");
    let dir = out.join("small-search").join("sub-P01");
    let trials = dir.join("trials.tsv");
    assert_eq!(column(&trials, "trial"), ["0", "1", "2", "3", "4"]);
    assert_eq!(
        column(&trials, "practice"),
        ["true", "true", "false", "false", "false"]
    );
    let conditions = column(&trials, "condition");
    assert_eq!(conditions[..2], ["E20", "E20"]);
    // The experimental trials are the plan's without practice: row 0 of
    // the Latin square starts with the control.
    assert_eq!(conditions[2], "control");
    // Events: the practice trials' marked, the others not.
    let ev_trial = column(&dir.join("events.tsv"), "trial");
    let ev_practice = column(&dir.join("events.tsv"), "practice");
    assert!(!ev_trial.is_empty());
    for (t, p) in ev_trial.iter().zip(&ev_practice) {
        let want = if t == "0" || t == "1" {
            "true"
        } else {
            "false"
        };
        assert_eq!(p, want, "event of trial {t}");
    }
    // Samples and frames: the practice trials' phases say practice.
    for file in ["samples.tsv", "frames.tsv"] {
        let path = dir.join(file);
        let phases = column(&path, "phase");
        let trial = column(&path, "trial");
        assert!(phases.iter().any(|p| p == "practice-search"), "{file}");
        assert!(phases.iter().any(|p| p == "search"), "{file}");
        for (p, t) in phases.iter().zip(&trial) {
            if p.ends_with("search") || p.ends_with("preview") || p.ends_with("confirm") {
                assert_eq!(
                    p.starts_with("practice-"),
                    t == "0" || t == "1",
                    "{file}: {p} in trial {t}"
                );
            }
        }
    }
    let markers = std::fs::read_to_string(dir.join("markers.tsv")).expect("markers");
    let at = |what: &str| {
        markers
            .find(what)
            .unwrap_or_else(|| panic!("no {what} in markers.tsv"))
    };
    assert!(at("start:practice-search") < at("start:practice-over"));
    assert!(at("start:practice-over") < at("start:search"));
    // The analysis counts the practice trials and leaves them out.
    let report = tmp.path().join("report");
    let o = common::gazecast()
        .args(["experiment", "analyze"])
        .arg(&dir)
        .arg("--out")
        .arg(&report)
        .succeed();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("3 trials of 1 participants (2 practice trials left out"),
        "{said}"
    );
    // The BIDS export marks them.
    let bids = tmp.path().join("bids");
    common::gazecast()
        .args(["experiment", "export-bids"])
        .arg(&dir)
        .arg("--out")
        .arg(&bids)
        .succeed();
    let events = bids.join("sub-P01/beh/sub-P01_task-search_run-1_events.tsv");
    assert_eq!(column(&events, "practice"), ["1", "1", "0", "0", "0"]);
}

/// Issue 35: `frames.tsv` carries each frame's GPU traffic (counted at the
/// `wgpu` calls): a search frame the GPU rendered states its bytes
/// uploaded and read back, dispatches and submissions; a search frame
/// shown again within the gaze tolerance moved nothing (0); every screen
/// no GPU renderer drew says `n/a`, and so does every frame on the CPU.
#[test]
#[ignore = "slow tier: whole experiment sessions on lavapipe and the CPU"]
fn frames_state_their_gpu_traffic() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let run = |backend: &str| {
        let out = tmp.path().join(backend);
        let o = common::small_session(
            common::SMALL_DESIGN.as_ref(),
            backend,
            &out,
            &[
                "--headless",
                "--simulate-participant",
                "3",
                "--max-trials",
                "2",
            ],
        );
        assert!(
            o.status.success(),
            "{}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        out.join("small-search/sub-P01/frames.tsv")
    };
    let gpu = run("gpu");
    let phase = column(&gpu, "phase");
    let rays = column(&gpu, "rays");
    let cols: Vec<Vec<String>> = [
        "gpu_uploaded_bytes",
        "gpu_read_back_bytes",
        "gpu_dispatches",
        "gpu_submits",
    ]
    .iter()
    .map(|c| column(&gpu, c))
    .collect();
    let (mut rendered, mut kept) = (0, 0);
    for k in 0..phase.len() {
        let row: Vec<&str> = cols.iter().map(|c| c[k].as_str()).collect();
        if phase[k] != "search" {
            assert_eq!(row, ["n/a"; 4], "row {k}: {}", phase[k]);
            continue;
        }
        let n: Vec<u64> = row
            .iter()
            .map(|v| v.parse().expect("a count on a search frame"))
            .collect();
        if n == [0, 0, 0, 0] {
            kept += 1;
        } else {
            rendered += 1;
            // Uniforms at least; the frame read back (4 B a pixel of
            // 640×512 at least); one submission or more.
            assert!(n[0] >= 80 && n[1] >= 4 * 640 * 512 && n[2] >= 1 && n[3] >= 1);
        }
        assert!(rays[k].parse::<u64>().expect("rays") > 0);
    }
    assert!(
        rendered >= 2 && kept >= 1,
        "{rendered} rendered, {kept} kept"
    );
    let cpu = run("cpu");
    assert!(column(&cpu, "gpu_uploaded_bytes")
        .iter()
        .all(|v| v == "n/a"));
}
