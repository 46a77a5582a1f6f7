//! The participant's session folder as the runner writes it
//! (`experiment::session` defines the files): created for a new session,
//! reopened for `--resume` after checks that it is the same participant
//! and the same design, appended to as the session happens.

use std::path::{Path, PathBuf};
use std::time::Duration;

use experiment::design::Design;
use experiment::session::{
    self, read_tsv, ClockRow, DisplayInfo, EventRow, FrameRow, MarkerRow, SampleRow, SessionInfo,
    Sitting, TrialRow, TsvLog,
};
use foveation::Display;

use super::RunOptions;
use crate::gaze_feed::GazeSetup;

/// The open session folder.
pub struct SessionDir {
    path: PathBuf,
    participant: String,
    next_trial: usize,
    sitting: u32,
    trials: TsvLog<TrialRow>,
    samples: TsvLog<SampleRow>,
    events: TsvLog<EventRow>,
    markers: TsvLog<MarkerRow>,
    frames: TsvLog<FrameRow>,
    clock: TsvLog<ClockRow>,
    /// The clock model's newest state, for `session.json` at the close.
    last_clock: Option<ClockRow>,
    /// What opening the files changed in them (columns added to the files
    /// of an earlier gazecast), one line each.
    upgraded: Vec<String>,
    aborted_trial: Option<(usize, u32)>,
    /// The first write that failed (the runner then stops).
    error: Option<String>,
    written_trials: usize,
    /// The LSL outlets (`--lsl`): every sample, marker and frame row
    /// written here is also pushed there, with the row's time.
    lsl: Option<crate::lsl_out::Outlets>,
    /// Frames pushed to LSL this sitting.
    lsl_frames: u64,
}

/// A participant id usable as a folder name and a BIDS label: the rule
/// of every string that becomes a path ([`experiment::design::check_id`]).
pub fn check_id(id: &str) -> Result<(), String> {
    experiment::design::check_id(id).map_err(|m| format!("--participant {m}"))
}

/// The session folder `out/<design name>/sub-<participant>`: both
/// components checked by the id rule here as well (whatever validated
/// them before), so the folder is always inside `out`.
pub fn session_path(out: &Path, design_name: &str, participant: &str) -> Result<PathBuf, String> {
    experiment::design::check_id(design_name).map_err(|m| format!("design name {m}"))?;
    check_id(participant)?;
    Ok(out.join(design_name).join(format!("sub-{participant}")))
}

fn io<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> String + '_ {
    move |e| format!("{}: {e}", path.display())
}

impl SessionDir {
    /// Creates the folder for a new session, or reopens it with `--resume`.
    pub fn open(
        opts: &RunOptions,
        design: &Design,
        display: &Display,
        index: usize,
        gaze: &GazeSetup,
    ) -> Result<Self, String> {
        let path = session_path(&opts.out, &design.name, &opts.participant)?;
        let design_text = input_file::read_to_string(&opts.design, input_file::DESIGN)
            .map_err(io(&opts.design))?;
        let info_path = path.join(session::SESSION_JSON);
        let trials_path = path.join(session::TRIALS_TSV);
        let exists = info_path.exists() || trials_path.exists();
        let mut next_trial = 0;
        let mut sitting = 1;
        if exists && !opts.resume {
            return Err(format!(
                "{}: a session of {} is already there; --resume continues it (nothing is overwritten)",
                path.display(),
                opts.participant
            ));
        }
        if !exists && opts.resume {
            return Err(format!(
                "--resume: {} holds no session to continue",
                path.display()
            ));
        }
        let software = format!("gazecast {}", env!("CARGO_PKG_VERSION"));
        let geometry = display.geometry().map_err(|e| e.to_string())?;
        let display_info = DisplayInfo {
            name: display.name.clone(),
            width_px: geometry.width_px,
            height_px: geometry.height_px,
            width_mm: display.size_mm.0,
            height_mm: display.size_mm.1,
            distance_mm: display.eye_distance_mm,
        };
        let tracker_settings = serde_json::to_value(&gaze.tracker).ok();
        let (started_unix_us, mut host_anchor_us) = wall_anchor();
        if opts.headless {
            // The virtual clock's start is the sitting's host time then.
            host_anchor_us = super::headless::START_US;
        }
        let device_clock = if opts.headless {
            super::headless::VIRTUAL_CLOCK.to_string()
        } else {
            gaze.device_clock().describe()
        };
        let mut aborted_trial = None;
        if exists {
            let mut info = SessionInfo::read(&info_path).map_err(|e| e.to_string())?;
            if info.participant_index != index {
                return Err(format!(
                    "--resume: {} was run with counterbalancing row {}, not {index}",
                    info_path.display(),
                    info.participant_index
                ));
            }
            let copy_path = path.join(session::DESIGN_RON);
            let copy = input_file::read_to_string(&copy_path, input_file::DESIGN)
                .map_err(io(&copy_path))?;
            if copy != design_text {
                return Err(format!(
                    "--resume: {} differs from the session's copy {}; a session continues with the design it started with",
                    opts.design.display(),
                    copy_path.display()
                ));
            }
            resume_differences(&info, &display_info, &software, gaze)
                .map_err(|d| format!("--resume: {}: {d}", info_path.display()))?;
            let done = read_tsv::<TrialRow>(&trials_path).map_err(|e| e.to_string())?;
            for w in &done.warnings {
                eprintln!("warning: {w}");
            }
            for (k, row) in done.rows.iter().enumerate() {
                if row.trial != k {
                    return Err(format!(
                        "{}: row {} is trial {}, expected {k}: the trial table is out of order",
                        trials_path.display(),
                        k + 2,
                        row.trial
                    ));
                }
            }
            next_trial = done.rows.len();
            sitting = 1 + info
                .sittings
                .iter()
                .map(|s| s.number)
                .max()
                .unwrap_or_else(|| {
                    info.notes
                        .iter()
                        .filter(|n| n.starts_with("sitting "))
                        .count() as u32
                });
            aborted_trial = Some((next_trial, sitting - 1));
            info.notes.push(format!(
                "sitting {sitting} from trial {} ({software}, {})",
                next_trial + 1,
                gaze.name
            ));
            info.sittings.push(Sitting {
                number: sitting,
                first_trial: next_trial,
                started_unix_us,
                host_anchor_us,
                software: software.clone(),
                tracker: gaze.name.clone(),
                tracker_settings,
                device_clock,
                clock: None,
            });
            info.synthetic |= opts.simulate.is_some();
            info.write(&info_path).map_err(|e| e.to_string())?;
        } else {
            std::fs::create_dir_all(path.join(session::STIMULI_DIR)).map_err(io(&path))?;
            let copy_path = path.join(session::DESIGN_RON);
            std::fs::write(&copy_path, &design_text).map_err(io(&copy_path))?;
            let rate = match &gaze.tracker.driver {
                tracker_hal::Driver::Mouse(m) => Some(m.rate_hz),
                tracker_hal::Driver::Iscan(i) => Some(i.rate_hz),
                _ => None,
            };
            let info = SessionInfo {
                participant: opts.participant.clone(),
                participant_index: index,
                design_name: design.name.clone(),
                software: software.clone(),
                display: display_info,
                tracker: gaze.name.clone(),
                tracker_rate_hz: rate,
                started_unix_s: started_unix_us as f64 / 1e6,
                synthetic: opts.simulate.is_some(),
                notes: vec![format!(
                    "sitting 1 from trial 1 ({software}, {})",
                    gaze.name
                )],
                sittings: vec![Sitting {
                    number: 1,
                    first_trial: 0,
                    started_unix_us,
                    host_anchor_us,
                    software: software.clone(),
                    tracker: gaze.name.clone(),
                    tracker_settings,
                    device_clock,
                    clock: None,
                }],
            };
            info.write(&info_path).map_err(|e| e.to_string())?;
        }
        let open = |name: &str| path.join(name);
        let err = |e: session::SessionFileError| e.to_string();
        let every = Duration::from_millis(200);
        let trials = TsvLog::append_to(open(session::TRIALS_TSV)).map_err(err)?;
        let frames = TsvLog::append_to(open(session::FRAMES_TSV))
            .map_err(err)?
            .flush_every(64, every);
        // A session begun by a gazecast without the later columns: they
        // were added to its files (n/a in the earlier sittings' rows).
        let upgraded = [
            (session::TRIALS_TSV, trials.added_columns()),
            (session::FRAMES_TSV, frames.added_columns()),
        ]
        .into_iter()
        .filter(|(_, added)| !added.is_empty())
        .map(|(file, added)| {
            format!(
                "{file}: written before its column{} {} existed; added, n/a in the rows of the earlier sittings",
                if added.len() == 1 { "" } else { "s" },
                added.join(", ")
            )
        })
        .collect();
        Ok(Self {
            participant: opts.participant.clone(),
            next_trial,
            sitting,
            trials,
            samples: TsvLog::append_to(open(session::SAMPLES_TSV))
                .map_err(err)?
                .flush_every(256, every),
            events: TsvLog::append_to(open(session::EVENTS_TSV)).map_err(err)?,
            markers: TsvLog::append_to(open(session::MARKERS_TSV)).map_err(err)?,
            frames,
            clock: TsvLog::append_to(open(session::CLOCK_TSV))
                .map_err(err)?
                .flush_every(64, every),
            upgraded,
            last_clock: None,
            aborted_trial,
            path,
            error: None,
            written_trials: 0,
            lsl: None,
            lsl_frames: 0,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// What opening the files changed in them, one line each (columns
    /// added to the files of a session begun by an earlier gazecast).
    pub fn upgraded(&self) -> &[String] {
        &self.upgraded
    }

    /// This sitting's number (1 for a new session).
    pub fn sitting(&self) -> u32 {
        self.sitting
    }

    /// A clock-model update: a `clock.tsv` row, and the newest one goes
    /// into `session.json`'s sitting at the close.
    pub fn clock(&mut self, c: &tracker_hal::ClockState, _how: &tracker_hal::DeviceClock) {
        let row = ClockRow {
            sitting: self.sitting,
            samples: c.samples,
            device_us: c.device_us,
            mapped_us: c.mapped_us,
            rate: c.rate,
            drift_ppm: c.drift_ppm,
            rate_clamped: c.rate_clamped,
            offset_us: c.offset_us,
            delay_us: c.delay_us,
            corrections: c.corrections,
            non_increasing: c.non_increasing,
            resets: c.resets,
        };
        let r = self.clock.write(&row);
        self.keep(r);
        self.last_clock = Some(row);
    }

    pub fn participant(&self) -> &str {
        &self.participant
    }

    /// The first trial not yet in the trial table.
    pub fn next_trial(&self) -> usize {
        self.next_trial
    }

    /// This sitting's recording of every tracker byte: `gaze-N.gzrec`.
    pub fn recording_path(&self) -> PathBuf {
        self.path.join(format!("gaze-{}.gzrec", self.sitting))
    }

    /// The first write that failed.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    fn keep<T>(&mut self, r: Result<T, session::SessionFileError>) {
        if let Err(e) = r {
            self.error.get_or_insert(e.to_string());
        }
    }

    pub fn sample(&mut self, row: &SampleRow) {
        let r = self.samples.write(row);
        self.keep(r);
        if let Some(o) = &mut self.lsl {
            let xy = row.x_px.zip(row.y_px).map(|(x, y)| [x, y]);
            let g = crate::lsl_out::GazeValues {
                gaze_px: xy,
                eyes_px: None,
            };
            o.gaze(row.mapped_us, g);
        }
    }

    /// Publishes the rows from now on to these LSL outlets too.
    pub fn attach_lsl(&mut self, outlets: crate::lsl_out::Outlets) {
        self.lsl = Some(outlets);
    }

    /// The LSL outlets' closing line, if any.
    pub fn lsl_summary(&self) -> Option<String> {
        self.lsl.as_ref().map(|o| {
            o.linger();
            o.summary()
        })
    }

    /// The trial an earlier sitting left unfinished (it is run again in
    /// this one), and that sitting: its rows there are aborted.
    pub fn aborted_trial(&self) -> Option<(usize, u32)> {
        self.aborted_trial
    }

    pub fn marker(&mut self, row: &MarkerRow) {
        let r = self.markers.write(row);
        self.keep(r);
        if let Some(o) = &mut self.lsl {
            let text = crate::lsl_out::event_text(&row.event, row.trial, &row.detail);
            o.event(row.host_us, &text);
        }
    }

    pub fn frame(&mut self, row: &FrameRow) {
        let r = self.frames.write(row);
        self.keep(r);
        if let Some(o) = &mut self.lsl {
            let trial = row.trial.map_or("-".to_string(), |t| t.to_string());
            let text = format!(
                "frame={} phase={} trial={trial} rays={} render_ms={:.2} late={}",
                self.lsl_frames,
                row.phase,
                row.rays,
                row.render_ms,
                u8::from(row.late)
            );
            o.frame(row.host_us, &text);
            self.lsl_frames += 1;
        }
    }

    pub fn event(&mut self, row: &EventRow) {
        let r = self.events.write(row);
        self.keep(r);
    }

    /// A completed trial: its row, then everything else pushed to the OS
    /// and the trial table to the disk, so a crash after this keeps it.
    pub fn trial(&mut self, row: &TrialRow) -> Result<(), String> {
        self.trials.write(row).map_err(|e| e.to_string())?;
        for r in [
            self.samples.flush(),
            self.events.flush(),
            self.markers.flush(),
            self.frames.flush(),
            self.trials.sync(),
        ] {
            r.map_err(|e| e.to_string())?;
        }
        self.written_trials += 1;
        Ok(())
    }

    /// Flushes every file and puts the sitting's final clock model into
    /// `session.json`; the closing line for the log.
    pub fn close(&mut self) -> String {
        for r in [
            self.samples.flush(),
            self.events.flush(),
            self.markers.flush(),
            self.frames.flush(),
            self.clock.flush(),
            self.trials.flush(),
        ] {
            self.keep(r);
        }
        if let Some(c) = self.last_clock.take() {
            let info_path = self.path.join(session::SESSION_JSON);
            let r = SessionInfo::read(&info_path).and_then(|mut info| {
                if let Some(s) = info.sittings.iter_mut().find(|s| s.number == self.sitting) {
                    s.clock = Some(c);
                }
                info.write(&info_path)
            });
            self.keep(r);
        }
        match &self.error {
            Some(e) => format!(
                "session folder {}: writing failed: {e}",
                self.path.display()
            ),
            None => format!(
                "session folder {}: {} trials this sitting, {} in all",
                self.path.display(),
                self.written_trials,
                self.next_trial + self.written_trials
            ),
        }
    }
}

/// The wall clock (Unix µs) and this process's host clock (µs) at one
/// instant: the host clock read on both sides of the wall clock, taking
/// the midpoint (they are microseconds apart).
fn wall_anchor() -> (u64, u64) {
    let a = tracker_hal::clock::monotonic_us();
    let unix = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    let b = tracker_hal::clock::monotonic_us();
    (unix, a + (b - a) / 2)
}

/// What a resumed sitting may not change: the display, the software and
/// the tracker's settings (all but how it is reached: its port or USB
/// device). The first difference, named.
fn resume_differences(
    info: &SessionInfo,
    display: &DisplayInfo,
    software: &str,
    gaze: &GazeSetup,
) -> Result<(), String> {
    if info.display != *display {
        let (a, b) = (&info.display, display);
        return Err(format!(
            "the session ran on display {:?} ({}x{} px, {}x{} mm at {} mm); this sitting would run on {:?} ({}x{} px, {}x{} mm at {} mm): a session continues on the display it started on",
            a.name, a.width_px, a.height_px, a.width_mm, a.height_mm, a.distance_mm,
            b.name, b.width_px, b.height_px, b.width_mm, b.height_mm, b.distance_mm
        ));
    }
    if info.software != software {
        return Err(format!(
            "the session was started by {}, this is {software}: finish it with the same version",
            info.software
        ));
    }
    let first = info
        .sittings
        .first()
        .and_then(|s| s.tracker_settings.clone());
    if let Some(first) = first {
        let Ok(was) = serde_json::from_value::<tracker_hal::TrackerConfig>(first) else {
            return Err("the first sitting's tracker settings cannot be read".into());
        };
        let d = tracker_hal::config::differences::tracker_differences_except(
            &was,
            &gaze.tracker,
            tracker_hal::config::differences::CONNECTION_ONLY,
        );
        if !d.is_empty() {
            return Err(format!(
                "the tracker differs from the first sitting's ({}); only its port or USB device may change",
                d.join("; ")
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_name_a_folder_and_nothing_else() {
        for ok in ["P01", "sub_3", "a-b", "X"] {
            assert!(check_id(ok).is_ok(), "{ok}");
        }
        for bad in ["", "../P01", "P 01", "P/1", "é", &"x".repeat(65)] {
            assert!(check_id(bad).is_err(), "{bad:?}");
        }
    }

    proptest::proptest! {
        /// Whatever the design name and the participant id, the session
        /// folder is either refused or exactly two levels inside `out`
        /// (no `..`, no root, no separator in a component).
        #[test]
        fn the_session_folder_never_leaves_out(
            name in "[a-zA-Z0-9_./\\-]{0,12}|/[a-z]{1,4}|\\.\\.(/[a-z]{1,3})?",
            id in "[a-zA-Z0-9_./-]{0,8}",
        ) {
            let out = Path::new("/srv/data/out");
            if let Ok(p) = session_path(out, &name, &id) {
                let rel = p.strip_prefix(out).expect("inside out");
                let parts: Vec<_> = rel.components().collect();
                proptest::prop_assert_eq!(parts.len(), 2, "{}", p.display());
                for c in parts {
                    proptest::prop_assert!(matches!(c, std::path::Component::Normal(_)));
                }
            }
        }
    }
}
