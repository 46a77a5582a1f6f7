//! Writing the report's files: the CSV tables, the figures and the
//! scanpath pictures, then `report.md`.

use super::compute::describe;
use super::format::{data_source, fmt_deg, SYNTHETIC_CSV};
use super::load::Loaded;
use super::markdown::markdown;
use super::output::{remove_stale, OutputWriter};
use super::report::{Computed, Report};
use super::{
    AnalysisError, AnalyzeOptions, CONDITIONS_CSV, FIG_7_3, FIG_7_4, FIG_CONDITIONS, REPORT_MD,
    SCANPATHS_DIR, STATS_JSON, TABLE_7_1_CSV, TRIALS_CSV,
};
use crate::figures::{Bar, BarChart, BarGroup, Fixation, Reference, Scanpath};
use crate::session::{EventRow, TrialRow};
use crate::stats::Summary;
use crate::{figures, session};

pub(crate) fn write_outputs(
    w: &OutputWriter,
    sessions: &[Loaded],
    opts: &AnalyzeOptions,
    report: &mut Report,
) -> Result<(), AnalysisError> {
    let mut outputs = Vec::new();
    // conditions.csv
    {
        let path = w.path(CONDITIONS_CSV);
        let mut text = String::new();
        if report.synthetic {
            text.push_str(SYNTHETIC_CSV);
            text.push('\n');
        }
        let mut csv = csv::Writer::from_writer(Vec::new());
        let io = |e: csv::Error| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        };
        csv.write_record([
            "data_source",
            "condition",
            "method",
            "inset_deg",
            "silhouette_edges",
            "n_trials",
            "n_incorrect",
            "n",
            "mean_s",
            "sd_s",
            "se_s",
        ])
        .map_err(io)?;
        for c in &report.conditions {
            let (n, mean, sd, se) = match &c.summary {
                Some(s) => (
                    s.n.to_string(),
                    s.mean.to_string(),
                    s.sd.to_string(),
                    s.se.to_string(),
                ),
                None => ("0".into(), "n/a".into(), "n/a".into(), "n/a".into()),
            };
            csv.write_record([
                data_source(report).to_string(),
                c.name.clone(),
                c.method.clone(),
                c.inset_deg.map_or("n/a".into(), fmt_deg),
                c.silhouette_edges.to_string(),
                c.n_trials.to_string(),
                c.n_incorrect.to_string(),
                n,
                mean,
                sd,
                se,
            ])
            .map_err(io)?;
        }
        let bytes = csv.into_inner().map_err(|e| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        text.push_str(&String::from_utf8_lossy(&bytes));
        w.bytes(&path, text.as_bytes())?;
        outputs.push(path);
    }
    // trials.csv: every trial read, in input order.
    {
        let path = w.path(TRIALS_CSV);
        let io = |e: csv::Error| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        };
        let mut text = String::new();
        if report.synthetic {
            text.push_str(SYNTHETIC_CSV);
            text.push('\n');
        }
        text.push_str("data_source,");
        text.push_str(&<TrialRow as crate::session::TsvRow>::COLUMNS.join(","));
        text.push('\n');
        let mut csv = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(Vec::new());
        for l in sessions {
            for t in &l.trials {
                csv.serialize(t).map_err(io)?;
            }
        }
        let bytes = csv.into_inner().map_err(|e| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        for line in String::from_utf8_lossy(&bytes).lines() {
            text.push_str(data_source(report));
            text.push(',');
            text.push_str(line);
            text.push('\n');
        }
        w.bytes(&path, text.as_bytes())?;
        outputs.push(path);
    }
    // table-7.1.csv
    if let Some(t) = &report.table71 {
        let path = w.path(TABLE_7_1_CSV);
        let mut text = String::new();
        if report.synthetic {
            text.push_str(SYNTHETIC_CSV);
            text.push('\n');
        }
        let mut csv = csv::Writer::from_writer(Vec::new());
        let io = |e: csv::Error| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        };
        let mut header = vec!["data_source".to_string(), "edges".to_string()];
        header.extend(t.insets.iter().map(|&d| fmt_deg(d)));
        header.push("pooled".into());
        csv.write_record(&header).map_err(io)?;
        let mean = |s: &Option<Summary>| s.map_or("n/a".into(), |s| s.mean.to_string());
        for r in &t.rows {
            let mut rec = vec![data_source(report).to_string(), r.label.clone()];
            rec.extend(r.cells.iter().map(mean));
            rec.push(mean(&r.pooled));
            csv.write_record(&rec).map_err(io)?;
        }
        if t.control.is_some() {
            let mut rec = vec![data_source(report).to_string(), "Control".to_string()];
            rec.extend(t.insets.iter().map(|_| "n/a".to_string()));
            rec.push(mean(&t.control));
            csv.write_record(&rec).map_err(io)?;
        }
        let bytes = csv.into_inner().map_err(|e| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        text.push_str(&String::from_utf8_lossy(&bytes));
        w.bytes(&path, text.as_bytes())?;
        outputs.push(path);
    }
    // Figures.
    let n_part = report.sessions.len();
    let synthetic_tag = if report.synthetic {
        " (SYNTHETIC DATA)"
    } else {
        ""
    };
    let subtitle_base = format!(
        "{} participant{}, {} trials; error bars ±1 SE{}",
        n_part,
        if n_part == 1 { "" } else { "s" },
        report.n_trials,
        if report.synthetic {
            "; simulated participants"
        } else {
            ""
        }
    );
    let mut figure =
        |name: &str, chart: &BarChart, size: (u32, u32)| -> Result<(), AnalysisError> {
            let path = w.path(name);
            w.guard(&path)?;
            figures::bar_chart(&path, chart, size).map_err(|e| AnalysisError::Output {
                path: path.clone(),
                message: e.to_string(),
            })?;
            outputs.push(path);
            Ok(())
        };
    {
        let groups = report
            .conditions
            .iter()
            .filter_map(|c| {
                c.summary.map(|s| BarGroup {
                    label: c.name.clone(),
                    bars: vec![Bar {
                        series: c.name.clone(),
                        mean: s.mean,
                        se: s.se,
                        n: s.n,
                        color: if c.method == "full" {
                            figures::CONTROL
                        } else if c.silhouette_edges {
                            figures::EDGES
                        } else {
                            figures::NO_EDGES
                        },
                    }],
                })
            })
            .collect();
        let chart = BarChart {
            title: format!("Mean search time per condition{synthetic_tag}"),
            subtitle: format!("{}: {subtitle_base}", report.design_name),
            x_label: "Condition".into(),
            y_label: "Mean search time (s)".into(),
            groups,
            reference: None,
            legend: false,
            synthetic: report.synthetic,
        };
        figure(FIG_CONDITIONS, &chart, (1100, 700))?;
    }
    if let Computed::Done(e) = &report.edges {
        let groups = e
            .groups
            .iter()
            .map(|g| {
                let (label, color) = match g.label.as_str() {
                    "E" => ("E (edges kept)", figures::EDGES),
                    "NE" => ("NE (no edges)", figures::NO_EDGES),
                    _ => ("Control (full)", figures::CONTROL),
                };
                BarGroup {
                    label: label.into(),
                    bars: vec![Bar {
                        series: g.label.clone(),
                        mean: g.summary.mean,
                        se: g.summary.se,
                        n: g.summary.n,
                        color,
                    }],
                }
            })
            .collect();
        let chart = BarChart {
            title: format!("Fig. 7.3: Mean search time, pooled{synthetic_tag}"),
            subtitle: format!("{}; {}", subtitle_base, e.anova.apa()),
            x_label: "Scene type (E = silhouette edges kept, NE = no edges)".into(),
            y_label: "Mean search time (s)".into(),
            groups,
            reference: None,
            legend: false,
            synthetic: report.synthetic,
        };
        figure(FIG_7_3, &chart, (900, 700))?;
    }
    if let Some(t) = &report.table71 {
        let groups = t
            .insets
            .iter()
            .enumerate()
            .map(|(j, &d)| BarGroup {
                label: format!("{}°", fmt_deg(d)),
                // E before NE, as the seed's figure.
                bars: t
                    .rows
                    .iter()
                    .rev()
                    .filter_map(|r| {
                        r.cells[j].map(|s| Bar {
                            series: if r.silhouette_edges {
                                "E (edges kept)".into()
                            } else {
                                "NE (no edges)".into()
                            },
                            mean: s.mean,
                            se: s.se,
                            n: s.n,
                            color: if r.silhouette_edges {
                                figures::EDGES
                            } else {
                                figures::NO_EDGES
                            },
                        })
                    })
                    .collect(),
            })
            .collect();
        let chart = BarChart {
            title: format!("Fig. 7.4: Mean search time per window size{synthetic_tag}"),
            subtitle: subtitle_base.clone(),
            x_label: "High-resolution inset diameter (deg of visual angle)".into(),
            y_label: "Mean search time (s)".into(),
            groups,
            reference: t.control.map(|c| Reference {
                label: format!("Control (full res.) {:.2} s ± SE", c.mean),
                mean: c.mean,
                se: c.se,
            }),
            legend: true,
            synthetic: report.synthetic,
        };
        figure(FIG_7_4, &chart, (1100, 700))?;
    }
    // Scanpaths.
    if opts.scanpaths {
        let dir = w.path(SCANPATHS_DIR);
        for s in sessions {
            let with_stimulus: Vec<&TrialRow> = s
                .trials
                .iter()
                .filter(|t| session::stimulus_path(&s.dir, t.trial).is_file())
                .collect();
            if with_stimulus.is_empty() {
                continue;
            }
            w.guard(&dir)?;
            std::fs::create_dir_all(&dir).map_err(|e| AnalysisError::Output {
                path: dir.clone(),
                message: e.to_string(),
            })?;
            for t in with_stimulus {
                let fixations = trial_fixations(&s.events, t);
                let cond = report.conditions.iter().find(|c| c.name == t.condition);
                let what = cond
                    .map(|c| describe(&c.method, c.inset_deg, c.silhouette_edges))
                    .unwrap_or_default();
                let sp = Scanpath {
                    fixations,
                    display_px: (s.info.display.width_px, s.info.display.height_px),
                    caption: vec![
                        format!(
                            "participant {}{} | trial {} (run {}, #{} in run) | condition {} ({})",
                            s.info.participant,
                            if s.synthetic { " (SYNTHETIC)" } else { "" },
                            t.trial,
                            t.run,
                            t.trial_in_run,
                            t.condition,
                            what
                        ),
                        format!(
                            "search time {:.2} s | {} fixations from search onset to response | circle size grows with duration",
                            t.rt_s,
                            trial_fixations(&s.events, t).len()
                        ),
                    ],
                    synthetic: s.synthetic,
                };
                let path = dir.join(format!(
                    "{}-trial-{:03}.png",
                    file_safe(&s.info.participant),
                    t.trial
                ));
                w.guard(&path)?;
                let stimulus = session::stimulus_path(&s.dir, t.trial);
                match figures::scanpath(&path, &stimulus, &sp) {
                    Ok(()) => outputs.push(path),
                    Err(e) => report
                        .warnings
                        .push(format!("{}: scanpath not drawn: {e}", stimulus.display())),
                }
            }
        }
    }
    let report_path = w.path(REPORT_MD);
    outputs.push(report_path.clone());
    let stats_path = w.path(STATS_JSON);
    outputs.push(stats_path.clone());
    remove_stale(w, &outputs, &mut report.warnings)?;
    report.outputs = outputs;
    let md = markdown(report);
    w.bytes(&report_path, md.as_bytes())?;
    // Full precision; non-finite values (none expected) become null.
    let json = serde_json::to_string_pretty(report).map_err(|e| AnalysisError::Output {
        path: stats_path.clone(),
        message: e.to_string(),
    })?;
    w.bytes(&stats_path, json.as_bytes())?;
    Ok(())
}

/// The trial's fixations between search onset and response (the sitting's
/// host clock), clipped to that window, in order. Only events of the
/// sitting that completed the trial count (an aborted run of it left none
/// on the same clock).
pub fn trial_fixations(events: &[EventRow], t: &TrialRow) -> Vec<Fixation> {
    let (t0, t1) = (t.search_onset_us, t.response_us);
    let mut fx: Vec<&EventRow> = events
        .iter()
        .filter(|e| e.kind == "fixation" && e.sitting == t.sitting)
        .filter(|e| e.trial.is_none_or(|i| i == t.trial))
        .filter(|e| e.onset_us < t1 && e.end_us > t0)
        .collect();
    fx.sort_by_key(|e| e.onset_us);
    fx.into_iter()
        .map(|e| Fixation {
            x: e.x_px,
            y: e.y_px,
            duration_ms: (e.end_us.min(t1) - e.onset_us.max(t0)) as f64 / 1000.0,
        })
        .collect()
}

pub(crate) fn file_safe(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if t.is_empty() {
        "participant".into()
    } else {
        t
    }
}
