//! The output folder: where analyze may write (never into an input),
//! its files written through a temporary file and a rename, and the stale
//! outputs of an earlier run removed.

use std::path::{Component, Path, PathBuf};

use super::{
    AnalysisError, CONDITIONS_CSV, FIG_7_3, FIG_7_4, FIG_CONDITIONS, REPORT_MD, SCANPATHS_DIR,
    STATS_JSON, TABLE_7_1_CSV, TRIALS_CSV,
};
use crate::session;

/// Absolute, normalised form of `p` (symlinks resolved for the part that
/// exists).
pub(crate) fn absolute(p: &Path) -> PathBuf {
    let mut existing = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            existing = c;
            break;
        }
        match (existing.file_name(), existing.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name.to_os_string());
                existing = parent.to_path_buf();
            }
            _ => break,
        }
    }
    for name in rest.into_iter().rev() {
        existing.push(name);
    }
    // Lexically resolve what canonicalize could not (a `..` after a missing part).
    let mut norm = PathBuf::new();
    for c in existing.components() {
        match c {
            Component::ParentDir => {
                norm.pop();
            }
            Component::CurDir => {}
            other => norm.push(other),
        }
    }
    norm
}

/// Which paths the outputs may not touch: the input folders.
pub(crate) struct OutputGuard {
    pub(crate) inputs: Vec<PathBuf>,
}

impl OutputGuard {
    /// Refuses a path inside an input folder (an input folder can sit
    /// inside the output folder), so no input file is ever replaced.
    pub(crate) fn check(&self, path: &Path) -> Result<(), String> {
        let abs = absolute(path);
        match self.inputs.iter().find(|i| abs.starts_with(i)) {
            Some(input) => Err(format!(
                "it is inside input folder {}; refusing to write there",
                input.display()
            )),
            None => Ok(()),
        }
    }
}

/// Refuses an output folder that is one of the inputs or inside one;
/// `Err((input, message))`.
pub(crate) fn check_output_folder(
    dirs: &[PathBuf],
    out: &Path,
) -> Result<OutputGuard, (PathBuf, String)> {
    let out_abs = absolute(out);
    let mut inputs = Vec::new();
    for d in dirs {
        let d_abs = absolute(d);
        if out_abs.starts_with(&d_abs) {
            return Err((
                d.clone(),
                "the output folder is an input folder or inside one".into(),
            ));
        }
        inputs.push(d_abs);
    }
    Ok(OutputGuard { inputs })
}

pub(crate) struct OutputWriter {
    pub(crate) out: PathBuf,
    pub(crate) guard: OutputGuard,
}

impl OutputWriter {
    pub(crate) fn path(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }

    pub(crate) fn guard(&self, path: &Path) -> Result<(), AnalysisError> {
        self.guard
            .check(path)
            .map_err(|message| AnalysisError::Output {
                path: path.to_path_buf(),
                message,
            })
    }

    pub(crate) fn bytes(&self, path: &Path, bytes: &[u8]) -> Result<(), AnalysisError> {
        self.guard(path)?;
        session::write_atomic(path, bytes).map_err(|e| AnalysisError::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }
}

/// Whether `name` (a file in `OUT/`, or in `OUT/scanpaths/` when
/// `scanpath`) is one that analyze writes: its fixed outputs, and
/// `<participant>-trial-NNN.png` scanpaths.
pub(crate) fn analyze_output_name(name: &str, scanpath: bool) -> bool {
    if !scanpath {
        return [
            REPORT_MD,
            STATS_JSON,
            CONDITIONS_CSV,
            TRIALS_CSV,
            TABLE_7_1_CSV,
            FIG_CONDITIONS,
            FIG_7_3,
            FIG_7_4,
        ]
        .contains(&name);
    }
    let Some((who, trial)) = name
        .strip_suffix(".png")
        .and_then(|stem| stem.rsplit_once("-trial-"))
    else {
        return false;
    };
    !who.is_empty()
        && who
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        && trial.len() >= 3
        && trial.chars().all(|c| c.is_ascii_digit())
}

/// Removes what an earlier analyze wrote into `OUT` and this one did not
/// (a figure this design has no data for, another participant's
/// scanpaths): they would sit beside a report that does not list them.
/// Only files named as analyze names its outputs are touched, never
/// another file; each removal is noted in the report's warnings.
pub(crate) fn remove_stale(
    w: &OutputWriter,
    outputs: &[PathBuf],
    warnings: &mut Vec<String>,
) -> Result<(), AnalysisError> {
    let err = |path: &Path, e: std::io::Error| AnalysisError::Output {
        path: path.to_path_buf(),
        message: format!("cannot remove this output of an earlier analyze: {e}"),
    };
    let scanpaths = w.path(SCANPATHS_DIR);
    for (dir, scanpath) in [(w.out.clone(), false), (scanpaths.clone(), true)] {
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(err(&dir, e)),
        };
        let mut stale = Vec::new();
        for e in entries {
            let e = e.map_err(|e| err(&dir, e))?;
            let path = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            let is_file = e.file_type().map(|t| t.is_file()).unwrap_or(false);
            if is_file && analyze_output_name(&name, scanpath) && !outputs.contains(&path) {
                stale.push(path);
            }
        }
        stale.sort();
        for path in stale {
            w.guard(&path)?;
            std::fs::remove_file(&path).map_err(|e| err(&path, e))?;
            warnings.push(format!(
                "removed {} (written by an earlier analyze, not by this one)",
                path.display()
            ));
        }
    }
    // An emptied scanpaths folder goes too (a folder with other files stays).
    if !outputs.iter().any(|o| o.starts_with(&scanpaths)) {
        let _ = std::fs::remove_dir(&scanpaths);
    }
    Ok(())
}
