//! Reading one session folder for the analysis: its `session.json`,
//! design, trials and (for scanpaths) events, checked to belong together.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::compute::describe;
use super::{AnalysisError, AnalyzeOptions};
use crate::design::{Design, MAX_SEARCH_S};
use crate::session;
use crate::session::{
    read_tsv, EventRow, SessionInfo, TrialRow, DESIGN_RON, EVENTS_TSV, SESSION_JSON, TRIALS_TSV,
};

pub(crate) struct Loaded {
    pub(crate) dir: PathBuf,
    pub(crate) info: SessionInfo,
    pub(crate) design: Design,
    /// The experimental trials (practice rows left out).
    pub(crate) trials: Vec<TrialRow>,
    /// Practice rows read and left out (never analysed).
    pub(crate) practice: usize,
    /// `events.tsv`, read when a trial has a stimulus picture (scanpaths).
    pub(crate) events: Vec<EventRow>,
    pub(crate) synthetic: bool,
}

pub(crate) fn load_session(
    dir: &Path,
    opts: &AnalyzeOptions,
    warnings: &mut Vec<String>,
) -> Result<Loaded, AnalysisError> {
    let info_path = dir.join(SESSION_JSON);
    let info = SessionInfo::read(&info_path)?;
    let design_path = dir.join(DESIGN_RON);
    let design = Design::load(&design_path).map_err(|source| AnalysisError::Design {
        path: design_path.clone(),
        source,
    })?;
    if info.design_name != design.name {
        return Err(AnalysisError::Invalid {
            path: info_path,
            line: None,
            message: format!(
                "design_name {:?} is not the name of the design in {} ({:?})",
                info.design_name,
                design_path.display(),
                design.name
            ),
        });
    }
    let trials_path = dir.join(TRIALS_TSV);
    let read = read_tsv::<TrialRow>(&trials_path)?;
    warnings.extend(read.warnings.iter().map(|w| w.to_string()));
    let mut seen: BTreeMap<usize, u64> = BTreeMap::new();
    let mut synthetic = info.synthetic;
    for (row, &line) in read.rows.iter().zip(&read.lines) {
        let bad = |message: String| AnalysisError::Invalid {
            path: trials_path.clone(),
            line: Some(line),
            message,
        };
        if row.participant != info.participant {
            return Err(bad(format!(
                "participant {:?}, but {} says {:?}",
                row.participant,
                info_path.display(),
                info.participant
            )));
        }
        let Some(c) = design.conditions.iter().find(|c| c.name == row.condition) else {
            return Err(bad(format!(
                "condition {:?} is not in {} ({})",
                row.condition,
                design_path.display(),
                design
                    .conditions
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        if c.method != row.method
            || c.inset_deg != row.inset_deg
            || c.silhouette_edges != row.silhouette_edges
        {
            return Err(bad(format!(
                "condition {:?} is {} in {} but the row says {}",
                c.name,
                describe(&c.method, c.inset_deg, c.silhouette_edges),
                design_path.display(),
                describe(&row.method, row.inset_deg, row.silhouette_edges)
            )));
        }
        if !(row.rt_s.is_finite() && (0.0..=MAX_SEARCH_S).contains(&row.rt_s)) {
            return Err(bad(format!(
                "rt_s {}: a search time must be 0 to {MAX_SEARCH_S} s",
                screen_geometry::fmt_f64(row.rt_s)
            )));
        }
        if let Some(first) = seen.insert(row.trial, line) {
            return Err(bad(format!(
                "trial {} already appears on line {first}",
                row.trial
            )));
        }
        synthetic |= row.synthetic;
    }
    // Scanpaths need events.tsv: read (and check) it before anything is written.
    let mut events = Vec::new();
    if opts.scanpaths
        && read
            .rows
            .iter()
            .any(|t| session::stimulus_path(dir, t.trial).is_file())
    {
        let e = read_tsv::<EventRow>(&dir.join(EVENTS_TSV))?;
        warnings.extend(e.warnings.iter().map(|w| w.to_string()));
        events = e.rows;
    }
    let (practice, trials): (Vec<TrialRow>, Vec<TrialRow>) =
        read.rows.into_iter().partition(|t| t.practice);
    Ok(Loaded {
        dir: dir.to_path_buf(),
        info,
        design,
        trials,
        practice: practice.len(),
        events,
        synthetic,
    })
}
