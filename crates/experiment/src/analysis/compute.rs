//! The analyses computed on the loaded sessions' trials: the
//! [`Report`] without its outputs.

use std::collections::{BTreeMap, BTreeSet};

use super::format::fmt_deg;
use super::load::Loaded;
use super::report::{
    Computed, ConditionStats, EdgesAnalysis, GroupStats, OneWay, PairResult, Report, RmResult,
    SeedPair, SessionSummary, Table71, Table71Row,
};
use super::{AnalyzeOptions, SEED_PAIRS};
use crate::design::Condition;
use crate::session::TrialRow;
use crate::stats;
use crate::stats::Summary;

pub(crate) fn describe(method: &str, inset: Option<f64>, edges: bool) -> String {
    match inset {
        Some(d) => format!(
            "{method}, {}° inset, {}",
            fmt_deg(d),
            if edges { "edges kept" } else { "no edges" }
        ),
        None => format!("{method}{}", if edges { ", edges kept" } else { "" }),
    }
}

pub(crate) fn is_control(c: &Condition) -> bool {
    c.method == "full"
}

pub(crate) fn used(t: &TrialRow, opts: &AnalyzeOptions) -> bool {
    !(opts.exclude_incorrect && t.correct == Some(false))
}

/// The analysed search times: `rts[c]` pooled over participants,
/// `per[s][c]` per session, with the counts of trials read, incorrect and
/// left out.
struct SearchTimes {
    rts: Vec<Vec<f64>>,
    per: Vec<Vec<Vec<f64>>>,
    n_trials: Vec<usize>,
    n_incorrect: Vec<usize>,
    n_read: usize,
    n_excluded: usize,
}

/// Computes the analyses of `sessions` (one design): the [`Report`]
/// without its outputs; `warnings` so far go first in its warnings.
pub(crate) fn compute(
    sessions: &[Loaded],
    opts: &AnalyzeOptions,
    mut warnings: Vec<String>,
) -> Report {
    let design = &sessions[0].design;
    let conds = &design.conditions;
    let index: BTreeMap<&str, usize> = conds
        .iter()
        .enumerate()
        .map(|(i, c)| (c.name.as_str(), i))
        .collect();
    let times = search_times(sessions, conds.len(), &index, opts);
    let conditions = condition_stats(conds, &times);
    let (anova, pairwise) = across_conditions(conds, &times.rts, &mut warnings);
    let significant = pairwise
        .done()
        .map(|ps| {
            ps.iter()
                .filter(|p| p.pair.p_holm < 0.05)
                .cloned()
                .collect()
        })
        .unwrap_or_default();
    let seed_pairs = SEED_PAIRS
        .iter()
        .filter(|(a, b, _)| index.contains_key(a) && index.contains_key(b))
        .map(|&(a, b, seed)| SeedPair {
            a: a.into(),
            b: b.into(),
            seed: seed.into(),
            result: pairwise.done().and_then(|ps| find_pair(ps, a, b)),
        })
        .collect();
    let edge_groups = edge_groups(conds, &times.rts);
    let edges = edges_analysis(&edge_groups);
    let rm_anova = repeated_measures(sessions, conds, &times.per, &mut warnings);
    let table71 = table_7_1(conds, &times.rts, &edge_groups[2].1 .1);
    Report {
        synthetic: sessions.iter().any(|s| s.synthetic),
        design_name: design.name.clone(),
        sessions: sessions
            .iter()
            .map(|s| SessionSummary {
                dir: s.dir.clone(),
                participant: s.info.participant.clone(),
                participant_index: s.info.participant_index,
                software: s.info.software.clone(),
                tracker: s.info.tracker.clone(),
                synthetic: s.synthetic,
                trials: s.trials.len(),
            })
            .collect(),
        n_trials_read: times.n_read,
        n_practice: sessions.iter().map(|s| s.practice).sum(),
        n_trials: times.n_read - times.n_excluded,
        n_excluded: times.n_excluded,
        exclude_incorrect: opts.exclude_incorrect,
        conditions,
        anova,
        edges,
        rm_anova,
        pairwise,
        significant,
        seed_pairs,
        table71,
        warnings,
        outputs: Vec::new(),
    }
}

/// Every session's trials by condition (`index`: condition name → its
/// index of `k`): the search times of the trials analysed
/// ([`used`]), and the counts.
fn search_times(
    sessions: &[Loaded],
    k: usize,
    index: &BTreeMap<&str, usize>,
    opts: &AnalyzeOptions,
) -> SearchTimes {
    let mut t = SearchTimes {
        rts: vec![Vec::new(); k],
        per: vec![vec![Vec::new(); k]; sessions.len()],
        n_trials: vec![0usize; k],
        n_incorrect: vec![0usize; k],
        n_read: 0,
        n_excluded: 0,
    };
    for (s, sess) in sessions.iter().enumerate() {
        for trial in &sess.trials {
            let c = index[trial.condition.as_str()];
            t.n_read += 1;
            t.n_trials[c] += 1;
            if trial.correct == Some(false) {
                t.n_incorrect[c] += 1;
            }
            if used(trial, opts) {
                t.rts[c].push(trial.rt_s);
                t.per[s][c].push(trial.rt_s);
            } else {
                t.n_excluded += 1;
            }
        }
    }
    t
}

/// Mean ± SE of the search times, where there are any.
fn summary(xs: &[f64]) -> Option<Summary> {
    stats::summarize(xs).ok()
}

/// Each condition's counts and pooled summary.
fn condition_stats(conds: &[Condition], times: &SearchTimes) -> Vec<ConditionStats> {
    conds
        .iter()
        .enumerate()
        .map(|(i, c)| ConditionStats {
            name: c.name.clone(),
            method: c.method.clone(),
            inset_deg: c.inset_deg,
            silhouette_edges: c.silhouette_edges,
            n_trials: times.n_trials[i],
            n_incorrect: times.n_incorrect[i],
            summary: summary(&times.rts[i]),
        })
        .collect()
}

/// One-way ANOVA and pairwise tests across the conditions with trials
/// (a condition without is left out, with a warning).
fn across_conditions(
    conds: &[Condition],
    rts: &[Vec<f64>],
    warnings: &mut Vec<String>,
) -> (Computed<OneWay>, Computed<Vec<PairResult>>) {
    let k = conds.len();
    let present: Vec<usize> = (0..k).filter(|&i| !rts[i].is_empty()).collect();
    for i in (0..k).filter(|i| rts[*i].is_empty()) {
        warnings.push(format!(
            "condition {} has no analysed trials: left out of the tests",
            conds[i].name
        ));
    }
    let groups: Vec<&[f64]> = present.iter().map(|&i| rts[i].as_slice()).collect();
    let names: Vec<String> = present.iter().map(|&i| conds[i].name.clone()).collect();
    let anova = match stats::one_way_anova(&groups) {
        Ok(a) => Computed::Done(OneWay {
            groups: names.clone(),
            anova: a,
        }),
        Err(e) => Computed::Skipped(format!("one-way ANOVA across conditions: {e}")),
    };
    let pairwise = match stats::pairwise_t_pooled(&groups) {
        Ok(ps) => Computed::Done(
            ps.into_iter()
                .map(|p| PairResult {
                    a: names[p.a].clone(),
                    b: names[p.b].clone(),
                    pair: p,
                })
                .collect::<Vec<_>>(),
        ),
        Err(e) => Computed::Skipped(format!("pairwise t-tests: {e}")),
    };
    (anova, pairwise)
}

/// A group of conditions pooled: (label, (condition names, search times)).
type EdgeGroup = (&'static str, (Vec<String>, Vec<f64>));

/// The search times pooled into edges kept (`E`), edges discarded (`NE`)
/// and the control, in that order.
fn edge_groups(conds: &[Condition], rts: &[Vec<f64>]) -> [EdgeGroup; 3] {
    let pool = |pick: &dyn Fn(&Condition) -> bool| -> (Vec<String>, Vec<f64>) {
        let mut names = Vec::new();
        let mut xs = Vec::new();
        for (i, c) in conds.iter().enumerate() {
            if pick(c) {
                names.push(c.name.clone());
                xs.extend_from_slice(&rts[i]);
            }
        }
        (names, xs)
    };
    [
        ("E", pool(&|c| !is_control(c) && c.silhouette_edges)),
        ("NE", pool(&|c| !is_control(c) && !c.silhouette_edges)),
        ("Control", pool(&is_control)),
    ]
}

/// The "significance of edges" one-way ANOVA over the groups with trials,
/// with pooled-SD pairwise t-tests; skipped unless both `E` and `NE` have
/// trials.
fn edges_analysis(edge_groups: &[EdgeGroup; 3]) -> Computed<EdgesAnalysis> {
    let present: Vec<_> = edge_groups
        .iter()
        .filter(|(_, (_, xs))| !xs.is_empty())
        .collect();
    let has_e = present.iter().any(|(l, _)| *l == "E");
    let has_ne = present.iter().any(|(l, _)| *l == "NE");
    if !(has_e && has_ne) {
        return Computed::Skipped(
            "the design has no hybrid conditions with both edges kept and edges discarded (with trials)"
                .into(),
        );
    }
    let gs: Vec<&[f64]> = present.iter().map(|(_, (_, xs))| xs.as_slice()).collect();
    let labels: Vec<String> = present.iter().map(|(l, _)| l.to_string()).collect();
    let summaries: Result<Vec<GroupStats>, stats::StatsError> = present
        .iter()
        .map(|(l, (names, xs))| {
            Ok(GroupStats {
                label: l.to_string(),
                conditions: names.clone(),
                summary: stats::summarize(xs)?,
            })
        })
        .collect();
    match (
        summaries,
        stats::one_way_anova(&gs),
        stats::pairwise_t_pooled(&gs),
    ) {
        (Ok(groups), Ok(a), Ok(ps)) => Computed::Done(EdgesAnalysis {
            groups,
            anova: OneWay {
                groups: labels.clone(),
                anova: a,
            },
            pairs: ps
                .into_iter()
                .map(|p| PairResult {
                    a: labels[p.a].clone(),
                    b: labels[p.b].clone(),
                    pair: p,
                })
                .collect(),
        }),
        (Err(e), _, _) | (_, Err(e), _) | (_, _, Err(e)) => {
            Computed::Skipped(format!("edges ANOVA: {e}"))
        }
    }
}

/// The repeated-measures ANOVA on per-participant condition means
/// (`per[s][c]`): participants without trials in every condition are
/// left out (a warning each when it runs).
fn repeated_measures(
    sessions: &[Loaded],
    conds: &[Condition],
    per: &[Vec<Vec<f64>>],
    warnings: &mut Vec<String>,
) -> Computed<RmResult> {
    let k = conds.len();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut included = Vec::new();
    let mut excluded = Vec::new();
    for (s, sess) in sessions.iter().enumerate() {
        let missing: Vec<&str> = (0..k)
            .filter(|&c| per[s][c].is_empty())
            .map(|c| conds[c].name.as_str())
            .collect();
        if missing.is_empty() {
            rows.push(
                per[s]
                    .iter()
                    .map(|xs| xs.iter().sum::<f64>() / xs.len() as f64)
                    .collect(),
            );
            included.push(sess.info.participant.clone());
        } else {
            excluded.push(format!(
                "{} (no analysed trials in {})",
                sess.info.participant,
                missing.join(", ")
            ));
        }
    }
    if rows.len() < 2 {
        return Computed::Skipped(format!(
            "needs at least 2 participants with trials in every condition; {} {}{}",
            rows.len(),
            if rows.len() == 1 { "has" } else { "have" },
            if excluded.is_empty() {
                String::new()
            } else {
                format!(" (left out: {})", excluded.join("; "))
            }
        ));
    }
    let data: Vec<&[f64]> = rows.iter().map(|r| r.as_slice()).collect();
    match stats::rm_anova(&data) {
        Ok(rm) => {
            for e in &excluded {
                warnings.push(format!("repeated-measures ANOVA leaves out {e}"));
            }
            Computed::Done(RmResult {
                participants: included,
                excluded,
                rm,
            })
        }
        Err(e) => Computed::Skipped(format!("repeated-measures ANOVA: {e}")),
    }
}

/// Table 7.1 of the hybrid conditions (none without any), with the
/// `control` search times' summary in its caption.
fn table_7_1(conds: &[Condition], rts: &[Vec<f64>], control: &[f64]) -> Option<Table71> {
    let hybrid: Vec<(usize, &Condition)> = conds
        .iter()
        .enumerate()
        .filter(|(_, c)| !is_control(c) && c.inset_deg.is_some())
        .collect();
    if hybrid.is_empty() {
        return None;
    }
    let edge_values: BTreeSet<bool> = hybrid.iter().map(|(_, c)| c.silhouette_edges).collect();
    let mut insets: Vec<f64> = Vec::new();
    for d in hybrid.iter().filter_map(|(_, c)| c.inset_deg) {
        if !insets.contains(&d) {
            insets.push(d);
        }
    }
    insets.sort_by(f64::total_cmp);
    let rows = edge_values
        .iter()
        .map(|&e| {
            let cells = insets
                .iter()
                .map(|&d| {
                    let xs: Vec<f64> = hybrid
                        .iter()
                        .filter(|(_, c)| c.silhouette_edges == e && c.inset_deg == Some(d))
                        .flat_map(|(i, _)| rts[*i].iter().copied())
                        .collect();
                    summary(&xs)
                })
                .collect();
            let all: Vec<f64> = hybrid
                .iter()
                .filter(|(_, c)| c.silhouette_edges == e)
                .flat_map(|(i, _)| rts[*i].iter().copied())
                .collect();
            Table71Row {
                label: if e { "Edges" } else { "No Edges" }.into(),
                silhouette_edges: e,
                cells,
                pooled: summary(&all),
            }
        })
        .collect();
    Some(Table71 {
        insets,
        rows,
        control: summary(control),
    })
}

pub(crate) fn find_pair(ps: &[PairResult], a: &str, b: &str) -> Option<PairResult> {
    ps.iter().find_map(|p| {
        if p.a == a && p.b == b {
            Some(p.clone())
        } else if p.a == b && p.b == a {
            // Report it in the asked-for direction.
            let mut q = p.clone();
            q.a = a.into();
            q.b = b.into();
            q.pair.diff = -q.pair.diff;
            q.pair.t = -q.pair.t;
            Some(q)
        } else {
            None
        }
    })
}
