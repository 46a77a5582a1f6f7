//! `gazecast calibrate`: the calibration screen. It shows
//! `tracker_hal::calibration`'s targets one at a time, fits the mapping
//! from raw tracker units to screen pixels on the accepted ones, validates
//! it on separate targets (per-point offsets drawn as arrows, accuracy and
//! precision in degrees), offers to show rejected or bad points again, and
//! saves the calibration that `view --calibration` and `replay
//! --calibration` load.
//!
//! The procedure runs on the samples' own clock, so a recorded calibration
//! session (`--record`, or `gazecast simulate --script calibration`)
//! replays through `--replay` to the same result.
//!
//! The session's decisions (rejected targets, when to fit, which targets to
//! redo after bad validation points, when an unattended run saves) are
//! [`tracker_hal::calibration::Session`]'s; this module is the window, the
//! keys, the drawing and the wiring.
//!
//! Keys: `Space` start; `R` show rejected / bad points again; `Enter`
//! continue or save; `V` validate again; `Esc` quit without saving.

use std::io::Write;
use std::path::PathBuf;

use plotters::prelude::*;
use tracker_hal::calibration::{
    Model, Session, SessionPhase, SessionRequest, TimedPoint, ValidationSummary,
};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::WindowId;

use crate::config;
use crate::gaze_feed::{GazeFeed, GazeSetup, TrackerMsg};
use crate::screen::{Input, Screen};

use crate::args::PlanArgs;

/// `--model`: the calibration's mapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelArg {
    /// Affine: 6 parameters, at least 3 targets.
    Affine,
    /// Projective: 8 parameters, at least 4 targets.
    Homography,
    /// Second-order polynomial per axis: 12 parameters, at least 6 targets.
    Polynomial2,
}

impl From<ModelArg> for Model {
    fn from(m: ModelArg) -> Self {
        match m {
            ModelArg::Affine => Model::Affine,
            ModelArg::Homography => Model::Homography,
            ModelArg::Polynomial2 => Model::Polynomial2,
        }
    }
}

/// `gazecast calibrate`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct CalibrateArgs {
    /// Tracker file (RON); not needed with --replay.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: Option<PathBuf>,
    /// Run the procedure on a recorded session (implies --yes).
    #[arg(long, value_name = "FILE.gzrec")]
    pub replay: Option<PathBuf>,
    /// Display file (RON).
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Where the calibration is saved (RON).
    #[arg(long, value_name = "FILE.ron")]
    pub out: PathBuf,
    /// The targets and their timing.
    #[command(flatten)]
    pub plan: PlanArgs,
    /// The mapping fitted from raw tracker coordinates to screen pixels.
    #[arg(long, value_enum, default_value = "homography")]
    pub model: ModelArg,
    /// A validation point whose accuracy is worse than this is bad.
    #[arg(long, default_value_t = 1.0, value_name = "DEG")]
    pub max_error_deg: f64,
    /// Record the session (every byte from and to the tracker).
    #[arg(long, value_name = "FILE.gzrec")]
    pub record: Option<PathBuf>,
    /// Write the last screen (the validation result) here on exit.
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// Fullscreen on the current monitor.
    #[arg(long)]
    pub fullscreen: bool,
    /// Fullscreen on this monitor (0-based; an out-of-range index lists them).
    #[arg(long, value_name = "INDEX")]
    pub monitor: Option<usize>,
    /// No keys: start at once, show rejected targets once more, save.
    #[arg(long)]
    pub yes: bool,
}

struct Calibrator<'a> {
    args: &'a CalibrateArgs,
    size: (u32, u32),
    session: Session,
    feed: GazeFeed,
    screen: Option<Screen>,
    status: String,
    stream_ended: bool,
    /// The tracker's clock model as last reported (a log line).
    clock: Option<String>,
    /// Set when the result should be saved once it has been drawn.
    save_after_draw: bool,
    saved: bool,
    rgb: Vec<u8>,
    log: Vec<String>,
    error: Option<String>,
}

/// Circle + dot, as labs draw calibration targets.
fn draw_target<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    p: [f64; 2],
    outer: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let c = (p[0].round() as i32, p[1].round() as i32);
    root.draw(&Circle::new(c, 14, outer.filled()))?;
    root.draw(&Circle::new(c, 3, BLACK.filled()))
}

/// An arrow from `a` to `b`.
fn draw_arrow<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    a: [f64; 2],
    b: [f64; 2],
    colour: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let pt = |p: [f64; 2]| (p[0].round() as i32, p[1].round() as i32);
    let style = colour.stroke_width(3);
    root.draw(&PathElement::new(vec![pt(a), pt(b)], style))?;
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = dx.hypot(dy);
    if len > 1.0 {
        let (ux, uy) = (dx / len, dy / len);
        let head = 10.0_f64.min(len / 2.0).max(5.0);
        for s in [-0.45f64, 0.45] {
            let (c, sn) = (s.cos(), s.sin());
            let back = [
                b[0] - head * (ux * c - uy * sn),
                b[1] - head * (ux * sn + uy * c),
            ];
            root.draw(&PathElement::new(vec![pt(b), pt(back)], style))?;
        }
    }
    Ok(())
}

/// An arrow scale that makes the largest offset about 60 px long: 1, 2, 5,
/// 10 or 20×.
fn arrow_scale(max_offset_px: f64) -> f64 {
    [20.0, 10.0, 5.0, 2.0]
        .into_iter()
        .find(|s| s * max_offset_px <= 60.0)
        .unwrap_or(1.0)
}

impl Calibrator<'_> {
    fn log(&mut self, s: String) {
        self.log.push(s);
    }

    /// Takes the session's log lines and does what it asks.
    fn sync(&mut self) {
        self.log.extend(self.session.take_log());
        for r in self.session.take_requests() {
            match r {
                SessionRequest::Save => self.save_after_draw = true,
                SessionRequest::Abort(e) => self.error = Some(e),
            }
        }
    }

    /// Feeds every queued sample to the session (in order: the
    /// procedure's clock is the samples' own).
    fn pump(&mut self) {
        loop {
            let m = match self.feed.rx.try_recv() {
                Ok(m) => m,
                Err(crossbeam_channel::TryRecvError::Empty) => break,
                Err(crossbeam_channel::TryRecvError::Disconnected) => {
                    self.stream_ended = true;
                    break;
                }
            };
            match m {
                TrackerMsg::Gaze { mapped_us, raw, .. } => {
                    let s = TimedPoint {
                        t_us: mapped_us,
                        raw,
                    };
                    self.session.feed(s);
                    self.sync();
                }
                TrackerMsg::Status(s) => {
                    if !s.is_empty() {
                        self.log(s.clone());
                    }
                    self.status = s;
                }
                TrackerMsg::Clock(c, d) => self.clock = Some(crate::live::clock_line(&c, &d)),
            }
        }
    }

    /// A key: the session's action for it in this phase.
    fn key(&mut self, el: &ActiveEventLoop, key: Key<&str>) {
        let phase = self.session.phase().clone();
        match (&phase, key) {
            (_, Key::Named(NamedKey::Escape)) => {
                self.log("quit without saving".into());
                el.exit();
            }
            (SessionPhase::Intro, Key::Named(NamedKey::Space)) => {
                // Samples from before the start are not the person's.
                while self.feed.rx.try_recv().is_ok() {}
                self.session.start();
            }
            (SessionPhase::Rejected(_), Key::Character("r")) => self.session.redo_rejected(),
            (SessionPhase::Rejected(_), Key::Named(NamedKey::Enter)) => {
                self.session.fit_without_rejected()
            }
            (SessionPhase::Failed(_), Key::Character("r")) => self.session.start_again(),
            (SessionPhase::Result, Key::Character("r")) => {
                self.session.redo_bad();
            }
            (SessionPhase::Result, Key::Character("v")) => self.session.validate_again(),
            (SessionPhase::Result, Key::Named(NamedKey::Enter) | Key::Character("s")) => {
                if let Err(e) = self.save() {
                    self.error = Some(e);
                }
                el.exit();
            }
            _ => {}
        }
        self.sync();
    }

    /// Writes the calibration (RON) with the validation as comments.
    fn save(&mut self) -> Result<(), String> {
        let c = self
            .session
            .calibration()
            .ok_or("there is no calibration to save")?;
        let mut text = format!(
            "// gazecast calibrate: {:?} on {} targets, RMS residual {:.2} px, display {:.0}×{:.0} px\n",
            c.model,
            c.points.len(),
            c.rms_residual_px,
            self.size.0,
            self.size.1
        );
        if let Some(ValidationSummary {
            accuracy_deg: a,
            precision_rms_deg: r,
            precision_std_deg: s,
            bad,
        }) = self.session.summary()
        {
            text += &format!(
                "// validation on {} points: accuracy {a:.2}°, precision RMS {r:.3}°, STD {s:.3}°; {bad} worse than {}°\n",
                self.session.points().len(),
                self.args.max_error_deg
            );
        }
        text += &ron::ser::to_string_pretty(c, ron::ser::PrettyConfig::default())
            .map_err(|e| e.to_string())?;
        text.push('\n');
        crate::output::write_whole(&self.args.out, text.as_bytes())
            .map_err(|e| format!("{}: cannot write: {e}", self.args.out.display()))?;
        self.saved = true;
        Ok(())
    }

    /// Draws the screen for the current phase into `self.rgb`.
    fn draw(&mut self) -> Result<(), String> {
        let (w, h) = self.size;
        self.rgb.clear();
        self.rgb.resize(3 * (w * h) as usize, 128);
        let mut lines: Vec<String> = Vec::new();
        let overall = self.session.summary();
        let mut rgb = std::mem::take(&mut self.rgb);
        let (cal, val) = (
            self.session.calibration_run(),
            self.session.validation_run(),
        );
        {
            crate::picture::register_font();
            let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
            let e = |e: DrawingAreaErrorKind<_>| e.to_string();
            match self.session.phase() {
                SessionPhase::Intro => {
                    // For the participant, in the middle of the screen.
                    let say = [
                        "Look at the centre of each dot until it moves on.".to_string(),
                        format!(
                            "{} dots, then {} to check.",
                            cal.plan.targets_px.len(),
                            val.plan.targets_px.len()
                        ),
                        "Space: start     Esc: quit".to_string(),
                    ];
                    let style = ("sans-serif", 30).into_font().color(&BLACK).pos(
                        plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Center,
                        ),
                    );
                    for (k, l) in say.iter().enumerate() {
                        let y = h as i32 / 2 + 48 * (k as i32 - 1);
                        root.draw(&Text::new(l.clone(), (w as i32 / 2, y), style.clone()))
                            .map_err(e)?;
                    }
                }
                SessionPhase::Calibrating | SessionPhase::Validating => {
                    let (p, name) = if *self.session.phase() == SessionPhase::Calibrating {
                        (cal, "calibration")
                    } else {
                        (val, "validation")
                    };
                    if let Some((_, at)) = p.target() {
                        draw_target(&root, at, WHITE).map_err(e)?;
                    }
                    lines.push(format!(
                        "{name} target {} of {}",
                        (p.results().count() + 1).min(p.plan.targets_px.len()),
                        p.plan.targets_px.len()
                    ));
                }
                SessionPhase::Rejected(r) => {
                    for (i, &t) in cal.plan.targets_px.iter().enumerate() {
                        let c = if r.contains(&i) { RED } else { GREEN };
                        draw_target(&root, t, c).map_err(e)?;
                    }
                    lines.push(format!(
                        "{} of {} targets rejected (too few valid samples or unsteady): R: show them again   Enter: fit without them   Esc: quit",
                        r.len(),
                        cal.plan.targets_px.len()
                    ));
                }
                SessionPhase::Failed(msg) => {
                    lines.push(format!("calibration failed: {msg}"));
                    lines.push("R: start again   Esc: quit".into());
                }
                SessionPhase::Result => {
                    for &t in &cal.plan.targets_px {
                        root.draw(&Circle::new(
                            (t[0].round() as i32, t[1].round() as i32),
                            4,
                            RGBColor(90, 90, 90).filled(),
                        ))
                        .map_err(e)?;
                    }
                    let max_px = self
                        .session
                        .points()
                        .iter()
                        .flatten()
                        .map(|p| {
                            (p.mean_gaze_px[0] - p.target_px[0])
                                .hypot(p.mean_gaze_px[1] - p.target_px[1])
                        })
                        .fold(0.0, f64::max);
                    let scale = arrow_scale(max_px);
                    for (r, p) in val.results().zip(self.session.points()) {
                        let t = r.target_px;
                        draw_target(&root, t, WHITE).map_err(e)?;
                        let at = (t[0].round() as i32 + 18, t[1].round() as i32 + 10);
                        let font = ("sans-serif", 16).into_font();
                        match p {
                            Ok(p) => {
                                let c = if p.accuracy_deg > self.args.max_error_deg {
                                    RED
                                } else {
                                    RGBColor(0, 140, 0)
                                };
                                let end = [
                                    t[0] + scale * (p.mean_gaze_px[0] - t[0]),
                                    t[1] + scale * (p.mean_gaze_px[1] - t[1]),
                                ];
                                draw_arrow(&root, t, end, c).map_err(e)?;
                                root.draw(&Text::new(
                                    format!(
                                        "{:.2}° (RMS {:.2}°, n={})",
                                        p.accuracy_deg, p.precision_rms_deg, p.samples
                                    ),
                                    at,
                                    font.color(&BLACK),
                                ))
                                .map_err(e)?;
                            }
                            Err(m) => {
                                root.draw(&Text::new(m.clone(), at, font.color(&RED)))
                                    .map_err(e)?;
                            }
                        }
                    }
                    match overall {
                        Some(ValidationSummary {
                            accuracy_deg: a,
                            precision_rms_deg: rms,
                            precision_std_deg: std,
                            bad,
                        }) => {
                            lines.push(format!(
                                "accuracy {a:.2}°   precision RMS {rms:.3}°  STD {std:.3}°   ({} points, {bad} worse than {}°)",
                                self.session.points().len(),
                                self.args.max_error_deg
                            ));
                        }
                        None => lines.push("no validation point has data".into()),
                    }
                    if let Some(c) = self.session.calibration() {
                        lines.push(format!(
                            "{:?} fit on {} targets, residual {:.2} px; arrows: target → mean gaze, drawn {scale}× long",
                            c.model,
                            c.points.len(),
                            c.rms_residual_px
                        ));
                    }
                    let bad = self.session.bad_points().len();
                    lines.push(format!(
                        "Enter: save to {}   {}V: validate again   Esc: quit without saving",
                        self.args.out.display(),
                        if bad > 0 {
                            format!("R: redo the {bad} bad points   ")
                        } else {
                            String::new()
                        }
                    ));
                }
            }
            root.present().map_err(|e| e.to_string())?;
        }
        if !self.status.is_empty() {
            lines.push(self.status.clone());
        }
        let refs: Vec<&str> = lines.iter().map(String::as_str).collect();
        let drawn =
            crate::picture::draw_text_lines(&mut rgb, (w, h), &refs).map_err(|e| e.to_string());
        self.rgb = rgb;
        drawn
    }

    fn frame(&mut self, el: &ActiveEventLoop) -> Result<(), String> {
        let tex = self.screen.as_ref().and_then(Screen::acquire);
        self.pump();
        if self.error.is_some() {
            el.exit();
            return Ok(());
        }
        if self.stream_ended && *self.session.phase() != SessionPhase::Result {
            return Err(format!(
                "the recording ended before the calibration finished (phase {:?})",
                self.session.phase()
            ));
        }
        self.draw()?;
        if let (Some(s), Some(t)) = (&mut self.screen, tex) {
            s.present(t, &self.rgb, self.size);
        }
        if self.save_after_draw {
            self.save_after_draw = false;
            self.save()?;
            el.exit();
        }
        Ok(())
    }
}

impl ApplicationHandler for Calibrator<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.screen.is_none() {
            match Screen::open(
                el,
                "gazecast — calibration",
                self.size,
                self.args.fullscreen,
                self.args.monitor,
                crate::screen::PresentChoice::Fifo,
                None,
            ) {
                Ok(s) => self.screen = Some(s),
                Err(e) => {
                    self.error = Some(e);
                    el.exit();
                }
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match Input::from(event) {
            Input::Close => el.exit(),
            Input::Cursor(x, y) => self.feed.cursor_moved(x, y),
            Input::Key(key) => self.key(el, key.as_ref()),
            Input::Redraw => {
                if crate::interrupt::interrupted() {
                    self.log("interrupted (Ctrl-C or SIGTERM): not saved".into());
                    return el.exit();
                }
                if let Err(e) = self.frame(el) {
                    self.error = Some(e);
                    return el.exit();
                }
                if let Some(s) = &self.screen {
                    s.window.request_redraw();
                }
            }
            Input::Other => {}
        }
    }
}

/// Runs `gazecast calibrate`.
pub fn run(args: &CalibrateArgs, out: &mut dyn Write) -> Result<(), String> {
    let mut outputs = vec![("--out", args.out.as_path())];
    outputs.extend(args.record.as_deref().map(|p| ("--record", p)));
    outputs.extend(args.screenshot.as_deref().map(|p| ("--screenshot", p)));
    let mut inputs = vec![("--display", args.display.as_path())];
    inputs.extend(args.tracker.as_deref().map(|p| ("--tracker", p)));
    inputs.extend(args.replay.as_deref().map(|p| ("--replay", p)));
    crate::output::refuse_inputs(&outputs, &inputs)?;
    if !(args.max_error_deg.is_finite() && args.max_error_deg > 0.0) {
        return Err(format!(
            "--max-error-deg {}: must be a positive number",
            args.max_error_deg
        ));
    }
    args.plan.check_counts()?;
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let size = display.resolution_px;
    let (cal_plan, val_plan) = args.plan.plans(size)?;
    let model = Model::from(args.model);
    if cal_plan.targets_px.len() < model.min_points() {
        return Err(format!(
            "--points {}: {model:?} needs at least {}",
            cal_plan.targets_px.len(),
            model.min_points()
        ));
    }
    let setup = GazeSetup::resolve(args.tracker.as_deref(), args.replay.as_deref())?;
    let auto = args.yes || setup.is_replay();
    let source = setup.name.clone();
    let event_loop = {
        crate::screen::close_recordings_if_the_x_server_goes();
        EventLoop::new()
    }
    .map_err(|e| {
        format!("cannot open a window ({e}); the calibration screen needs a display (or Xvfb)")
    })?;
    crate::interrupt::catch_interrupts();
    let feed = setup.spawn(
        None,
        args.record.as_deref().map(|p| (p, display.name.as_str())),
    )?;
    let mut c = Calibrator {
        args,
        size,
        session: Session::new(
            model,
            cal_plan,
            val_plan,
            geometry,
            args.max_error_deg,
            auto,
        ),
        feed,
        screen: None,
        status: String::new(),
        stream_ended: false,
        clock: None,
        save_after_draw: false,
        saved: false,
        rgb: Vec::new(),
        log: Vec::new(),
        error: None,
    };
    let result = event_loop.run_app(&mut c);
    let recorded = c.feed.finish();
    report(&c, &source, out)?;
    // The tracker's faults (silences, undecoded bytes, reconnects). Gaze far
    // off the screen is not rejected here: a calibration must see what an
    // uncalibrated tracker reports, however far off.
    for line in c.feed.report().into_iter().chain(c.clock.clone()) {
        writeln!(out, "{line}").map_err(|e| e.to_string())?;
    }
    if let Some(line) = recorded? {
        writeln!(out, "{line}").map_err(|e| e.to_string())?;
    }
    if let Some(path) = &args.screenshot {
        if !c.rgb.is_empty() {
            crate::picture::save_png(path, size, &c.rgb)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            writeln!(out, "wrote {}", path.display()).map_err(|e| e.to_string())?;
        }
    }
    if let Some(e) = c.error {
        return Err(e);
    }
    result.map_err(|e| format!("window: {e}"))?;
    if !c.saved {
        return Err(format!("not saved: {} was not written", args.out.display()));
    }
    Ok(())
}

/// The session log: targets, fit, validation.
fn report(c: &Calibrator, source: &str, out: &mut dyn Write) -> Result<(), String> {
    let w = |out: &mut dyn Write, s: String| writeln!(out, "{s}").map_err(|e| e.to_string());
    w(out, format!("gazecast calibrate: gaze from {source}"))?;
    for l in &c.log {
        w(out, l.clone())?;
    }
    let cal = c.session.calibration_run();
    for r in cal.results() {
        let t = r.target_px;
        w(
            out,
            match &r.window {
                Ok(win) if r.accepted(&cal.plan) => format!(
                    "target ({:.0}, {:.0}): accepted, raw ({:.2}, {:.2}), {} of {} samples, dispersion {:.3}",
                    t[0], t[1], win.raw[0], win.raw[1], win.kept, win.in_window, win.dispersion
                ),
                Ok(win) => format!(
                    "target ({:.0}, {:.0}): rejected, dispersion {:.3} too large",
                    t[0], t[1], win.dispersion
                ),
                Err(why) => format!("target ({:.0}, {:.0}): rejected, {why}", t[0], t[1]),
            },
        )?;
    }
    for (r, p) in c.session.validation_run().results().zip(c.session.points()) {
        let t = r.target_px;
        w(
            out,
            match p {
                Ok(p) => format!(
                    "validation ({:.0}, {:.0}): accuracy {:.3}°, precision RMS {:.3}°, STD {:.3}°, {} samples",
                    t[0], t[1], p.accuracy_deg, p.precision_rms_deg, p.precision_std_deg, p.samples
                ),
                Err(e) => format!("validation ({:.0}, {:.0}): {e}", t[0], t[1]),
            },
        )?;
    }
    if let Some(ValidationSummary {
        accuracy_deg: a,
        precision_rms_deg: r,
        precision_std_deg: s,
        bad,
    }) = c.session.summary()
    {
        w(
            out,
            format!(
                "validation: accuracy {a:.3}°, precision RMS {r:.3}°, STD {s:.3}°; {bad} of {} points worse than {}°",
                c.session.points().len(),
                c.args.max_error_deg
            ),
        )?;
    }
    if c.saved {
        w(out, format!("saved {}", c.args.out.display()))?;
    }
    Ok(())
}
