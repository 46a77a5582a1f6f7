//! The windowed form of Luebke & Hallen's ramp (`--procedure
//! luebke-hallen` with `--tracker FILE`): the ramp drawn frame by frame
//! under gaze-contingent fixation control, answered with the mouse or the
//! keys — or, for tests and demonstrations, by the simulated observer with
//! a scripted gaze on the mouse tracker (synthetic).
//!
//! # A trial
//!
//! The fixation target (a black dot) sits at the display's eye point. Once
//! every sample has stayed within `--fixation-window-deg` of it for
//! `--fixate-ms`, the ramp starts: the trial's Gabor patch at its
//! eccentricity in its direction (`psychophysics::ramp`; rendered each
//! frame at the schedule's contrast for the frame's start, dithered anew
//! each frame; a patch placed up, left or down is the rightward patch's
//! pixels moved there, so its pixels-per-degree are the horizontal ones).
//! The participant presses `Space` or the left mouse button when something
//! becomes visible; the patch goes and a small mark shows at each place it
//! could have been; the participant then clicks the place (the nearest
//! mark by direction from the dot) or presses the arrow key of its
//! direction (4 places: → ↑ ← ↓), without looking away. With the mouse
//! tracker the mouse is the gaze: answer the place with the arrow keys.
//! No response by the ramp's end (after the hold) is a no-response trial.
//!
//! From the ramp's first frame until the place is given, a sample outside
//! the window or an invalid one aborts the attempt: a notice for a second,
//! then the same trial again (the same place and ramp: the session draws
//! them once per trial). Aborts go to `aborts.tsv` and are counted in
//! `trials.tsv` (`aborted_attempts`) and `session.json`. Unlike the 2IFC
//! window, a tracker that stops sending samples does not abort a ramp:
//! only the samples that come are checked.
//!
//! # Clocks
//!
//! This process's host monotonic clock (µs) decides, as in the 2IFC
//! window: the onset is the start of the ramp's first frame, the response
//! time runs from it to the `Space`/click event's arrival (ms in
//! `response_ms`), the simulated observer's answer arrives when it planned
//! (onset plus the response time it drew on the ramp's schedule, whose
//! frames are the design's `frame_ms`, not the window's).

use std::io::Write;
use std::path::PathBuf;

use psychophysics::fixation::{AttemptTiming, FixationWindow};
use psychophysics::observer::SimulatedObserver;
use psychophysics::ramp::{RampRecord, RampResponse, RampSession, RampSpec, RampTrial};
use tracker_hal::clock::monotonic_us;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::WindowId;

use super::ramp::{ramp_row, RAMP_TRIALS_HEADER};
use super::window::{
    blit, centred_text, disc, Files, WindowInfo, BREAK_AFTER_US, BREAK_DEG, NOTICE_US,
};
use super::{
    create_folder, load_observer, software, write_results, write_session_json, Loaded, MeasureArgs,
    Measured, SessionInfo, SessionSetup,
};
use crate::gaze_feed::{GazeFeed, GazeSetup, TrackerMsg};
use crate::screen::Screen;

/// The screen shown.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Show {
    Instructions {
        since_us: u64,
    },
    /// Waiting for steady fixation (`steady_since`: the first of the
    /// current run of samples inside the window).
    Fixating {
        steady_since: Option<u64>,
    },
    /// The ramp, since `onset_us`.
    Ramp {
        onset_us: u64,
    },
    /// "Seen" at `seen_us`; waiting for the place.
    Locate {
        onset_us: u64,
        seen_us: u64,
    },
    /// Aborted; the same trial again at `until_us`.
    Notice {
        until_us: u64,
    },
    Over {
        since_us: u64,
    },
}

impl Show {
    fn name(&self) -> &'static str {
        match self {
            Show::Instructions { .. } => "instructions",
            Show::Fixating { .. } => "fixation",
            Show::Ramp { .. } => "stimulus",
            Show::Locate { .. } => "locate",
            Show::Notice { .. } => "abort",
            Show::Over { .. } => "over",
        }
    }
}

/// The trial on screen.
struct Current {
    trial: RampTrial,
    aborted: u32,
    /// The simulated observer's answer for this attempt: due at (host µs).
    planned: Option<(u64, RampResponse)>,
    /// The places' centres, px.
    places: Vec<[f64; 2]>,
}

struct RampMeasurer<'a> {
    a: &'a MeasureArgs,
    loaded: &'a Loaded<RampSpec>,
    dir: PathBuf,
    size: (u32, u32),
    session: RampSession,
    window: FixationWindow,
    feed: GazeFeed,
    screen: Option<Screen>,
    files: Files,
    show: Show,
    current: Option<Current>,
    observer: Option<SimulatedObserver>,
    breaks_left: u32,
    aborts_total: u32,
    frame: u64,
    cursor: Option<[f64; 2]>,
    base: Vec<u8>,
    rgb: Vec<u8>,
    screenshots: Option<PathBuf>,
    shot: Vec<&'static str>,
    log: Vec<String>,
    status: Option<String>,
    clock: Option<String>,
    error: Option<String>,
    quitting: bool,
    completed: bool,
}

/// The place of `location` of `locations` at the distance of `right` (the
/// rightward patch's centre) from `eye`, directions counter-clockwise from
/// rightward with the screen's y pointing down.
fn place(eye: [f64; 2], right: [f64; 2], location: u32, locations: u32) -> [f64; 2] {
    let r = (right[0] - eye[0]).hypot(right[1] - eye[1]);
    let th = (360.0 * f64::from(location) / f64::from(locations.max(1))).to_radians();
    [eye[0] + r * th.cos(), eye[1] - r * th.sin()]
}

/// The place nearest in direction to `at` (0 at 0°: one place).
fn nearest_place(eye: [f64; 2], at: [f64; 2], locations: u32) -> u32 {
    if locations <= 1 {
        return 0;
    }
    let deg = (-(at[1] - eye[1])).atan2(at[0] - eye[0]).to_degrees();
    let step = 360.0 / f64::from(locations);
    ((deg.rem_euclid(360.0) / step).round() as u32) % locations
}

impl RampMeasurer<'_> {
    fn eye(&self) -> [f64; 2] {
        self.loaded.geometry.eye_point_px
    }

    /// The next trial, or the last screen.
    fn begin_trial(&mut self, now: u64) -> Result<(), String> {
        let Some(trial) = self.session.next_trial() else {
            self.completed = true;
            self.current = None;
            self.show = Show::Over { since_us: now };
            return Ok(());
        };
        // Where the rightward patch's centre falls gives the places.
        let right = self
            .loaded
            .patch(self.a, trial.frequency_cpd, trial.eccentricity_deg, 0.0, 0)
            .map_err(|e| format!("trial {}: {e}", trial.index))?
            .centre_px;
        let eye = self.eye();
        let places = (0..trial.locations)
            .map(|l| place(eye, right, l, trial.locations))
            .collect();
        self.current = Some(Current {
            trial,
            aborted: 0,
            planned: None,
            places,
        });
        self.show = Show::Fixating { steady_since: None };
        Ok(())
    }

    fn abort(&mut self, reason: &str, offset: Option<f64>, at_us: u64) -> Result<(), String> {
        let (Show::Ramp { onset_us } | Show::Locate { onset_us, .. }) = self.show else {
            return Ok(());
        };
        let Some(c) = &mut self.current else {
            return Ok(());
        };
        c.aborted += 1;
        c.planned = None;
        self.aborts_total += 1;
        let row = format!(
            "{}\t{}\t{}\t{reason}\t{}\t{onset_us}\t{at_us}\n",
            c.trial.index,
            c.trial.condition,
            c.aborted,
            offset.map_or("n/a".into(), |o| format!("{o:.3}")),
        );
        let f = &mut self.files.aborts;
        f.write_all(row.as_bytes())
            .and_then(|()| f.flush())
            .map_err(|e| format!("aborts.tsv: {e}"))?;
        self.breaks_left = self.breaks_left.saturating_sub(1);
        self.show = Show::Notice {
            until_us: at_us.max(monotonic_us()) + NOTICE_US,
        };
        Ok(())
    }

    /// Records `response` (host times: the onset, the "seen" response).
    fn answer(
        &mut self,
        response: RampResponse,
        onset_us: u64,
        seen_us: Option<u64>,
    ) -> Result<(), String> {
        let Some(c) = &self.current else {
            return Ok(());
        };
        let trial = c.trial;
        let aborted = c.aborted;
        let result = if self.observer.is_some() {
            self.session
                .record_synthetic(&trial, psychophysics::ramp::SyntheticRampResponse(response))
        } else {
            self.session.record(&trial, response)
        };
        result.map_err(|e| format!("trial {}: {e}", trial.index))?;
        let Some(rec): Option<RampRecord> = self.session.records().last().copied() else {
            return Err(format!("trial {}: not recorded", trial.index));
        };
        let patch = match rec.sample_log10 {
            Some(x) => Some(
                self.loaded
                    .patch(
                        self.a,
                        trial.frequency_cpd,
                        trial.eccentricity_deg,
                        10f64.powf(x),
                        u64::from(trial.index),
                    )
                    .map_err(|e| format!("trial {}: {e}", trial.index))?,
            ),
            None => None,
        };
        let windowed = format!(
            "{aborted}\t{onset_us}\t{}",
            seen_us.map_or("n/a".into(), |s| s.to_string())
        );
        let row = ramp_row(&rec, patch.as_ref(), &windowed);
        let f = &mut self.files.trials;
        f.write_all(row.as_bytes())
            .and_then(|()| f.flush())
            .map_err(|e| format!("trials.tsv: {e}"))?;
        self.begin_trial(monotonic_us())
    }

    /// The scripted gaze of a simulated session: on the target, or away
    /// during a planned fixation break.
    fn scripted_gaze(&self, now: u64) {
        if self.observer.is_none() {
            return;
        }
        let mut at = self.eye();
        if let Show::Ramp { onset_us } = self.show {
            if self.breaks_left > 0 && now >= onset_us + BREAK_AFTER_US {
                let g = &self.loaded.geometry;
                at[0] += g.eye_distance_mm * BREAK_DEG.to_radians().tan() / g.pitch_x_mm;
            }
        }
        self.feed.cursor_moved(at[0], at[1]);
    }

    /// Every queued tracker message: samples to the file and the fixation
    /// check.
    fn pump(&mut self) -> Result<(), String> {
        let msgs: Vec<TrackerMsg> = self.feed.rx.try_iter().collect();
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
                        "{mapped_us}\t{}\t{arrival_us}\t{x}\t{y}\t{}\t{}\t{trial}\n",
                        device_us.map_or("n/a".into(), |d| d.to_string()),
                        u8::from(gaze_px.is_some()),
                        self.show.name(),
                    );
                    self.files
                        .samples
                        .write_all(row.as_bytes())
                        .map_err(|e| format!("samples.tsv: {e}"))?;
                    let geometry = &self.loaded.geometry;
                    let inside = self.window.contains(geometry, gaze_px);
                    match self.show {
                        Show::Fixating { steady_since } => {
                            self.show = Show::Fixating {
                                steady_since: if inside {
                                    steady_since.or(Some(mapped_us))
                                } else {
                                    None
                                },
                            };
                        }
                        Show::Ramp { onset_us } | Show::Locate { onset_us, .. }
                            if mapped_us >= onset_us && !inside =>
                        {
                            let offset = self.window.offset_deg(geometry, gaze_px);
                            let reason = if offset.is_some() {
                                "left-window"
                            } else {
                                "invalid-sample"
                            };
                            self.abort(reason, offset, mapped_us)?;
                        }
                        _ => {}
                    }
                }
                TrackerMsg::Status(s) => {
                    if !s.is_empty() && self.status.as_deref() != Some(s.as_str()) {
                        self.log.push(format!("tracker: {s}"));
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
            Show::Fixating {
                steady_since: Some(s),
            } if now >= s + (self.a.fixate_ms * 1e3) as u64 => {
                // The onset: the simulated observer plans its answer.
                let frame_ms = self.loaded.spec.frame_ms;
                if let (Some(o), Some(c)) = (&mut self.observer, &mut self.current) {
                    let r = o
                        .respond_ramp(&c.trial, frame_ms)
                        .map_err(|e| format!("trial {}: {e}", c.trial.index))?
                        .0;
                    let end_ms = c.trial.schedule.end_ms();
                    let due_ms = r.response_ms.unwrap_or(end_ms).min(end_ms);
                    c.planned = Some((now + (due_ms * 1e3) as u64, r));
                }
                self.show = Show::Ramp { onset_us: now };
            }
            Show::Fixating { .. } => {}
            Show::Ramp { onset_us } => {
                let Some(c) = &self.current else {
                    return Ok(());
                };
                let end_us = onset_us + (c.trial.schedule.end_ms() * 1e3) as u64;
                match c.planned {
                    Some((due, r)) if now >= due => {
                        let seen = r.response_ms.map(|_| due);
                        self.answer(r, onset_us, seen)?;
                    }
                    _ if now >= end_us => {
                        let none = RampResponse {
                            response_ms: None,
                            clicked_location: None,
                        };
                        self.answer(none, onset_us, None)?;
                    }
                    _ => {}
                }
            }
            Show::Locate { .. } => {}
            Show::Notice { until_us } => {
                if now >= until_us {
                    self.show = Show::Fixating { steady_since: None };
                }
            }
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
        let ppd = 1.0
            / self
                .loaded
                .geometry
                .eccentricity_deg(eye, [eye[0], eye[1] + 1.0]);
        self.rgb.clone_from(&self.base);
        match self.show {
            Show::Instructions { .. } => {
                let lines = [
                    "Keep your eyes on the black dot in the middle.".to_string(),
                    "A faint striped patch slowly fades in somewhere around it.".to_string(),
                    "As soon as you see something: Space or a left click.".to_string(),
                    "Then, still looking at the dot, show where it was:".to_string(),
                    "click on its mark, or the arrow key of its direction.".to_string(),
                    "If your eyes leave the dot, the trial stops and comes again.".to_string(),
                    String::new(),
                    "Space: start        Esc: end the session".to_string(),
                ];
                self.rgb.fill(self.a.background_level);
                centred_text(&mut self.rgb, size, (w / 2, h / 2), &lines, 26)?;
            }
            Show::Fixating { .. } => {}
            Show::Ramp { onset_us } => {
                if let Some(c) = &self.current {
                    let t_ms = now.saturating_sub(onset_us) as f64 / 1e3;
                    let contrast = c.trial.schedule.contrast_at(t_ms);
                    let mut p = self
                        .loaded
                        .patch(
                            self.a,
                            c.trial.frequency_cpd,
                            c.trial.eccentricity_deg,
                            contrast,
                            u64::from(c.trial.index) << 24 | (self.frame & 0xff_ffff),
                        )
                        .map_err(|e| format!("trial {}: {e}", c.trial.index))?;
                    if let Some(pl) = c.places.get(c.trial.location as usize) {
                        // centre_px is a pixel centre (x.5).
                        p.centre_px = [pl[0].floor() + 0.5, pl[1].floor() + 0.5];
                    }
                    blit(&mut self.rgb, size, &p);
                    disc(&mut self.rgb, size, eye, 4.0, 0);
                }
            }
            Show::Locate { .. } => {
                if let Some(c) = &self.current {
                    let mark = self.a.background_level.saturating_sub(40);
                    for pl in &c.places {
                        disc(&mut self.rgb, size, *pl, 5.0, mark);
                    }
                }
                let above = (at.0, at.1 - (2.0 * ppd).round() as i32);
                centred_text(
                    &mut self.rgb,
                    size,
                    above,
                    &["Where was it? Click its mark or press its arrow key.".to_string()],
                    24,
                )?;
            }
            Show::Notice { .. } => {
                let above = (at.0, at.1 - (2.0 * ppd).round() as i32);
                centred_text(
                    &mut self.rgb,
                    size,
                    above,
                    &["Your eyes left the dot: this one comes again.".to_string()],
                    24,
                )?;
            }
            Show::Over { .. } => {
                self.rgb.fill(self.a.background_level);
                let lines = [
                    "The session is over. Thank you!".to_string(),
                    format!(
                        "{} trials answered, {} shown again after the eyes left the dot.",
                        self.session.records().len(),
                        self.aborts_total
                    ),
                    String::new(),
                    "Space or Esc: close".to_string(),
                ];
                centred_text(&mut self.rgb, size, (w / 2, h / 2), &lines, 26)?;
            }
        }
        Ok(())
    }

    fn screenshot(&mut self) -> Result<(), String> {
        let Some(dir) = &self.screenshots else {
            return Ok(());
        };
        let name = self.show.name();
        if self.shot.contains(&name) {
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
        self.pump()?;
        self.step(now)?;
        self.draw(now)?;
        self.frame += 1;
        if let (Some(s), Some(t)) = (&mut self.screen, tex) {
            s.present(t, &self.rgb, self.size);
        }
        self.screenshot()
    }

    /// "Seen" during the ramp.
    fn seen(&mut self, now: u64) {
        if let Show::Ramp { onset_us } = self.show {
            if self.observer.is_none() {
                self.show = Show::Locate {
                    onset_us,
                    seen_us: now,
                };
            }
        }
    }

    /// The place given while locating.
    fn located(&mut self, location: u32) -> Result<(), String> {
        let Show::Locate { onset_us, seen_us } = self.show else {
            return Ok(());
        };
        let Some(c) = &self.current else {
            return Ok(());
        };
        let location = if c.trial.locations <= 1 {
            0
        } else {
            location % c.trial.locations
        };
        let r = RampResponse {
            response_ms: Some(seen_us.saturating_sub(onset_us) as f64 / 1e3),
            clicked_location: Some(location),
        };
        self.answer(r, onset_us, Some(seen_us))
    }

    fn key(&mut self, key: Key<&str>, now: u64) -> Result<(), String> {
        let arrow = |k: NamedKey| match k {
            NamedKey::ArrowRight => Some(0),
            NamedKey::ArrowUp => Some(1),
            NamedKey::ArrowLeft => Some(2),
            NamedKey::ArrowDown => Some(3),
            _ => None,
        };
        match (self.show, key) {
            (_, Key::Named(NamedKey::Escape)) => {
                if !matches!(self.show, Show::Over { .. }) {
                    self.log.push(format!(
                        "Esc: ended after {} trials; what was answered is written",
                        self.session.records().len()
                    ));
                }
                self.quitting = true;
            }
            (Show::Instructions { .. }, Key::Named(NamedKey::Space)) => self.begin_trial(now)?,
            (Show::Over { .. }, Key::Named(NamedKey::Space)) => self.quitting = true,
            (Show::Ramp { .. }, Key::Named(NamedKey::Space)) => self.seen(now),
            (Show::Locate { .. }, Key::Named(k)) => {
                let four = self.current.as_ref().map(|c| c.trial.locations);
                if let (Some(l), Some(1 | 4)) = (arrow(k), four) {
                    self.located(l)?;
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn handle(&mut self, event: WindowEvent) -> Result<(), String> {
        let now = monotonic_us();
        match event {
            WindowEvent::CloseRequested => {
                self.log
                    .push("window closed: ending the session".to_string());
                self.quitting = true;
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = Some([position.x, position.y]);
                // A simulated session's gaze is scripted.
                if self.observer.is_none() {
                    self.feed.cursor_moved(position.x, position.y);
                }
            }
            WindowEvent::MouseInput {
                state: ElementState::Pressed,
                button: MouseButton::Left,
                ..
            } if self.observer.is_none() => match self.show {
                Show::Ramp { .. } => self.seen(now),
                Show::Locate { .. } => {
                    if let (Some(at), Some(c)) = (self.cursor, &self.current) {
                        let l = nearest_place(self.eye(), at, c.trial.locations);
                        self.located(l)?;
                    }
                }
                _ => {}
            },
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && !event.repeat =>
            {
                self.key(event.logical_key.as_ref(), now)?
            }
            WindowEvent::RedrawRequested => {
                if crate::interrupt::interrupted() {
                    self.log
                        .push("interrupted (Ctrl-C or SIGTERM): ending the session".into());
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

impl ApplicationHandler for RampMeasurer<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.screen.is_none() {
            match Screen::open(
                el,
                &format!("gazecast thresholds (ramp) — {}", self.a.participant),
                self.size,
                self.a.fullscreen,
                self.a.monitor,
                crate::screen::PresentChoice::Fifo,
                None,
            ) {
                Ok(s) => {
                    self.log.push(format!("window: {}", s.present_mode));
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
            self.error.get_or_insert(e);
            self.quitting = true;
        }
        if self.quitting {
            el.exit();
        }
    }
}

/// Runs the windowed ramp session.
pub(super) fn run(a: &MeasureArgs, out: &mut dyn Write) -> Result<(), String> {
    let Some(tracker) = &a.tracker else {
        return Err(
            "thresholds measure --procedure luebke-hallen needs --tracker FILE.ron for the \
             windowed session (config/trackers/mouse.ron: the mouse), or --headless \
             --simulate-observer FILE.ron"
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
    let loaded = Loaded::<RampSpec>::read_ramp(a)?;
    let window = FixationWindow::new(loaded.geometry.eye_point_px, a.fixation_window_deg)
        .map_err(|e| format!("--fixation-window-deg: {e}"))?;
    if !(a.fixate_ms.is_finite() && (0.0..=10_000.0).contains(&a.fixate_ms)) {
        return Err(format!(
            "--fixate-ms {}: must be finite and in 0..=10000",
            a.fixate_ms
        ));
    }
    let session = RampSession::new(loaded.spec.clone()).map_err(|e| format!("ramp design: {e}"))?;
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
    let files = Files::create_with(&dir, RAMP_TRIALS_HEADER)?;
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
        "gazecast thresholds (Luebke & Hallen's ramp): {} in a window, gaze from {source}, session folder {}{}",
        a.participant,
        dir.display(),
        if synthetic {
            " — SIMULATED observer and scripted gaze (synthetic data)"
        } else {
            ""
        }
    );
    let mut m = RampMeasurer {
        a,
        loaded: &loaded,
        dir,
        size,
        session,
        window,
        feed,
        screen: None,
        files,
        show: Show::Instructions {
            since_us: monotonic_us(),
        },
        current: None,
        observer,
        breaks_left: a.simulate_fixation_breaks,
        aborts_total: 0,
        frame: 0,
        cursor: None,
        base,
        rgb: Vec::new(),
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
    let _ = m.pump();
    let report: Vec<String> = m.feed.report().into_iter().chain(m.clock.take()).collect();
    m.log.extend(report);
    if let Ok(Some(line)) = &recorded {
        m.log.push(line.clone());
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
            "Luebke & Hallen's ramp: a simulated observer answered every ramp and a scripted gaze fixated (mouse tracker); no person has yet run this procedure".into()
        } else {
            format!(
                "Luebke & Hallen's ramp, answered by participant {} in a window",
                a.participant
            )
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
            timing: AttemptTiming {
                fixate_ms: a.fixate_ms,
                ..AttemptTiming::default()
            },
            procedure: "Luebke & Hallen's ramp: the patch fades in at one of the places; Space or a left click when seen, then a click on its place or its arrow key; fixation checked from the ramp's first frame until the place is given",
            clocks: "onset_host_us, response_host_us, mapped_host_us, arrival_host_us, onset/at in aborts.tsv: this process's host monotonic clock (µs); response_ms: from the onset; device_us: the tracker's own clock (µs)",
            simulated_fixation_breaks: a.simulate_fixation_breaks,
        }),
        aborted_attempts: m.aborts_total,
        setup: SessionSetup::of_ramp(&loaded, a, &m.session),
    };
    if let Some(e) = m.error.take() {
        let _ = write_session_json(&m.dir, &info);
        return Err(e);
    }
    result?;
    recorded?;
    write_session_json(&m.dir, &info)?;
    if !m.completed {
        return writeln!(
            out,
            "{}: ended before the last trial ({} answered, {} attempts aborted); no fit: the session is incomplete",
            m.dir.display(),
            m.session.records().len(),
            m.aborts_total
        )
        .map_err(|e| e.to_string());
    }
    let _ = writeln!(
        out,
        "{} attempts aborted by the fixation control ({}° window)",
        m.aborts_total, a.fixation_window_deg
    );
    let who = match &a.simulate_observer {
        Some(p) => format!(
            "a simulated observer ({}), Luebke & Hallen's ramp",
            p.display()
        ),
        None => format!("participant {}, Luebke & Hallen's ramp", a.participant),
    };
    let fitted =
        psychophysics::fit::fit_ramp(&m.session, &info.setup.fit_options).and_then(|fit| {
            psychophysics::fit::ramp_threshold_table(&m.session, &fit).map(|t| (fit, t))
        });
    match fitted {
        Ok(fitted) => write_results(a, &m.dir, &Measured::of_ramp(&m.session), fitted, &who, out),
        Err(e) => writeln!(
            out,
            "{}: no thresholds file: the fit: {e}; the trials are in trials.tsv",
            m.dir.display()
        )
        .map_err(|e| e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn places_go_round_counter_clockwise_and_clicks_find_the_nearest() {
        let eye = [100.0, 100.0];
        let right = [150.0, 100.0];
        let p: Vec<[f64; 2]> = (0..4).map(|l| place(eye, right, l, 4)).collect();
        let near =
            |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9;
        assert!(near(p[0], [150.0, 100.0]));
        assert!(near(p[1], [100.0, 50.0]), "up is screen y − r");
        assert!(near(p[2], [50.0, 100.0]));
        assert!(near(p[3], [100.0, 150.0]));
        for (l, at) in p.iter().enumerate() {
            assert_eq!(nearest_place(eye, *at, 4), l as u32);
        }
        assert_eq!(
            nearest_place(eye, [140.0, 80.0], 4),
            0,
            "27° is nearer right"
        );
        assert_eq!(nearest_place(eye, [130.0, 40.0], 4), 1, "63° is nearer up");
        assert_eq!(nearest_place(eye, [150.0, 101.0], 4), 0, "just below right");
        assert_eq!(nearest_place(eye, [10.0, 10.0], 1), 0);
    }
}
