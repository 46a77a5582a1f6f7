//! The analysis on generated session folders: its numbers against
//! `stats` called directly, Table 7.1's cells, the files it writes, the
//! synthetic labelling, and the errors on bad inputs.
//!
//! Set `ANALYSIS_SAMPLE_DIR` to keep a full-size sample output there.

use experiment::analysis::{analyze, AnalysisError, AnalyzeOptions, Computed};
use experiment::design::Design;
use experiment::session::{
    self, DisplayInfo, EventRow, SessionInfo, TrialRow, TsvLog, TsvRow, DESIGN_RON, SESSION_JSON,
    TRIALS_TSV,
};
use experiment::stats;
use std::path::{Path, PathBuf};

const SEED_DESIGN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../config/experiments/murphy2007-search.ron"
);

/// The seed's Table 7.1 means (s) by condition name; the mean each
/// generated condition is built around.
fn seed_mean(name: &str) -> f64 {
    match name {
        "control" => 8.69,
        "NE2" => 10.22,
        "NE5" => 8.80,
        "NE10" => 7.84,
        "NE15" => 8.38,
        "NE20" => 7.97,
        "E2" => 7.47,
        "E5" => 6.95,
        "E10" => 8.69,
        "E15" => 6.65,
        "E20" => 6.27,
        _ => 5.0,
    }
}

/// A small deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

struct Gen {
    participant: String,
    index: usize,
    synthetic: bool,
    /// Trials (by session index) that get a stimulus picture and fixations.
    stimuli: Vec<usize>,
    stimulus_size: (u32, u32),
    /// Every `incorrect_every`-th trial is incorrect (0: none).
    incorrect_every: usize,
}

impl Gen {
    fn new(participant: &str, index: usize) -> Self {
        Gen {
            participant: participant.into(),
            index,
            synthetic: false,
            stimuli: vec![0, 5],
            stimulus_size: (320, 256),
            incorrect_every: 0,
        }
    }
}

fn display() -> DisplayInfo {
    DisplayInfo {
        name: "17-inch LCD".into(),
        width_px: 1280,
        height_px: 1024,
        width_mm: 337.9,
        height_mm: 270.3,
        distance_mm: 540.0,
    }
}

/// Writes a session folder for the seed design and returns its trial rows.
fn make_session(dir: &Path, g: &Gen) -> Vec<TrialRow> {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::copy(SEED_DESIGN, dir.join(DESIGN_RON)).unwrap();
    let design = Design::load(SEED_DESIGN).unwrap();
    SessionInfo {
        participant: g.participant.clone(),
        participant_index: g.index,
        design_name: design.name.clone(),
        software: "gazecast 0.1.0-test".into(),
        display: display(),
        tracker: "simulated tracker".into(),
        tracker_rate_hz: Some(50.0),
        started_unix_s: 1.7e9,
        synthetic: g.synthetic,
        notes: vec![],
        sittings: Vec::new(),
    }
    .write(&dir.join(SESSION_JSON))
    .unwrap();
    let plan = experiment::plan(&design, g.index).unwrap();
    let mut rng = Rng(1000 + g.index as u64);
    let mut rows = Vec::new();
    let mut trials = TsvLog::<TrialRow>::append_to(dir.join(TRIALS_TSV)).unwrap();
    let mut events = TsvLog::<EventRow>::append_to(dir.join(session::EVENTS_TSV)).unwrap();
    let mut t_us = 5_000_000u64;
    for t in &plan {
        let c = &design.conditions[t.condition];
        let rt = seed_mean(&c.name) + 0.4 * g.index as f64 + 3.0 * (rng.next() - 0.5);
        let onset = t_us;
        let response = onset + (rt * 1e6).round() as u64;
        let incorrect = g.incorrect_every > 0 && t.index % g.incorrect_every == 1;
        let row = TrialRow {
            participant: g.participant.clone(),
            sitting: 1,
            run: t.run,
            trial: t.index,
            trial_in_run: t.trial_in_run,
            condition: c.name.clone(),
            method: c.method.clone(),
            inset_deg: c.inset_deg,
            silhouette_edges: c.silhouette_edges,
            target_mesh: (t.index % 4) as u32,
            target_row: t.target_cell.0,
            target_col: t.target_cell.1,
            search_onset_us: onset,
            response_us: response,
            rt_s: rt,
            clicked_row: Some(t.target_cell.0),
            clicked_col: Some(if incorrect {
                (t.target_cell.1 + 1) % 5
            } else {
                t.target_cell.1
            }),
            correct: Some(!incorrect),
            frames: 100,
            frames_late: 1,
            mean_rays: 50_000.0,
            synthetic: g.synthetic,
            plan: None,
            reference_row: None,
            reference_col: None,
            mean_triangles: None,
            mean_render_ms: None,
            p95_render_ms: None,
            practice: false,
        };
        trials.write(&row).unwrap();
        if g.stimuli.contains(&t.index) {
            write_stimulus(dir, t.index, g.stimulus_size);
            // A counter-clockwise sweep around the centre, then back to the
            // centre (the reference mesh), then the target.
            let (cx, cy) = (640.0, 512.0);
            let mut at = onset.saturating_sub(100_000); // starts before onset: clipped
            let n = 9;
            for k in 0..n {
                let (x, y) = if k == 0 || k == n - 2 {
                    (cx, cy)
                } else {
                    let a = k as f64 * 0.8;
                    (cx + 330.0 * a.cos(), cy - 330.0 * a.sin())
                };
                let dur = 150_000 + 90_000 * (k as u64 % 4);
                events
                    .write(&EventRow {
                        sitting: 1,
                        trial: Some(t.index),
                        kind: "fixation".into(),
                        onset_us: at,
                        end_us: at + dur,
                        onset_device_us: 0,
                        end_device_us: 0,
                        x_px: x,
                        y_px: y,
                        end_x_px: x,
                        end_y_px: y,
                        practice: false,
                    })
                    .unwrap();
                events
                    .write(&EventRow {
                        sitting: 1,
                        trial: Some(t.index),
                        kind: "saccade".into(),
                        onset_us: at + dur,
                        end_us: at + dur + 40_000,
                        onset_device_us: 0,
                        end_device_us: 0,
                        x_px: x,
                        y_px: y,
                        end_x_px: x + 1.0,
                        end_y_px: y + 1.0,
                        practice: false,
                    })
                    .unwrap();
                at += dur + 40_000;
            }
            // A fixation after the response: not drawn.
            events
                .write(&EventRow {
                    sitting: 1,
                    trial: Some(t.index),
                    kind: "fixation".into(),
                    onset_us: response + 10_000,
                    end_us: response + 300_000,
                    onset_device_us: 0,
                    end_device_us: 0,
                    x_px: 10.0,
                    y_px: 10.0,
                    end_x_px: 10.0,
                    end_y_px: 10.0,
                    practice: false,
                })
                .unwrap();
        }
        rows.push(row);
        t_us = response + 3_000_000;
    }
    rows
}

/// A grey search display: a 5×5 grid of "meshes" (discs) plus the centre.
fn write_stimulus(dir: &Path, trial: usize, (w, h): (u32, u32)) {
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = ((y * w + x) * 3) as usize;
            let (fx, fy) = (x as f64 / w as f64, y as f64 / h as f64);
            let mut v = 40u8;
            for r in 0..5 {
                for c in 0..5 {
                    let (gx, gy) = (0.2 + 0.15 * c as f64, 0.2 + 0.15 * r as f64);
                    let d = ((fx - gx) * w as f64).hypot((fy - gy) * h as f64);
                    if d < w as f64 * 0.04 {
                        v = 90 + 25 * ((r * 5 + c + trial) % 4) as u8;
                    }
                }
            }
            rgb[i..i + 3].copy_from_slice(&[v, v, v + 10]);
        }
    }
    let dir = dir.join(session::STIMULI_DIR);
    std::fs::create_dir_all(&dir).unwrap();
    experiment::figures::write_png_rgb(&dir.join(session::stimulus_file_name(trial)), (w, h), &rgb)
        .unwrap();
}

fn close(got: f64, want: f64, what: &str) {
    let tol = 1e-9 * want.abs().max(1.0);
    assert!((got - want).abs() <= tol, "{what}: got {got}, want {want}");
}

fn decode_png(path: &Path) -> (u32, u32, Vec<u8>) {
    experiment::figures::read_png_rgb(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn three_sessions(root: &Path) -> (Vec<PathBuf>, Vec<Vec<TrialRow>>) {
    let mut dirs = Vec::new();
    let mut rows = Vec::new();
    for (i, p) in ["P01", "P02", "P03"].iter().enumerate() {
        let d = root.join(format!("sess-{p}"));
        rows.push(make_session(&d, &Gen::new(p, i)));
        dirs.push(d);
    }
    (dirs, rows)
}

#[test]
fn numbers_match_stats_called_directly() {
    let tmp = tempfile::tempdir().unwrap();
    let (dirs, rows) = three_sessions(tmp.path());
    let out = tmp.path().join("out");
    let report = analyze(&dirs, &out, &AnalyzeOptions::default()).unwrap();
    let design = Design::load(SEED_DESIGN).unwrap();
    let names: Vec<&str> = design.conditions.iter().map(|c| c.name.as_str()).collect();

    // Pooled groups in design order, participants in input order.
    let group = |pick: &dyn Fn(&TrialRow) -> bool| -> Vec<f64> {
        rows.iter()
            .flatten()
            .filter(|t| pick(t))
            .map(|t| t.rt_s)
            .collect()
    };
    let groups: Vec<Vec<f64>> = names
        .iter()
        .map(|n| group(&|t: &TrialRow| t.condition == *n))
        .collect();
    assert_eq!(report.n_trials, 3 * 44);
    assert_eq!(report.n_trials_read, 3 * 44);
    assert_eq!(report.sessions.len(), 3);
    assert!(!report.synthetic);

    for (c, xs) in report.conditions.iter().zip(&groups) {
        let want = stats::summarize(xs).unwrap();
        let got = c.summary.unwrap();
        assert_eq!(got.n, 12, "{}", c.name);
        assert_eq!(c.n_trials, 12);
        assert_eq!(c.n_incorrect, 0);
        close(got.mean, want.mean, &c.name);
        close(got.se, want.se, &c.name);
        close(got.sd, want.sd, &c.name);
    }

    let slices: Vec<&[f64]> = groups.iter().map(|g| g.as_slice()).collect();
    let want = stats::one_way_anova(&slices).unwrap();
    let a = report.anova.done().expect("ANOVA computed");
    assert_eq!((a.anova.df_between, a.anova.df_within), (10.0, 121.0));
    close(a.anova.f, want.f, "F");
    close(a.anova.p, want.p, "p");
    assert!(a.apa().starts_with("F(10,121) = "), "{}", a.apa());

    // Edges: E / NE / control.
    let e = group(&|t: &TrialRow| t.method == "hybrid" && t.silhouette_edges);
    let ne = group(&|t: &TrialRow| t.method == "hybrid" && !t.silhouette_edges);
    let ctl = group(&|t: &TrialRow| t.method == "full");
    let want = stats::one_way_anova(&[&e, &ne, &ctl]).unwrap();
    let edges = report.edges.done().expect("edges computed");
    assert_eq!(edges.anova.groups, vec!["E", "NE", "Control"]);
    assert_eq!(
        (edges.anova.anova.df_between, edges.anova.anova.df_within),
        (2.0, 129.0)
    );
    close(edges.anova.anova.f, want.f, "edges F");
    close(edges.anova.anova.p, want.p, "edges p");
    let want_pairs = stats::pairwise_t_pooled(&[&e, &ne, &ctl]).unwrap();
    assert_eq!(edges.pairs.len(), 3);
    for (g, w) in edges.pairs.iter().zip(&want_pairs) {
        close(g.pair.t, w.t, "edges t");
        close(g.pair.p_holm, w.p_holm, "edges p_holm");
    }
    assert_eq!(
        (edges.pairs[0].a.as_str(), edges.pairs[0].b.as_str()),
        ("E", "NE")
    );
    close(
        edges.groups[0].summary.mean,
        stats::summarize(&e).unwrap().mean,
        "E mean",
    );

    // Repeated measures on per-participant means.
    let per: Vec<Vec<f64>> = rows
        .iter()
        .map(|rs| {
            names
                .iter()
                .map(|n| {
                    let xs: Vec<f64> = rs
                        .iter()
                        .filter(|t| t.condition == *n)
                        .map(|t| t.rt_s)
                        .collect();
                    xs.iter().sum::<f64>() / xs.len() as f64
                })
                .collect()
        })
        .collect();
    let per_slices: Vec<&[f64]> = per.iter().map(|r| r.as_slice()).collect();
    let want = stats::rm_anova(&per_slices).unwrap();
    let rm = report.rm_anova.done().expect("rm computed");
    assert_eq!(rm.participants, vec!["P01", "P02", "P03"]);
    close(rm.rm.f, want.f, "rm F");
    close(rm.rm.gg_epsilon, want.gg_epsilon, "GG epsilon");
    close(rm.rm.p_gg, want.p_gg, "p GG");

    // Pairwise over all 11 conditions.
    let want = stats::pairwise_t_pooled(&slices).unwrap();
    let ps = report.pairwise.done().expect("pairwise computed");
    assert_eq!(ps.len(), 55);
    for (g, w) in ps.iter().zip(&want) {
        assert_eq!((g.a.as_str(), g.b.as_str()), (names[w.a], names[w.b]));
        close(g.pair.p_holm, w.p_holm, "p_holm");
    }
    let want_sig: Vec<(usize, usize)> = want
        .iter()
        .filter(|p| p.p_holm < 0.05)
        .map(|p| (p.a, p.b))
        .collect();
    let got_sig: Vec<(usize, usize)> = report
        .significant
        .iter()
        .map(|p| {
            (
                names.iter().position(|n| *n == p.a).unwrap(),
                names.iter().position(|n| *n == p.b).unwrap(),
            )
        })
        .collect();
    assert_eq!(got_sig, want_sig);
    assert!(
        !want_sig.is_empty(),
        "the generated effects are large enough"
    );
    // Seed pairs, in the asked-for direction (NE2 − E5 > 0 here).
    assert_eq!(report.seed_pairs.len(), 4);
    let sp = &report.seed_pairs[0];
    assert_eq!((sp.a.as_str(), sp.b.as_str()), ("NE2", "E5"));
    let r = sp.result.as_ref().unwrap();
    let i_ne2 = names.iter().position(|n| *n == "NE2").unwrap();
    let i_e5 = names.iter().position(|n| *n == "E5").unwrap();
    let w = want.iter().find(|p| p.a == i_ne2 && p.b == i_e5).unwrap();
    close(r.pair.diff, w.diff, "NE2-E5 diff");
    assert!(r.pair.diff > 0.0);

    // Table 7.1.
    let t = report.table71.as_ref().expect("table 7.1");
    assert_eq!(t.insets, vec![2.0, 5.0, 10.0, 15.0, 20.0]);
    let labels: Vec<&str> = t.rows.iter().map(|r| r.label.as_str()).collect();
    assert_eq!(labels, vec!["No Edges", "Edges"]);
    for (ri, prefix) in [(0, "NE"), (1, "E")] {
        for (j, d) in ["2", "5", "10", "15", "20"].iter().enumerate() {
            let name = format!("{prefix}{d}");
            let want = stats::summarize(&group(&|t: &TrialRow| t.condition == name)).unwrap();
            let got = t.rows[ri].cells[j].unwrap();
            close(got.mean, want.mean, &name);
            assert_eq!(got.n, 12);
        }
    }
    close(
        t.rows[0].pooled.unwrap().mean,
        stats::summarize(&ne).unwrap().mean,
        "NE pooled",
    );
    close(
        t.rows[1].pooled.unwrap().mean,
        stats::summarize(&e).unwrap().mean,
        "E pooled",
    );
    close(
        t.control.unwrap().mean,
        stats::summarize(&ctl).unwrap().mean,
        "control",
    );

    // stats.json: the same statistics at full precision (bit for bit).
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
    let f = json["anova"]["Done"]["anova"]["f"]
        .as_f64()
        .expect("F in stats.json");
    assert_eq!(f, report.anova.done().unwrap().anova.f);
    let gg = json["rm_anova"]["Done"]["rm"]["p_gg"]
        .as_f64()
        .expect("p_gg");
    assert_eq!(gg, report.rm_anova.done().unwrap().rm.p_gg);
    assert_eq!(json["synthetic"], serde_json::Value::Bool(false));
    assert_eq!(
        json["conditions"][0]["summary"]["mean"].as_f64(),
        report.conditions[0].summary.map(|s| s.mean)
    );

    // The files.
    for name in [
        "report.md",
        "stats.json",
        "conditions.csv",
        "table-7.1.csv",
        "fig-7.3.png",
        "fig-7.4.png",
        "fig-conditions.png",
    ] {
        assert!(out.join(name).is_file(), "{name} written");
        assert!(report.outputs.contains(&out.join(name)), "{name} listed");
    }
    for name in ["fig-7.3.png", "fig-7.4.png", "fig-conditions.png"] {
        let (w, h, rgb) = decode_png(&out.join(name));
        assert!(w >= 800 && h >= 600, "{name} {w}x{h}");
        // Not blank: the bars' colours are there.
        let has = |c: [u8; 3]| rgb.chunks_exact(3).any(|p| p == c);
        assert!(has(experiment::figures::EDGES), "{name} has E bars");
        assert!(has(experiment::figures::NO_EDGES), "{name} has NE bars");
        // Not synthetic: no red banner.
        assert_ne!(&rgb[0..3], &[0xc0, 0x10, 0x10], "{name}");
    }
    for p in ["P01", "P02", "P03"] {
        for trial in [0, 5] {
            let sp = out
                .join("scanpaths")
                .join(format!("{p}-trial-{trial:03}.png"));
            let (w, h, _) = decode_png(&sp);
            assert_eq!((w, h), (320, 256), "{}", sp.display());
        }
    }
    assert_eq!(
        std::fs::read_dir(out.join("scanpaths")).unwrap().count(),
        6,
        "one per stimulus, nothing else"
    );
    // No temporary files left.
    for e in std::fs::read_dir(&out).unwrap() {
        let n = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!n.starts_with('.'), "left {n}");
    }

    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.starts_with("# Visual search analysis: murphy2007-search\n"),
        "{md}"
    );
    assert!(!md.to_lowercase().contains("synthetic"));
    assert!(md.contains(&a.apa()), "report has the F test");
    assert!(md.contains(&format!("Control = {:.2} s", t.control.unwrap().mean)));
    assert!(md.contains("3 participants, 132 trials analysed"));
    assert!(md.contains("gazecast 0.1.0-test"), "software versions");
    for d in &dirs {
        assert!(md.contains(&d.display().to_string()), "input folder listed");
    }
    assert!(md.contains("NE2 vs E5"));
    assert!(md.contains("Greenhouse"));

    // conditions.csv: header first, values as computed.
    let csv = std::fs::read_to_string(out.join("conditions.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "data_source,condition,method,inset_deg,silhouette_edges,n_trials,n_incorrect,n,mean_s,sd_s,se_s"
    );
    let first: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        &first[..8],
        &["human", "control", "full", "n/a", "false", "12", "0", "12"]
    );
    close(
        first[8].parse().unwrap(),
        report.conditions[0].summary.unwrap().mean,
        "csv mean",
    );

    let t71 = std::fs::read_to_string(out.join("table-7.1.csv")).unwrap();
    let lines: Vec<&str> = t71.lines().collect();
    assert_eq!(lines[0], "data_source,edges,2,5,10,15,20,pooled");
    let ne_row: Vec<&str> = lines[1].split(',').collect();
    assert_eq!(&ne_row[..2], &["human", "No Edges"]);
    close(
        ne_row[2].parse().unwrap(),
        t.rows[0].cells[0].unwrap().mean,
        "csv NE2",
    );
    assert!(lines[3].starts_with("human,Control,n/a,"));

    // trials.csv: every trial of every session, in input order, rt exact.
    let all = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    let lines: Vec<&str> = all.lines().collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(
        &header[..4],
        &["data_source", "participant", "sitting", "run"]
    );
    let rt = header.iter().position(|h| *h == "rt_s").unwrap();
    let flat: Vec<&TrialRow> = rows.iter().flatten().collect();
    assert_eq!(lines.len(), 1 + flat.len());
    for (line, want) in lines[1..].iter().zip(&flat) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f[0], "human");
        assert_eq!(f[1], want.participant);
        assert_eq!(f[rt].parse::<f64>().unwrap(), want.rt_s);
    }

    if let Ok(keep) = std::env::var("ANALYSIS_SAMPLE_DIR") {
        keep_sample(Path::new(&keep));
    }
}

/// A full-size sample for a look (not part of the assertions' inputs).
fn keep_sample(root: &Path) {
    let _ = std::fs::remove_dir_all(root);
    let data = root.join("sessions");
    let mut dirs = Vec::new();
    for (i, p) in ["P01", "P02", "P03"].iter().enumerate() {
        let mut g = Gen::new(p, i);
        g.stimulus_size = (1280, 1024);
        g.stimuli = vec![3];
        g.synthetic = i == 0;
        let d = data.join(p);
        make_session(&d, &g);
        dirs.push(d);
    }
    let report = analyze(&dirs, &root.join("analysis"), &AnalyzeOptions::default()).unwrap();
    assert!(report.synthetic);
    let mut g = Gen::new("P09", 0);
    g.stimulus_size = (1280, 1024);
    g.stimuli = vec![3];
    let human = data.join("human-P09");
    make_session(&human, &g);
    let mut g = Gen::new("P10", 1);
    g.stimuli = vec![];
    let human2 = data.join("human-P10");
    make_session(&human2, &g);
    analyze(
        &[human, human2],
        &root.join("analysis-human"),
        &AnalyzeOptions::default(),
    )
    .unwrap();
}

#[test]
fn synthetic_data_are_labelled_everywhere() {
    let tmp = tempfile::tempdir().unwrap();
    let (mut dirs, _) = three_sessions(tmp.path());
    // One more participant, synthetic only in the trial rows.
    let mut g = Gen::new("P04", 3);
    g.synthetic = true;
    let d = tmp.path().join("sess-P04");
    make_session(&d, &g);
    let mut info = SessionInfo::read(&d.join(SESSION_JSON)).unwrap();
    info.synthetic = false;
    info.write(&d.join(SESSION_JSON)).unwrap();
    dirs.push(d);
    let out = tmp.path().join("out");
    let report = analyze(&dirs, &out, &AnalyzeOptions::default()).unwrap();
    assert!(report.synthetic);
    assert!(report.sessions[3].synthetic && !report.sessions[0].synthetic);

    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let first = md.lines().next().unwrap();
    assert!(
        first.contains("SYNTHETIC DATA") && first.contains("not from human"),
        "{first}"
    );
    assert!(md.contains("(SYNTHETIC DATA)"), "in the title too");
    for name in ["conditions.csv", "table-7.1.csv", "trials.csv"] {
        let text = std::fs::read_to_string(out.join(name)).unwrap();
        let mut lines = text.lines();
        assert!(
            lines.next().unwrap().starts_with("# SYNTHETIC DATA"),
            "{name}"
        );
        assert!(lines.next().unwrap().starts_with("data_source,"), "{name}");
        for l in lines {
            assert!(l.starts_with("synthetic,"), "{name}: {l}");
        }
    }
    let banner = [0xc0, 0x10, 0x10];
    for name in ["fig-7.3.png", "fig-7.4.png", "fig-conditions.png"] {
        let (w, _, rgb) = decode_png(&out.join(name));
        // The red banner spans the top rows.
        let row = 5 * w as usize * 3;
        assert_eq!(&rgb[row..row + 3], &banner, "{name}");
        assert_eq!(
            &rgb[row + (w as usize - 1) * 3..row + w as usize * 3],
            &banner,
            "{name}"
        );
    }
    let (w, _, rgb) = decode_png(&out.join("scanpaths").join("P04-trial-000.png"));
    let row = 3 * w as usize * 3;
    assert_eq!(&rgb[row..row + 3], &banner, "synthetic scanpath banner");
    let (_, _, rgb) = decode_png(&out.join("scanpaths").join("P01-trial-000.png"));
    assert_ne!(
        &rgb[row..row + 3],
        &banner,
        "a human session's scanpath has no banner"
    );
}

#[test]
fn incorrect_trials_are_counted_and_optionally_excluded() {
    let tmp = tempfile::tempdir().unwrap();
    let mut dirs = Vec::new();
    let mut rows = Vec::new();
    for (i, p) in ["A", "B"].iter().enumerate() {
        let mut g = Gen::new(p, i);
        g.incorrect_every = 4;
        g.stimuli = vec![];
        let d = tmp.path().join(p);
        rows.extend(make_session(&d, &g));
        dirs.push(d);
    }
    let n_bad = rows.iter().filter(|t| t.correct == Some(false)).count();
    assert!(n_bad > 0);
    let kept = analyze(&dirs, &tmp.path().join("o1"), &AnalyzeOptions::default()).unwrap();
    assert_eq!(kept.n_trials, 88);
    assert_eq!(kept.n_excluded, 0);
    assert_eq!(
        kept.conditions.iter().map(|c| c.n_incorrect).sum::<usize>(),
        n_bad
    );
    let opts = AnalyzeOptions {
        exclude_incorrect: true,
        scanpaths: false,
    };
    let excl = analyze(&dirs, &tmp.path().join("o2"), &opts).unwrap();
    assert_eq!(excl.n_excluded, n_bad);
    assert_eq!(excl.n_trials, 88 - n_bad);
    for c in &excl.conditions {
        let xs: Vec<f64> = rows
            .iter()
            .filter(|t| t.condition == c.name && t.correct != Some(false))
            .map(|t| t.rt_s)
            .collect();
        match c.summary {
            Some(s) => close(s.mean, stats::summarize(&xs).unwrap().mean, &c.name),
            None => assert!(xs.is_empty()),
        }
        assert_eq!(c.n_trials, 8);
    }
    let md = std::fs::read_to_string(tmp.path().join("o2/report.md")).unwrap();
    assert!(md.contains(&format!("{n_bad} incorrect excluded")), "{md}");
}

#[test]
fn one_participant_skips_the_repeated_measures_anova_with_a_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("only");
    make_session(&d, &Gen::new("solo", 0));
    let report = analyze(&[d], &tmp.path().join("out"), &AnalyzeOptions::default()).unwrap();
    match &report.rm_anova {
        Computed::Skipped(why) => assert!(why.contains("at least 2 participants"), "{why}"),
        Computed::Done(_) => panic!("rm ANOVA with one participant"),
    }
    assert!(report.anova.done().is_some(), "the pooled ANOVA still runs");
    let md = std::fs::read_to_string(tmp.path().join("out/report.md")).unwrap();
    assert!(md.contains("Skipped: needs at least 2 participants"));
}

#[test]
fn a_participant_missing_a_condition_is_left_out_of_the_rm_anova() {
    let tmp = tempfile::tempdir().unwrap();
    let (dirs, _) = three_sessions(tmp.path());
    // Drop P03's E20 trials.
    let p = dirs[2].join(TRIALS_TSV);
    let text = std::fs::read_to_string(&p).unwrap();
    let kept: Vec<&str> = text.lines().filter(|l| !l.contains("\tE20\t")).collect();
    std::fs::write(&p, kept.join("\n") + "\n").unwrap();
    let report = analyze(&dirs, &tmp.path().join("out"), &AnalyzeOptions::default()).unwrap();
    let rm = report.rm_anova.done().unwrap();
    assert_eq!(rm.participants, vec!["P01", "P02"]);
    assert_eq!(rm.excluded.len(), 1);
    assert!(rm.excluded[0].contains("P03") && rm.excluded[0].contains("E20"));
}

#[test]
fn a_design_without_the_factors_gets_the_per_condition_table_only() {
    let tmp = tempfile::tempdir().unwrap();
    let ron = std::fs::read_to_string(SEED_DESIGN).unwrap();
    let start = ron.find("Experiment(").unwrap();
    let mut design: Design = Design::from_ron_str(&ron[start..]).unwrap();
    design.name = "two-controls".into();
    design.factors.clear();
    design.conditions.truncate(1);
    let mut b = design.conditions[0].clone();
    b.name = "control-b".into();
    design.conditions.push(b);
    design.breaks.break_after_trials = None;
    let text = ron::ser::to_string_pretty(&design, Default::default()).unwrap();
    let mut dirs = Vec::new();
    for (i, p) in ["X", "Y"].iter().enumerate() {
        let d = tmp.path().join(p);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join(DESIGN_RON), &text).unwrap();
        SessionInfo {
            participant: p.to_string(),
            participant_index: i,
            design_name: "two-controls".into(),
            software: "t".into(),
            display: display(),
            tracker: "none".into(),
            tracker_rate_hz: None,
            started_unix_s: 0.0,
            synthetic: false,
            notes: vec![],
            sittings: Vec::new(),
        }
        .write(&d.join(SESSION_JSON))
        .unwrap();
        let mut log = TsvLog::<TrialRow>::append_to(d.join(TRIALS_TSV)).unwrap();
        for t in experiment::plan(&design, i).unwrap() {
            let c = &design.conditions[t.condition];
            log.write(&TrialRow {
                participant: p.to_string(),
                sitting: 1,
                run: t.run,
                trial: t.index,
                trial_in_run: t.trial_in_run,
                condition: c.name.clone(),
                method: c.method.clone(),
                inset_deg: None,
                silhouette_edges: false,
                target_mesh: 0,
                target_row: 0,
                target_col: 0,
                search_onset_us: 0,
                response_us: 1,
                rt_s: 5.0 + t.index as f64 * 0.25 + t.condition as f64,
                clicked_row: None,
                clicked_col: None,
                correct: None,
                frames: 0,
                frames_late: 0,
                mean_rays: 0.0,
                synthetic: false,
                plan: None,
                reference_row: None,
                reference_col: None,
                mean_triangles: None,
                mean_render_ms: None,
                p95_render_ms: None,
                practice: false,
            })
            .unwrap();
        }
        dirs.push(d);
    }
    let out = tmp.path().join("out");
    let report = analyze(&dirs, &out, &AnalyzeOptions::default()).unwrap();
    assert!(report.table71.is_none());
    assert!(matches!(report.edges, Computed::Skipped(_)));
    assert!(report.seed_pairs.is_empty());
    assert_eq!(report.conditions.len(), 2);
    assert!(report.anova.done().is_some());
    assert!(out.join("conditions.csv").is_file() && out.join("fig-conditions.png").is_file());
    for absent in ["table-7.1.csv", "fig-7.3.png", "fig-7.4.png", "scanpaths"] {
        assert!(!out.join(absent).exists(), "{absent} should not be written");
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("Not applicable"));
}

#[test]
fn a_half_written_trials_line_is_a_warning_in_the_report() {
    let tmp = tempfile::tempdir().unwrap();
    let (dirs, _) = three_sessions(tmp.path());
    let p = dirs[1].join(TRIALS_TSV);
    let mut text = std::fs::read_to_string(&p).unwrap();
    text.push_str("P02\t3\t44\t0\tNE");
    std::fs::write(&p, text).unwrap();
    let report = analyze(&dirs, &tmp.path().join("out"), &AnalyzeOptions::default()).unwrap();
    assert_eq!(report.n_trials, 132);
    assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    assert!(report.warnings[0].contains("trials.tsv") && report.warnings[0].contains("line 46"));
    let md = std::fs::read_to_string(tmp.path().join("out/report.md")).unwrap();
    assert!(md.contains("## Warnings") && md.contains("incomplete last line"));
}

fn err_of(dirs: &[PathBuf], out: &Path) -> AnalysisError {
    match analyze(dirs, out, &AnalyzeOptions::default()) {
        Err(e) => e,
        Ok(_) => panic!("analysis accepted bad input"),
    }
}

#[test]
fn bad_inputs_give_errors_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let fresh = |name: &str, p: &str, i: usize| {
        let d = tmp.path().join(name);
        let mut g = Gen::new(p, i);
        g.stimuli = vec![0];
        make_session(&d, &g);
        d
    };

    // Missing trials.tsv.
    let a = fresh("a", "A", 0);
    std::fs::remove_file(a.join(TRIALS_TSV)).unwrap();
    let msg = err_of(std::slice::from_ref(&a), &out).to_string();
    assert!(
        msg.contains(&a.join(TRIALS_TSV).display().to_string()),
        "{msg}"
    );

    // Corrupt value: file, line, column.
    let b = fresh("b", "B", 1);
    let p = b.join(TRIALS_TSV);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[4].split('\t').map(String::from).collect();
    f[14] = "8,5".into(); // rt_s
    lines[4] = f.join("\t");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let msg = err_of(std::slice::from_ref(&b), &out).to_string();
    assert!(
        msg.contains(&p.display().to_string()) && msg.contains("line 5") && msg.contains("rt_s"),
        "{msg}"
    );

    // A condition the design does not have.
    let c = fresh("c", "C", 2);
    let p = c.join(TRIALS_TSV);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[2].split('\t').map(String::from).collect();
    f[5] = "E99".into(); // condition
    lines[2] = f.join("\t");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let msg = err_of(std::slice::from_ref(&c), &out).to_string();
    assert!(
        msg.contains(&p.display().to_string()) && msg.contains("line 3") && msg.contains("E99"),
        "{msg}"
    );

    // A negative search time.
    let c2 = fresh("c2", "C2", 2);
    let p = c2.join(TRIALS_TSV);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[1].split('\t').map(String::from).collect();
    f[14] = "-1.5".into(); // rt_s
    lines[1] = f.join("\t");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let msg = err_of(std::slice::from_ref(&c2), &out).to_string();
    assert!(
        msg.contains("trials.tsv: line 2") && msg.contains("rt_s"),
        "{msg}"
    );

    // Corrupt design.ron.
    let d = fresh("d", "D", 3);
    std::fs::write(d.join(DESIGN_RON), "Experiment(name: )").unwrap();
    let msg = err_of(std::slice::from_ref(&d), &out).to_string();
    assert!(
        msg.contains(&d.join(DESIGN_RON).display().to_string()),
        "{msg}"
    );

    // Corrupt session.json.
    let e = fresh("e", "E", 4);
    std::fs::write(e.join(SESSION_JSON), "{\n  \"participant\": 5\n}").unwrap();
    let msg = err_of(std::slice::from_ref(&e), &out).to_string();
    assert!(
        msg.contains(&e.join(SESSION_JSON).display().to_string()) && msg.contains("line 2"),
        "{msg}"
    );

    // Missing events.tsv when a stimulus needs it.
    let f2 = fresh("f", "F", 5);
    std::fs::remove_file(f2.join(session::EVENTS_TSV)).unwrap();
    let msg = err_of(std::slice::from_ref(&f2), &out).to_string();
    assert!(
        msg.contains(&f2.join(session::EVENTS_TSV).display().to_string()),
        "{msg}"
    );

    // Two designs.
    let g = fresh("g", "G", 0);
    let h = fresh("h", "H", 1);
    let ron = std::fs::read_to_string(h.join(DESIGN_RON)).unwrap();
    std::fs::write(
        h.join(DESIGN_RON),
        ron.replace("name: \"murphy2007-search\"", "name: \"other\""),
    )
    .unwrap();
    let mut info = SessionInfo::read(&h.join(SESSION_JSON)).unwrap();
    info.design_name = "other".into();
    info.write(&h.join(SESSION_JSON)).unwrap();
    let err = err_of(&[g.clone(), h.clone()], &out);
    assert!(matches!(err, AnalysisError::DesignMismatch { .. }));
    let msg = err.to_string();
    assert!(
        msg.contains(&g.display().to_string()) && msg.contains(&h.display().to_string()),
        "{msg}"
    );

    // session.json naming another design than design.ron.
    let mut info = SessionInfo::read(&g.join(SESSION_JSON)).unwrap();
    info.design_name = "other".into();
    info.write(&g.join(SESSION_JSON)).unwrap();
    let msg = err_of(std::slice::from_ref(&g), &out).to_string();
    assert!(
        msg.contains(&g.join(SESSION_JSON).display().to_string()),
        "{msg}"
    );

    // The same participant twice.
    let i1 = fresh("i1", "Same", 0);
    let i2 = fresh("i2", "Same", 1);
    let err = err_of(&[i1.clone(), i2.clone()], &out);
    assert!(matches!(err, AnalysisError::DuplicateParticipant { .. }));
    let msg = err.to_string();
    assert!(
        msg.contains(&i1.display().to_string()) && msg.contains(&i2.display().to_string()),
        "{msg}"
    );

    // No inputs.
    assert!(matches!(err_of(&[], &out), AnalysisError::NoInputs));
    assert!(!out.exists(), "nothing written on any error above");
}

#[test]
fn output_inside_an_input_is_refused_and_inputs_are_never_written() {
    let tmp = tempfile::tempdir().unwrap();
    let (dirs, _) = three_sessions(tmp.path());
    let before = snapshot(&dirs[0]);
    for out in [
        dirs[0].clone(),
        dirs[0].join("analysis"),
        dirs[1].join("stimuli/x"),
        dirs[0].join("sub/../analysis"),
    ] {
        let err = err_of(&dirs, &out);
        assert!(
            matches!(err, AnalysisError::OutputInsideInput { .. }),
            "{}: {err}",
            out.display()
        );
        assert!(err.to_string().contains(&out.display().to_string()));
    }
    // A relative path spelling of the same folder.
    let cwd = std::env::current_dir().unwrap();
    let rel: PathBuf = pathdiff(&dirs[0], &cwd);
    let err = err_of(&dirs, &rel.join("out"));
    assert!(
        matches!(err, AnalysisError::OutputInsideInput { .. }),
        "{err}"
    );
    assert_eq!(snapshot(&dirs[0]), before, "input untouched");

    // An input folder inside OUT at a path an output would take: refused,
    // the input is not overwritten.
    let out = tmp.path().join("out");
    let trap = out.join("scanpaths");
    let mut g = Gen::new("P09", 0);
    g.stimuli = vec![0];
    make_session(&trap, &g);
    // Make P09's scanpath name collide with a file in the input itself.
    std::fs::write(trap.join("P09-trial-000.png"), b"input file").unwrap();
    let before = snapshot(&trap);
    let err = err_of(std::slice::from_ref(&trap), &out);
    assert!(matches!(err, AnalysisError::Output { .. }), "{err}");
    assert!(err.to_string().contains("inside input folder"), "{err}");
    assert_eq!(snapshot(&trap), before, "input untouched");
}

/// `target` relative to `base` (both absolute), with `..` as needed.
fn pathdiff(target: &Path, base: &Path) -> PathBuf {
    let t: Vec<_> = target.components().collect();
    let b: Vec<_> = base.components().collect();
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut p = PathBuf::new();
    for _ in common..b.len() {
        p.push("..");
    }
    for c in &t[common..] {
        p.push(c);
    }
    p
}

fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn stimulus_pictures_in_any_png_colour_type_are_read_as_rgb() {
    let tmp = tempfile::tempdir().unwrap();
    let write = |name: &str, color: png::ColorType, data: &[u8], palette: Option<&[u8]>| {
        let p = tmp.path().join(name);
        let f = std::fs::File::create(&p).unwrap();
        let mut enc = png::Encoder::new(f, 2, 1);
        enc.set_color(color);
        enc.set_depth(png::BitDepth::Eight);
        if let Some(pal) = palette {
            enc.set_palette(pal.to_vec());
        }
        let mut w = enc.write_header().unwrap();
        w.write_image_data(data).unwrap();
        w.finish().unwrap();
        p
    };
    let want = vec![10, 20, 30, 200, 100, 0];
    let cases = [
        write("rgb.png", png::ColorType::Rgb, &want, None),
        write(
            "rgba.png",
            png::ColorType::Rgba,
            &[10, 20, 30, 255, 200, 100, 0, 255],
            None,
        ),
        write(
            "indexed.png",
            png::ColorType::Indexed,
            &[1, 0],
            Some(&[200, 100, 0, 10, 20, 30]),
        ),
    ];
    for p in &cases {
        let (w, h, rgb) = decode_png(p);
        assert_eq!((w, h), (2, 1));
        assert_eq!(rgb, want, "{}", p.display());
    }
    let (_, _, grey) = decode_png(&write("grey.png", png::ColorType::Grayscale, &[7, 9], None));
    assert_eq!(grey, vec![7, 7, 7, 9, 9, 9]);
    // Half-transparent RGBA is composited over black.
    let (_, _, half) = decode_png(&write(
        "half.png",
        png::ColorType::Rgba,
        &[200, 100, 50, 128, 0, 0, 0, 0],
        None,
    ));
    assert_eq!(half, vec![100, 50, 25, 0, 0, 0]);
}

/// Replaces field `column` (0-based) of line `line` (1-based, header = 1)
/// of `path`'s TSV.
fn set_cell(path: &Path, line: usize, column: usize, value: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[line - 1].split('\t').map(String::from).collect();
    f[column] = value.into();
    lines[line - 1] = f.join("\t");
    std::fs::write(path, lines.join("\n") + "\n").unwrap();
}

/// Search times beyond the stated maximum (an hour) are invalid input
/// naming the file and line, not F = inf, 309-digit means or a panic in
/// the ANOVA (two sessions at 1e308 panicked).
#[test]
fn search_times_beyond_the_maximum_are_invalid_input() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let rt = <TrialRow as TsvRow>::COLUMNS
        .iter()
        .position(|c| *c == "rt_s")
        .unwrap();
    for (k, value) in ["1e155", "1e308", "3600.5", "86400"].iter().enumerate() {
        let a = tmp.path().join(format!("a{k}"));
        let b = tmp.path().join(format!("b{k}"));
        let mut g = Gen::new("A", 0);
        g.stimuli.clear();
        make_session(&a, &g);
        let mut g = Gen::new("B", 1);
        g.stimuli.clear();
        make_session(&b, &g);
        set_cell(&a.join(TRIALS_TSV), 3, rt, value);
        set_cell(&b.join(TRIALS_TSV), 7, rt, value);
        let msg = err_of(&[a.clone(), b], &out).to_string();
        assert!(
            msg.contains(&a.join(TRIALS_TSV).display().to_string())
                && msg.contains("line 3")
                && msg.contains("rt_s")
                && msg.contains("3600")
                && msg.len() < 300,
            "{value}: {msg}"
        );
    }
    // The maximum itself is accepted.
    let a = tmp.path().join("max");
    let mut g = Gen::new("A", 0);
    g.stimuli.clear();
    make_session(&a, &g);
    set_cell(&a.join(TRIALS_TSV), 3, rt, "3600");
    let report = analyze(&[a], &out, &AnalyzeOptions::default()).expect("an hour is allowed");
    assert!(report.conditions.iter().all(|c| c
        .summary
        .is_none_or(|s| s.mean.is_finite() && s.mean < 3600.0)));
}

/// Sessions of one design name whose stimuli differ (`meshes: 4` and
/// `64`, another grid, another object size, another condition) are
/// refused, naming the field and both values.
#[test]
fn sessions_with_different_stimuli_are_not_pooled() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let cases = [
        ("meshes: 4", "meshes: 64", "stimulus.meshes: 4 → 64"),
        ("grid: (5, 5)", "grid: (5, 7)", "stimulus.grid[1]: 5 → 7"),
        (
            "object_deg: 3.5",
            "object_deg: 2.5",
            "stimulus.object_deg: 3.5 → 2.5",
        ),
        ("seed: 2007", "seed: 2008", "stimulus.seed: 2007 → 2008"),
        ("contrast: 0.25", "contrast: 0.5", "contrast: 0.25 → 0.5"),
        (
            "inset_deg: Some(20.0), silhouette_edges: true",
            "inset_deg: Some(25.0), silhouette_edges: true",
            "conditions[10].inset_deg: 20.0 → 25.0",
        ),
    ];
    for (k, (from, to, named)) in cases.iter().enumerate() {
        let a = tmp.path().join(format!("a{k}"));
        let b = tmp.path().join(format!("b{k}"));
        let mut g = Gen::new("A", 0);
        g.stimuli.clear();
        make_session(&a, &g);
        let mut g = Gen::new("B", 1);
        g.stimuli.clear();
        make_session(&b, &g);
        let ron = std::fs::read_to_string(b.join(DESIGN_RON)).unwrap();
        assert!(ron.contains(from), "{from}");
        std::fs::write(b.join(DESIGN_RON), ron.replacen(from, to, 1)).unwrap();
        if from.starts_with("inset_deg") {
            // The rows must agree with their own design (or that is the
            // error): rewrite E20's rows.
            let p = b.join(TRIALS_TSV);
            let cols = <TrialRow as TsvRow>::COLUMNS;
            let at = |name: &str| cols.iter().position(|c| *c == name).unwrap();
            let text: Vec<String> = std::fs::read_to_string(&p)
                .unwrap()
                .lines()
                .map(|l| {
                    let mut f: Vec<&str> = l.split('\t').collect();
                    if f.get(at("condition")) == Some(&"E20") {
                        f[at("inset_deg")] = "25";
                    }
                    f.join("\t")
                })
                .collect();
            std::fs::write(&p, text.join("\n") + "\n").unwrap();
        }
        let msg = err_of(&[a.clone(), b.clone()], &out).to_string();
        assert!(
            msg.contains(&b.join(DESIGN_RON).display().to_string())
                && msg.contains(named)
                && msg.contains("not pooled"),
            "{from} → {to}: {msg}"
        );
    }
    // The free-text description may differ.
    let a = tmp.path().join("d1");
    let b = tmp.path().join("d2");
    make_session(&a, &Gen::new("A", 0));
    make_session(&b, &Gen::new("B", 1));
    let ron = std::fs::read_to_string(b.join(DESIGN_RON)).unwrap();
    let ron = ron.replacen("description: \"", "description: \"Re-run. ", 1);
    std::fs::write(b.join(DESIGN_RON), ron).unwrap();
    analyze(&[a, b], &out, &AnalyzeOptions::default()).expect("only the description differs");
}

/// Analysing into a folder an earlier analyze wrote: the outputs it does
/// not write this time (another participant's scanpaths) are removed, so
/// the folder holds what the report lists; a user's own files stay.
#[test]
fn a_second_analyze_leaves_no_stale_outputs_and_keeps_other_files() {
    let tmp = tempfile::tempdir().unwrap();
    let (dirs, _) = three_sessions(tmp.path());
    let out = tmp.path().join("out");
    analyze(&dirs, &out, &AnalyzeOptions::default()).unwrap();
    let sp = out.join("scanpaths");
    assert!(sp.join("P03-trial-000.png").is_file());
    // The user's own files, some almost named like analyze's.
    let mine = [
        out.join("notes.md"),
        out.join("report.md.bak"),
        sp.join("my-sketch.png"),
        sp.join("P03-trial-x.png"),
    ];
    for f in &mine {
        std::fs::write(f, "mine").unwrap();
    }
    let report = analyze(&dirs[..2], &out, &AnalyzeOptions::default()).unwrap();
    let listed: std::collections::BTreeSet<PathBuf> = report.outputs.iter().cloned().collect();
    for e in std::fs::read_dir(&sp).unwrap() {
        let p = e.unwrap().path();
        assert!(
            listed.contains(&p) || mine.contains(&p),
            "{} is neither this run's output nor the user's",
            p.display()
        );
    }
    assert!(!sp.join("P03-trial-000.png").exists());
    assert!(sp.join("P01-trial-000.png").is_file());
    for f in &mine {
        assert_eq!(
            std::fs::read_to_string(f).unwrap(),
            "mine",
            "{}",
            f.display()
        );
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("P03-trial-000.png") && md.contains("earlier analyze"),
        "{md}"
    );
    // Without stimulus pictures at all, the whole scanpaths set goes.
    let opts = AnalyzeOptions {
        scanpaths: false,
        ..Default::default()
    };
    analyze(&dirs[..2], &out, &opts).unwrap();
    assert!(!sp.join("P01-trial-000.png").exists());
    assert!(sp.join("my-sketch.png").is_file());
}

/// Practice trials (`practice` true in trials.tsv) are read, counted and
/// left out: every statistic equals the analysis of the same sessions
/// without them, however slow the practice searches were.
#[test]
fn practice_trials_are_counted_and_never_analysed() {
    let tmp = tempfile::tempdir().unwrap();
    let (dirs, rows) = three_sessions(tmp.path());
    let before = analyze(&dirs, &tmp.path().join("o1"), &AnalyzeOptions::default()).unwrap();
    for (d, r) in dirs.iter().zip(&rows) {
        let mut log = TsvLog::<TrialRow>::append_to(d.join(TRIALS_TSV)).unwrap();
        for k in 0..3 {
            log.write(&TrialRow {
                trial: 1000 + k,
                rt_s: 250.0 + k as f64,
                practice: true,
                ..r[0].clone()
            })
            .unwrap();
        }
    }
    let after = analyze(&dirs, &tmp.path().join("o2"), &AnalyzeOptions::default()).unwrap();
    assert_eq!(after.n_practice, 9);
    assert_eq!(before.n_practice, 0);
    assert_eq!(after.n_trials, before.n_trials);
    assert_eq!(after.n_trials_read, before.n_trials_read);
    assert_eq!(
        serde_json::to_value(&after.conditions).unwrap(),
        serde_json::to_value(&before.conditions).unwrap()
    );
    assert_eq!(
        serde_json::to_value(&after.rm_anova).unwrap(),
        serde_json::to_value(&before.rm_anova).unwrap()
    );
    let md = std::fs::read_to_string(tmp.path().join("o2/report.md")).unwrap();
    assert!(md.contains("9 practice trials left out"), "{md}");
}
