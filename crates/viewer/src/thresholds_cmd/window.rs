//! The windowed session of `thresholds measure`: a two-interval forced
//! choice under gaze-contingent fixation control, for a person (or, for
//! tests and demonstrations, the simulated observer with a scripted gaze).
//!
//! # A trial
//!
//! The fixation target (a black dot) sits at the display's eye point. Once
//! the gaze has stayed within `--fixation-window-deg` of it for the
//! fixation time, two intervals are shown, marked `1` and `2` below the
//! dot (beyond the patch's ±3σ); the Gabor patch of the trial (its
//! frequency, eccentricity to the right of fixation, contrast;
//! `psychophysics::stimulus`, dithered, mean luminance the background's)
//! is in one of them, chosen by a seeded generator. Then the participant
//! answers: `←` or `1` or a left click for the first interval, `→` or `2`
//! or a right click for the second. A two-interval choice rather than two
//! locations: a patch at 0° has only one place. At 0° the fixation dot
//! covers the patch's centre pixels.
//!
//! The fixation control is `psychophysics::fixation::FixationControl`:
//! a sample outside the window, an invalid sample (a blink) or no samples
//! during the two intervals abort the attempt; a notice is shown for a
//! second and the same trial comes again (with its interval drawn anew).
//! Aborts go to `aborts.tsv` as they happen and are counted in
//! `trials.tsv` (`aborted_attempts`) and `session.json`.
//!
//! # Clocks
//!
//! One clock decides: this process's host monotonic clock (µs,
//! tracker-hal `clock::monotonic_us`), onto which the tracker's device
//! times are mapped (`mapped_us`). The stimulus onset is the start of the
//! frame that first shows the intervals (its present follows within a
//! refresh: FIFO); the response time runs from the start of the frame
//! that first shows the prompt to the key or click event's arrival in the
//! window (winit gives key events no timestamp). The simulated observer's
//! answers arrive at the time it planned (prompt onset plus its response
//! time). `samples.tsv` has each sample's mapped time, its device time (the
//! tracker's clock) and its arrival time (host clock).
//!
//! # Keys
//!
//! `Space` starts; `←`/`1`/left click and `→`/`2`/right click answer;
//! `Esc` ends the session: what was answered stays written (no fit:
//! the session is incomplete); `Space` or `Esc` closes the last screen.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use psychophysics::fixation::{
    Abort, AbortReason, AttemptPhase, AttemptTiming, FixationControl, FixationWindow, Step,
};
use psychophysics::observer::{SimulatedObserver, SyntheticResponse};
use psychophysics::session::{Response, Session, Trial};
use psychophysics::stimulus::GaborPatch;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use tracker_hal::clock::monotonic_us;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::WindowId;

use super::{
    create_folder, fit_and_table, load_observer, software, trial_row, write_results,
    write_session_json, Loaded, MeasureArgs, Measured, SessionInfo, SessionSetup, Shown,
    TRIALS_HEADER,
};
use crate::gaze_feed::{GazeFeed, GazeSetup, TrackerMsg};
use crate::screen::Screen;

/// How long the abort notice stays, µs.
pub(super) const NOTICE_US: u64 = 1_000_000;
/// How far the scripted gaze looks away in a simulated fixation break, degrees.
pub(super) const BREAK_DEG: f64 = 3.0;
/// The scripted gaze breaks this long after the onset, µs.
pub(super) const BREAK_AFTER_US: u64 = 100_000;

/// What `session.json` says about the windowed session.
#[derive(Debug, Clone, Serialize)]
pub(super) struct WindowInfo {
    pub(super) tracker: String,
    pub(super) calibration: Option<String>,
    pub(super) fixation_window_deg: f64,
    pub(super) timing: AttemptTiming,
    pub(super) procedure: &'static str,
    pub(super) clocks: &'static str,
    pub(super) simulated_fixation_breaks: u32,
}

/// The screen shown.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Show {
    Instructions {
        since_us: u64,
    },
    /// An attempt: fixation, the two intervals, the check.
    Attempt,
    /// The attempt was aborted; the same trial comes again at `until_us`.
    Notice {
        until_us: u64,
    },
    /// The prompt, shown since `prompt_us`; the simulated observer's
    /// answer is due at `due_us`.
    Respond {
        prompt_us: u64,
        planned: Option<(u64, SyntheticResponse)>,
    },
    Over {
        since_us: u64,
    },
}

impl Show {
    fn name(&self, phase: AttemptPhase) -> &'static str {
        match (self, phase) {
            (Show::Instructions { .. }, _) => "instructions",
            (Show::Attempt, AttemptPhase::Presenting { .. }) => "stimulus",
            (Show::Attempt, _) => "fixation",
            (Show::Notice { .. }, _) => "abort",
            (Show::Respond { .. }, _) => "response",
            (Show::Over { .. }, _) => "over",
        }
    }
}

/// The trial on screen.
struct Current {
    trial: Trial,
    patch: GaborPatch,
    /// 0 or 1.
    target_interval: u8,
    onset_us: Option<u64>,
}

/// The files written as it happens.
pub(super) struct Files {
    pub(super) trials: BufWriter<File>,
    pub(super) samples: BufWriter<File>,
    pub(super) aborts: BufWriter<File>,
}

impl Files {
    fn create(dir: &Path) -> Result<Self, String> {
        Self::create_with(dir, TRIALS_HEADER)
    }

    /// With `trials_header` as `trials.tsv`'s first line.
    pub(super) fn create_with(dir: &Path, trials_header: &str) -> Result<Self, String> {
        let open = |name: &str, header: &str| -> Result<BufWriter<File>, String> {
            let p = dir.join(name);
            let mut f =
                BufWriter::new(File::create(&p).map_err(|e| format!("{}: {e}", p.display()))?);
            f.write_all(header.as_bytes())
                .and_then(|()| f.flush())
                .map_err(|e| format!("{}: {e}", p.display()))?;
            Ok(f)
        };
        Ok(Self {
            trials: open("trials.tsv", trials_header)?,
            // mapped: the device time on the host monotonic clock; device:
            // the tracker's own clock; arrival: host monotonic.
            samples: open(
                "samples.tsv",
                "mapped_host_us\tdevice_us\tarrival_host_us\tx_px\ty_px\tvalid\tscreen\ttrial\n",
            )?,
            aborts: open(
                "aborts.tsv",
                "trial\tcondition\tattempt\treason\toffset_deg\tonset_host_us\tat_host_us\n",
            )?,
        })
    }
}

struct Measurer<'a> {
    a: &'a MeasureArgs,
    loaded: &'a Loaded,
    dir: PathBuf,
    size: (u32, u32),
    session: Session,
    control: FixationControl,
    feed: GazeFeed,
    screen: Option<Screen>,
    files: Files,
    show: Show,
    current: Option<Current>,
    interval_rng: ChaCha8Rng,
    observer: Option<SimulatedObserver>,
    breaks_left: u32,
    /// The background with the fixation dot, drawn once.
    base: Vec<u8>,
    rgb: Vec<u8>,
    /// Does `rgb` hold the patch?
    patch_drawn: bool,
    screenshots: Option<PathBuf>,
    shot: Vec<&'static str>,
    log: Vec<String>,
    status: Option<String>,
    /// The tracker's clock model as last reported (a log line at the end).
    clock: Option<String>,
    error: Option<String>,
    quitting: bool,
    completed: bool,
}

/// Writes `lines` centred on (x, y), `px` high, black.
pub(super) fn centred_text(
    rgb: &mut [u8],
    size: (u32, u32),
    at: (i32, i32),
    lines: &[String],
    px: u32,
) -> Result<(), String> {
    crate::picture::register_font();
    let root = BitMapBackend::with_buffer(rgb, size).into_drawing_area();
    let style = ("sans-serif", px)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Center));
    let step = (px * 3 / 2) as i32;
    let top = at.1 - step * (lines.len() as i32 - 1) / 2;
    for (k, l) in lines.iter().enumerate() {
        root.draw(&Text::new(
            l.clone(),
            (at.0, top + step * k as i32),
            style.clone(),
        ))
        .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

/// A filled disc of `level` (grey) at `c`, radius `r` px.
pub(super) fn disc(rgb: &mut [u8], (w, h): (u32, u32), c: [f64; 2], r: f64, level: u8) {
    let (x0, x1) = (
        (c[0] - r).floor().max(0.0),
        (c[0] + r).ceil().min(f64::from(w)),
    );
    let (y0, y1) = (
        (c[1] - r).floor().max(0.0),
        (c[1] + r).ceil().min(f64::from(h)),
    );
    for y in y0 as u32..y1 as u32 {
        for x in x0 as u32..x1 as u32 {
            let (dx, dy) = (f64::from(x) + 0.5 - c[0], f64::from(y) + 0.5 - c[1]);
            if dx * dx + dy * dy <= r * r {
                let i = 3 * (y as usize * w as usize + x as usize);
                rgb[i..i + 3].fill(level);
            }
        }
    }
}

/// Copies the patch's levels (grey) into the frame at its place.
pub(super) fn blit(rgb: &mut [u8], (w, h): (u32, u32), p: &GaborPatch) {
    let n = p.side_px as i64;
    let half = n / 2;
    // centre_px is a pixel centre (x.5): its pixel index is the floor.
    let (cx, cy) = (p.centre_px[0].floor() as i64, p.centre_px[1].floor() as i64);
    for j in 0..n {
        let y = cy - half + j;
        if !(0..i64::from(h)).contains(&y) {
            continue;
        }
        for i in 0..n {
            let x = cx - half + i;
            if !(0..i64::from(w)).contains(&x) {
                continue;
            }
            let level = p.levels[(j * n + i) as usize];
            let k = 3 * (y as usize * w as usize + x as usize);
            rgb[k..k + 3].fill(level);
        }
    }
}

impl Measurer<'_> {
    fn say(&mut self, line: String) {
        self.log.push(line);
    }

    fn eye(&self) -> [f64; 2] {
        self.loaded.geometry.eye_point_px
    }

    /// The next trial, or the last screen when the session is over.
    fn begin_trial(&mut self, now: u64) -> Result<(), String> {
        let Some(trial) = self.session.next_trial() else {
            self.completed = true;
            self.current = None;
            self.show = Show::Over { since_us: now };
            return Ok(());
        };
        let patch = self
            .loaded
            .patch(
                self.a,
                trial.frequency_cpd,
                trial.eccentricity_deg,
                trial.contrast,
                u64::from(trial.index),
            )
            .map_err(|e| format!("trial {}: {e}", trial.index))?;
        self.current = Some(Current {
            trial,
            patch,
            target_interval: self.interval_rng.random_range(0..2),
            onset_us: None,
        });
        self.control.next_trial(now);
        self.show = Show::Attempt;
        Ok(())
    }

    /// The same trial again after an abort, its interval drawn anew.
    fn repeat_trial(&mut self, now: u64) {
        let interval = self.interval_rng.random_range(0..2);
        if let Some(c) = &mut self.current {
            c.target_interval = interval;
            c.onset_us = None;
        }
        self.control.start(now);
        self.show = Show::Attempt;
    }

    fn aborted(&mut self, a: Abort, now: u64) -> Result<(), String> {
        let Some(c) = &self.current else {
            return Ok(());
        };
        let offset = match a.reason {
            AbortReason::LeftWindow { offset_deg } => format!("{offset_deg:.3}"),
            _ => "n/a".into(),
        };
        let row = format!(
            "{}\t{}\t{}\t{}\t{offset}\t{}\t{}\n",
            c.trial.index,
            c.trial.condition,
            self.control.aborts_this_trial(),
            a.reason.name(),
            a.onset_us,
            a.at_us
        );
        let f = &mut self.files.aborts;
        f.write_all(row.as_bytes())
            .and_then(|()| f.flush())
            .map_err(|e| format!("aborts.tsv: {e}"))?;
        self.breaks_left = self.breaks_left.saturating_sub(1);
        self.show = Show::Notice {
            until_us: now + NOTICE_US,
        };
        Ok(())
    }

    /// An answer: `chosen` interval (0 or 1) at `at_us`, or the simulated
    /// observer's.
    fn answer(&mut self, chosen: Option<u8>, at_us: u64) -> Result<(), String> {
        let Show::Respond { prompt_us, planned } = self.show else {
            return Ok(());
        };
        let Some(c) = &self.current else {
            return Ok(());
        };
        let trial = c.trial;
        let (chosen, result) = match (planned, chosen) {
            (Some((_, r)), _) => {
                let chosen = if r.0.correct {
                    c.target_interval
                } else {
                    1 - c.target_interval
                };
                (chosen, self.session.record_synthetic(&trial, r))
            }
            (None, Some(chosen)) => {
                let r = Response {
                    correct: chosen == c.target_interval,
                    rt_ms: at_us.saturating_sub(prompt_us) as f64 / 1e3,
                };
                (chosen, self.session.record(&trial, r))
            }
            (None, None) => return Ok(()),
        };
        result.map_err(|e| format!("trial {}: {e}", trial.index))?;
        let rec = self.session.records()[self.session.records().len() - 1];
        let shown = Shown {
            aborted_attempts: self.control.aborts_this_trial(),
            target_interval: c.target_interval + 1,
            chosen_interval: chosen + 1,
            onset_host_us: c.onset_us.unwrap_or(0),
            response_host_us: match planned {
                Some((due, _)) => due,
                None => at_us,
            },
        };
        let row = trial_row(&c.patch, &rec, Some(&shown));
        let f = &mut self.files.trials;
        f.write_all(row.as_bytes())
            .and_then(|()| f.flush())
            .map_err(|e| format!("trials.tsv: {e}"))?;
        self.begin_trial(at_us)
    }

    /// The scripted gaze of a simulated session: on the target, or away
    /// during a planned fixation break.
    fn scripted_gaze(&self, now: u64) {
        if self.observer.is_none() {
            return;
        }
        let eye = self.eye();
        let mut at = eye;
        if let (Show::Attempt, AttemptPhase::Presenting { onset_us }) =
            (self.show, self.control.phase())
        {
            if self.breaks_left > 0 && now >= onset_us + BREAK_AFTER_US {
                let g = &self.loaded.geometry;
                at[0] += g.eye_distance_mm * BREAK_DEG.to_radians().tan() / g.pitch_x_mm;
            }
        }
        self.feed.cursor_moved(at[0], at[1]);
    }

    /// Every queued tracker message: samples to the file and the control.
    fn pump(&mut self, now: u64) -> Result<(), String> {
        let msgs: Vec<TrackerMsg> = self.feed.rx.try_iter().collect();
        let screen = self.show.name(self.control.phase());
        let trial = self
            .current
            .as_ref()
            .map_or("n/a".to_string(), |c| c.trial.index.to_string());
        for m in msgs {
            match m {
                TrackerMsg::Gaze {
                    mapped_us,
                    device_us,
                    arrival_us,
                    gaze_px,
                    ..
                } => {
                    let (x, y) = gaze_px.map_or(("n/a".into(), "n/a".into()), |g| {
                        (format!("{:.2}", g[0]), format!("{:.2}", g[1]))
                    });
                    let row = format!(
                        "{mapped_us}\t{}\t{arrival_us}\t{x}\t{y}\t{}\t{screen}\t{trial}\n",
                        device_us.map_or("n/a".into(), |d| d.to_string()),
                        u8::from(gaze_px.is_some()),
                    );
                    self.files
                        .samples
                        .write_all(row.as_bytes())
                        .map_err(|e| format!("samples.tsv: {e}"))?;
                    if self.show == Show::Attempt {
                        if let Step::Aborted(a) = self.control.sample(mapped_us, gaze_px) {
                            self.aborted(a, now)?;
                        }
                    }
                }
                TrackerMsg::Status(s) => {
                    if !s.is_empty() && self.status.as_deref() != Some(s.as_str()) {
                        self.say(format!("tracker: {s}"));
                        self.status = Some(s);
                    }
                }
                TrackerMsg::Clock(c, d) => self.clock = Some(crate::live::clock_line(&c, &d)),
            }
        }
        self.files
            .samples
            .flush()
            .map_err(|e| format!("samples.tsv: {e}"))
    }

    /// The state machine at `now`.
    fn step(&mut self, now: u64) -> Result<(), String> {
        let simulated = self.observer.is_some();
        match self.show {
            Show::Instructions { since_us } => {
                if simulated && now >= since_us + 800_000 {
                    self.begin_trial(now)?;
                }
            }
            Show::Attempt => match self.control.tick(now) {
                Step::Onset(t) => {
                    if let Some(c) = &mut self.current {
                        c.onset_us = Some(t);
                    }
                }
                Step::Clean => {
                    let planned = match (&mut self.observer, &self.current) {
                        (Some(o), Some(c)) => {
                            let t = c.trial;
                            let r = o
                                .respond(
                                    t.frequency_cpd,
                                    t.eccentricity_deg,
                                    t.contrast.min(self.loaded.max_contrast),
                                )
                                .map_err(|e| format!("trial {}: {e}", t.index))?;
                            let rt_us = (r.0.rt_ms.max(0.0) * 1e3) as u64;
                            Some((now + rt_us, r))
                        }
                        _ => None,
                    };
                    self.show = Show::Respond {
                        prompt_us: now,
                        planned,
                    };
                }
                Step::Aborted(a) => self.aborted(a, now)?,
                Step::Same => {}
            },
            Show::Notice { until_us } => {
                if now >= until_us {
                    self.repeat_trial(now);
                }
            }
            Show::Respond {
                planned: Some((due, _)),
                ..
            } => {
                if now >= due {
                    self.answer(None, due)?;
                }
            }
            Show::Respond { .. } => {}
            Show::Over { since_us } => {
                if simulated && now >= since_us + 1_000_000 {
                    self.quitting = true;
                }
            }
        }
        Ok(())
    }

    /// Draws the current screen into `self.rgb`.
    fn draw(&mut self, now: u64) -> Result<(), String> {
        let size = self.size;
        let (w, h) = (size.0 as i32, size.1 as i32);
        let eye = self.eye();
        let at = (eye[0] as i32, eye[1] as i32);
        self.rgb.clone_from(&self.base);
        self.patch_drawn = false;
        let rgb = &mut self.rgb;
        let ppd = 1.0
            / self
                .loaded
                .geometry
                .eccentricity_deg(eye, [eye[0], eye[1] + 1.0]);
        match self.show {
            Show::Instructions { .. } => {
                let lines = [
                    "Keep your eyes on the black dot in the middle.".to_string(),
                    "A faint striped patch appears in one of two moments, marked 1 and 2."
                        .to_string(),
                    "Then say which: ← or 1 (or a left click) for the first,".to_string(),
                    "→ or 2 (or a right click) for the second. Guess when unsure.".to_string(),
                    "If your eyes leave the dot, the trial stops and comes again.".to_string(),
                    String::new(),
                    "Space: start        Esc: end the session".to_string(),
                ];
                rgb.fill(self.a.background_level);
                centred_text(rgb, size, (w / 2, h / 2), &lines, 26)?;
            }
            Show::Attempt => {
                if let Some(k) = self.control.showing_interval(now) {
                    if let Some(c) = &self.current {
                        if c.target_interval == k {
                            blit(rgb, size, &c.patch);
                            self.patch_drawn = true;
                        }
                    }
                    // The fixation dot over the patch (at 0°).
                    disc(rgb, size, eye, 4.0, 0);
                    // Below the patch's window (±3σ) even at 0°.
                    let down_deg = (3.0 * self.a.sigma_deg + 0.5).max(1.0);
                    let below = (at.0, at.1 + (down_deg * ppd).round() as i32);
                    centred_text(rgb, size, below, &[format!("{}", k + 1)], 22)?;
                }
            }
            Show::Notice { .. } => {
                let above = (at.0, at.1 - (2.0 * ppd).round() as i32);
                centred_text(
                    rgb,
                    size,
                    above,
                    &["Your eyes left the dot: this one comes again.".to_string()],
                    24,
                )?;
            }
            Show::Respond { .. } => {
                let above = (at.0, at.1 - (2.0 * ppd).round() as i32);
                centred_text(
                    rgb,
                    size,
                    above,
                    &["Which one held the patch?   ← 1      2 →".to_string()],
                    26,
                )?;
            }
            Show::Over { .. } => {
                rgb.fill(self.a.background_level);
                let lines = [
                    "The session is over. Thank you!".to_string(),
                    format!(
                        "{} trials answered, {} shown again after the eyes left the dot.",
                        self.session.records().len(),
                        self.control.aborts_total()
                    ),
                    String::new(),
                    "Space or Esc: close".to_string(),
                ];
                centred_text(rgb, size, (w / 2, h / 2), &lines, 26)?;
            }
        }
        Ok(())
    }

    /// The first frame of each screen, when asked.
    fn screenshot(&mut self) -> Result<(), String> {
        let Some(dir) = &self.screenshots else {
            return Ok(());
        };
        let name = self.show.name(self.control.phase());
        // The stimulus screen: a frame with the patch on it.
        if self.shot.contains(&name) || (name == "stimulus" && !self.patch_drawn) {
            return Ok(());
        }
        let p = dir.join(format!("{name}.png"));
        crate::picture::save_png(&p, self.size, &self.rgb)
            .map_err(|e| format!("{}: {e}", p.display()))?;
        self.shot.push(name);
        Ok(())
    }

    fn frame(&mut self) -> Result<(), String> {
        let tex = self.screen.as_ref().and_then(Screen::acquire);
        let now = monotonic_us();
        self.scripted_gaze(now);
        self.pump(now)?;
        self.step(now)?;
        self.draw(now)?;
        if let (Some(s), Some(t)) = (&mut self.screen, tex) {
            s.present(t, &self.rgb, self.size);
        }
        self.screenshot()
    }

    fn key(&mut self, key: Key<&str>, now: u64) -> Result<(), String> {
        match (self.show, key) {
            (_, Key::Named(NamedKey::Escape)) => {
                if !matches!(self.show, Show::Over { .. }) {
                    self.say(format!(
                        "Esc: ended after {} trials; what was answered is written",
                        self.session.records().len()
                    ));
                }
                self.quitting = true;
            }
            (Show::Instructions { .. }, Key::Named(NamedKey::Space)) => self.begin_trial(now)?,
            (Show::Over { .. }, Key::Named(NamedKey::Space)) => self.quitting = true,
            (Show::Respond { planned: None, .. }, Key::Named(NamedKey::ArrowLeft))
            | (Show::Respond { planned: None, .. }, Key::Character("1")) => {
                self.answer(Some(0), now)?
            }
            (Show::Respond { planned: None, .. }, Key::Named(NamedKey::ArrowRight))
            | (Show::Respond { planned: None, .. }, Key::Character("2")) => {
                self.answer(Some(1), now)?
            }
            _ => {}
        }
        Ok(())
    }

    fn handle(&mut self, event: WindowEvent) -> Result<(), String> {
        let now = monotonic_us();
        match event {
            WindowEvent::CloseRequested => {
                self.say("window closed: ending the session".into());
                self.quitting = true;
            }
            // A simulated session's gaze is scripted.
            WindowEvent::CursorMoved { position, .. } if self.observer.is_none() => {
                self.feed.cursor_moved(position.x, position.y);
            }
            WindowEvent::MouseInput {
                state: ElementState::Pressed,
                button,
                ..
            } if matches!(self.show, Show::Respond { planned: None, .. }) => match button {
                MouseButton::Left => self.answer(Some(0), now)?,
                MouseButton::Right => self.answer(Some(1), now)?,
                _ => {}
            },
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && !event.repeat =>
            {
                self.key(event.logical_key.as_ref(), now)?
            }
            WindowEvent::RedrawRequested => {
                if crate::interrupt::interrupted() {
                    self.say("interrupted (Ctrl-C or SIGTERM): ending the session".into());
                    self.quitting = true;
                } else {
                    self.frame()?;
                    if let Some(s) = &self.screen {
                        s.window.request_redraw();
                    }
                }
            }
            _ => {}
        }
        Ok(())
    }
}

impl ApplicationHandler for Measurer<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.screen.is_none() {
            match Screen::open(
                el,
                &format!("gazecast thresholds — {}", self.a.participant),
                self.size,
                self.a.fullscreen,
                self.a.monitor,
                // Onsets are tied to the refresh: every frame waits for it.
                crate::screen::PresentChoice::Fifo,
                // The stimuli are drawn on the CPU: copied into the window.
                None,
            ) {
                Ok(s) => {
                    self.say(format!("window: {}", s.present_mode));
                    self.screen = Some(s);
                }
                Err(e) => {
                    self.error = Some(e);
                    el.exit();
                }
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if let Err(e) = self.handle(event) {
            // Keep the first error: it is the cause.
            self.error.get_or_insert(e);
            self.quitting = true;
        }
        if self.quitting {
            el.exit();
        }
    }
}

/// Runs the windowed session.
pub(super) fn run(a: &MeasureArgs, out: &mut dyn Write) -> Result<(), String> {
    let Some(tracker) = &a.tracker else {
        return Err(
            "thresholds measure needs --tracker FILE.ron for the windowed session \
             (config/trackers/mouse.ron: the mouse), or --headless --simulate-observer FILE.ron"
                .into(),
        );
    };
    if a.simulate_fixation_breaks > 0 && a.simulate_observer.is_none() {
        return Err("--simulate-fixation-breaks needs --simulate-observer FILE.ron".into());
    }
    let setup = GazeSetup::resolve(Some(tracker), None)?;
    let observer = match &a.simulate_observer {
        Some(p) if !setup.is_mouse() => {
            return Err(format!(
                "--simulate-observer {} in a window scripts the gaze on the mouse tracker \
                 (--tracker config/trackers/mouse.ron), not {}",
                p.display(),
                setup.name
            ))
        }
        Some(p) => Some(load_observer(p)?),
        None => None,
    };
    let calibration = match &a.calibration {
        Some(p) => Some(crate::config::load_calibration(p).map_err(|e| e.to_string())?),
        None => None,
    };
    let loaded = Loaded::read(a)?;
    let window = FixationWindow::new(loaded.geometry.eye_point_px, a.fixation_window_deg)
        .map_err(|e| format!("--fixation-window-deg: {e}"))?;
    let timing = AttemptTiming {
        fixate_ms: a.fixate_ms,
        interval_ms: a.interval_ms,
        gap_ms: a.gap_ms,
        ..AttemptTiming::default()
    };
    timing.validate().map_err(|e| {
        let flag = match e.field {
            "fixate_ms" => "--fixate-ms",
            "interval_ms" => "--interval-ms",
            "gap_ms" => "--gap-ms",
            other => other,
        };
        format!("{flag} {}: {}", e.value, e.reason)
    })?;
    let control = FixationControl::new(window, timing, loaded.geometry)
        .map_err(|e| format!("fixation control: {e}"))?;
    let session = Session::new(loaded.spec.clone()).map_err(|e| format!("session design: {e}"))?;
    let event_loop = {
        crate::screen::close_recordings_if_the_x_server_goes();
        EventLoop::new()
    }
    .map_err(|e| {
        format!(
            "cannot open a window ({}); the windowed session needs a display (or Xvfb), or run --headless --simulate-observer FILE.ron",
            crate::screen::plain_error(&e)
        )
    })?;
    if let Some(d) = &a.screenshots {
        std::fs::create_dir_all(d).map_err(|e| format!("--screenshots {}: {e}", d.display()))?;
    }
    let dir = create_folder(a)?;
    let files = Files::create(&dir)?;
    crate::interrupt::catch_interrupts();
    let source = setup.name.clone();
    let record = dir.join("tracker.gzrec");
    let feed = setup
        .with_screen(loaded.geometry.size_px())
        .spawn(calibration, Some((&record, loaded.display.name.as_str())))?;
    let size = (loaded.geometry.width_px, loaded.geometry.height_px);
    let mut base = vec![a.background_level; 3 * size.0 as usize * size.1 as usize];
    disc(&mut base, size, loaded.geometry.eye_point_px, 4.0, 0);
    let synthetic = observer.is_some();
    let _ = writeln!(
        out,
        "gazecast thresholds: {} in a window, gaze from {source}, session folder {}{}",
        a.participant,
        dir.display(),
        if synthetic {
            " — SIMULATED observer and scripted gaze (synthetic data)"
        } else {
            ""
        }
    );
    let mut m = Measurer {
        a,
        loaded: &loaded,
        dir,
        size,
        session,
        control,
        feed,
        screen: None,
        files,
        show: Show::Instructions {
            since_us: monotonic_us(),
        },
        current: None,
        interval_rng: ChaCha8Rng::seed_from_u64(loaded.spec.seed ^ 0x2_1fc),
        observer,
        breaks_left: a.simulate_fixation_breaks,
        base,
        rgb: Vec::new(),
        patch_drawn: false,
        screenshots: a.screenshots.clone(),
        shot: Vec::new(),
        log: Vec::new(),
        status: None,
        clock: None,
        error: None,
        quitting: false,
        completed: false,
    };
    let result = event_loop
        .run_app(&mut m)
        .map_err(|e| format!("window: {e}"));
    let recorded = m.feed.finish();
    // The last samples.
    let _ = m.pump(monotonic_us());
    for l in m.feed.report().into_iter().chain(m.clock.take()) {
        m.say(l);
    }
    if let Ok(Some(line)) = &recorded {
        m.say(line.clone());
    }
    for l in &m.log {
        let _ = writeln!(out, "{l}");
    }
    for (f, name) in [
        (&mut m.files.trials, "trials.tsv"),
        (&mut m.files.samples, "samples.tsv"),
        (&mut m.files.aborts, "aborts.tsv"),
    ] {
        f.flush().map_err(|e| format!("{name}: {e}"))?;
    }
    let info = SessionInfo {
        synthetic: m.session.is_synthetic(),
        note: if synthetic {
            "a simulated observer answered every trial and a scripted gaze fixated (mouse tracker); no person has yet run this procedure".into()
        } else {
            format!("answered by participant {} in a window", a.participant)
        },
        software: software(),
        participant: &a.participant,
        observer_file: a
            .simulate_observer
            .as_ref()
            .map(|p| p.display().to_string()),
        observer: m.observer.as_ref().map(|o| *o.spec()),
        completed: m.completed,
        window: Some(WindowInfo {
            tracker: source,
            calibration: a.calibration.as_ref().map(|p| p.display().to_string()),
            fixation_window_deg: a.fixation_window_deg,
            timing,
            procedure: "two-interval forced choice; the patch in one interval, chosen by a seeded generator",
            clocks: "onset_host_us, response_host_us, mapped_host_us, arrival_host_us, onset/at in aborts.tsv: this process's host monotonic clock (µs); device_us: the tracker's own clock (µs)",
            simulated_fixation_breaks: a.simulate_fixation_breaks,
        }),
        aborted_attempts: m.control.aborts_total(),
        setup: SessionSetup::of(&loaded, a, &m.session),
    };
    if let Some(e) = m.error.take() {
        let _ = write_session_json(&m.dir, &info);
        return Err(e);
    }
    result?;
    recorded?;
    if !m.completed {
        write_session_json(&m.dir, &info)?;
        return writeln!(
            out,
            "{}: ended before the last trial ({} answered, {} attempts aborted); no fit: the session is incomplete",
            m.dir.display(),
            m.session.records().len(),
            m.control.aborts_total()
        )
        .map_err(|e| e.to_string());
    }
    let who = match &a.simulate_observer {
        Some(p) => format!("a simulated observer ({})", p.display()),
        None => format!("participant {}", a.participant),
    };
    let _ = writeln!(
        out,
        "{} attempts aborted by the fixation control ({}° window)",
        m.control.aborts_total(),
        a.fixation_window_deg
    );
    write_session_json(&m.dir, &info)?;
    // A fit that fails (too few trials, thresholds that do not rise with
    // frequency) leaves the session's files: a finding, not a failed run.
    match fit_and_table(&m.session, &info.setup.fit_options) {
        Ok(fitted) => write_results(a, &m.dir, &Measured::of(&m.session), fitted, &who, out),
        Err(e) => writeln!(
            out,
            "{}: no thresholds file: {e}; the trials are in trials.tsv",
            m.dir.display()
        )
        .map_err(|e| e.to_string()),
    }
}
