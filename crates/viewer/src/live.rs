//! The live gaze-contingent session in a window, shared by `gazecast view`
//! and `gazecast demo`.
//!
//! Threads: a tracker thread ([`crate::gaze_feed`]) runs the driver and
//! sends samples over a `crossbeam-channel`, optionally tapping every byte
//! into a recording (its own writer thread); the window thread, once the
//! surface has a texture for the next frame, drains the channel to the
//! newest sample (never an old gaze, never waiting for the tracker),
//! renders through the frame pipeline (`pipeline::Renderer`: the scene's
//! method and effect passes, CPU or GPU core), and presents by copying the frame
//! into the window's surface (wgpu). Invalid samples (blinks) keep the last
//! valid gaze; a tracker that fails is reopened with backoff while
//! rendering goes on with a status line. Closing the window, `Esc`, Ctrl-C,
//! SIGTERM or the frame limit end it; the recording is then closed properly.
//!
//! Keys: `P` POR box, `L` layers view, `H` HUD, `S` screenshot (to
//! `gazecast-screenshot.png`), `Esc` quit.
//!
//! The session log says what drew every frame: a `plan: …` line with the
//! renderer's provenance (`pipeline::Renderer::provenance`: method,
//! backend, passes) before the first frame, a `plan changed: …` line
//! before the first frame of each new plan (`P` adds or removes the POR
//! box pass), and each frame's line ends `[plan: …]`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crossbeam_channel::Receiver;
use foveation::{Display, ScreenGeometry};
use pipeline::{BackendChoice, Options, Renderer};
use raycast::gpu::Traffic;
use raycast::render::Stats;
use raycast::{layers_rgb, Camera, Frame, Scene};
use tracker_hal::clock::monotonic_us;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::WindowId;

use crate::config::{self, load_scene};
use crate::gaze_feed::{GazeFeed, GazeSetup, TrackerMsg};
use crate::picture::{draw_text_lines, save_png, text_overlay};
use crate::screen::{Input, Screen};
use experiment::stats::nearest_rank::p50_95_99;

/// What a live session runs: plain values, whichever command asks.
#[derive(Debug, Clone, Default)]
pub struct LiveOptions {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// Display file (RON).
    pub display: PathBuf,
    /// Tracker file (RON); not needed with `replay`.
    pub tracker: Option<PathBuf>,
    /// A tracker-hal recording played at its original pacing as the gaze.
    pub replay: Option<PathBuf>,
    /// A calibration (from `gazecast calibrate`) mapping the raw gaze.
    pub calibration: Option<PathBuf>,
    /// Record the session losslessly here.
    pub record: Option<PathBuf>,
    /// Exit after this many frames.
    pub frames: Option<u64>,
    /// Write the last frame (with overlays) here on exit.
    pub screenshot: Option<PathBuf>,
    /// Draw the POR box whatever the scene asks.
    pub por_overlay: bool,
    /// Where to render: CPU, GPU, or the GPU when there is one.
    pub backend: BackendChoice,
    /// The rendering method (the scene may still fall back to full).
    pub method: pipeline::Method,
    /// The model-based methods' budget and gaze options.
    pub model_based: pipeline::model_based::ModelBasedOptions,
    /// A participant's thresholds (`--thresholds FILE`); `None`: the
    /// default Geisler–Perry model.
    pub thresholds: Option<PathBuf>,
    /// The hybrid method's gaze tolerance, degrees
    /// (`foveation::SamplingModel::gaze_tolerance_deg`).
    pub gaze_tolerance_deg: f64,
    /// Whether the ray masks follow the eye distance the tracker measures.
    pub eye_distance: EyeDistance,
    /// Fullscreen on the current monitor.
    pub fullscreen: bool,
    /// Fullscreen on this monitor (0-based).
    pub monitor: Option<usize>,
    /// How the window presents (`--present-mode`).
    pub present_mode: crate::screen::PresentChoice,
    /// Publish LSL streams (`--lsl`; [`crate::lsl_out`]).
    pub lsl: Option<crate::lsl_out::LslOptions>,
}

/// `--eye-distance`: which eye-to-screen distance the ray masks are built
/// for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum EyeDistance {
    /// The tracker's measured distance when its samples carry eye positions
    /// (HID trackers), else the display file's.
    #[default]
    Measured,
    /// Always the display file's.
    Fixed,
}

/// Why a live session ended in failure.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LiveError {
    /// No window can be opened here (no display server); the cause is the
    /// windowing system's. A caller may fall back to rendering headless.
    #[error(
        "cannot open a window ({0}); on a machine without a display use `gazecast demo` or run under Xvfb"
    )]
    NoWindow(String),
    /// Anything else: the files, the tracker, rendering, the session log.
    #[error("{0}")]
    Failed(String),
}

impl From<String> for LiveError {
    fn from(e: String) -> Self {
        LiveError::Failed(e)
    }
}

/// Frames the HUD's latency percentiles cover.
const HUD_FRAMES: usize = 300;

/// Gaze-to-photon figures (ms), one entry per frame that showed a gaze
/// sample for the first time (a sample's later frames add no latency).
/// Gaze age counts from the sample's capture: its mapped device time
/// ([`tracker_hal::supervisor::capture_us`]), so the transport's delivery delay
/// is in it (the tracker's own fixed latency before its timestamp is not:
/// no tracker here reports it).
#[derive(Debug, Default)]
pub struct Latency {
    /// Capture → latched by the frame (after the surface gave it a
    /// texture, so a vsync wait is not counted as gaze age).
    pub latch: Vec<f64>,
    /// Capture → the frame's copy submitted to the GPU queue.
    pub submit: Vec<f64>,
    /// Capture → the present call returned.
    pub present: Vec<f64>,
    /// Submit-to-submit time of those frames.
    pub interval: Vec<f64>,
    /// Age at submit minus the frame interval: what the software adds
    /// beyond the frame (the goal is ≤ 2 ms).
    pub excess: Vec<f64>,
}

impl Latency {
    /// The session log's summary lines.
    pub fn summary(&self) -> Vec<String> {
        if self.submit.is_empty() {
            return vec!["gaze age: no gaze sample arrived".into()];
        }
        let f = |name: &str, v: &[f64]| {
            if v.is_empty() {
                return format!("{name}: none (it needs two frames)");
            }
            let [a, b, c] = p50_95_99(v);
            format!("{name} p50 {a:.1} ms, p95 {b:.1} ms, p99 {c:.1} ms")
        };
        vec![
            f("gaze age at latch", &self.latch),
            f("gaze age at submit", &self.submit),
            f("gaze age when the present call returned", &self.present),
            f("interval between frames", &self.interval),
            format!(
                "{} (goal ≤ 2 ms)",
                f("software-added latency (age at submit − frame interval)", &self.excess)
            ),
            "scan-out time: not reported (wgpu 30 exposes no presentation timestamps); the present call's return is the last instant measured".into(),
        ]
    }
}
struct Viewer<'a> {
    /// The display's geometry (vergence is measured in it).
    geometry: ScreenGeometry,
    opts: &'a LiveOptions,
    /// The session log, written as it happens (a long session keeps
    /// nothing in memory and a crash loses nothing written).
    out: &'a mut dyn Write,
    /// The first failure to write the log (the session goes on).
    log_error: Option<String>,
    renderer: Renderer<'a>,
    /// The plan the log last named ([`PlanLog`]).
    plan: PlanLog,
    feed: GazeFeed,
    screen: Option<Screen>,
    gaze: [f64; 2],
    /// Lee's attention model is the gaze source: the renderer runs it on
    /// every frame (its last pass, `Renderer::set_attention_gaze`), its
    /// point fed to the tracker stream for the next frames.
    attention: bool,
    /// Both eyes' points of the gaze in use, when its sample had both.
    eyes_px: Option<[[f64; 2]; 2]>,
    /// The last measured eye distance (mm), kept through samples without
    /// one (blinks); `None` until one arrives.
    eye_distance_mm: Option<f64>,
    /// Capture time of the gaze in use (this process's clock), and whether
    /// a frame has shown it.
    gaze_host_us: Option<u64>,
    /// The tracker's clock model, as last reported, and when it was last
    /// logged (µs).
    clock: Option<(tracker_hal::ClockState, tracker_hal::DeviceClock)>,
    clock_logged_us: Option<u64>,
    gaze_shown: bool,
    status: String,
    layers: bool,
    hud: bool,
    /// The text lines over the last frame (HUD, status, recording), for a
    /// screenshot of a frame that stayed on the GPU.
    shown_lines: Vec<String>,
    /// The overlay's text on the window's GPU and when it was uploaded:
    /// frames that stay on the GPU refresh it at most every
    /// [`OVERLAY_REFRESH`] (and at once when its lines come or go).
    overlay: Option<(String, Instant)>,
    frames: u64,
    fresh_frames: u64,
    /// Frames drawn with a new ray mask, and frames that were the last
    /// one copied (a kept mask, nothing else changed).
    new_masks: u64,
    copied_frames: u64,
    /// When the first frame was submitted.
    first_submit_us: Option<u64>,
    latency: Latency,
    last_submit_us: Option<u64>,
    last: Option<(Frame, Stats)>,
    started: Instant,
    error: Option<String>,
    /// When the session was asked to end (frames reached, Esc, the window
    /// closed, an error), host monotonic µs.
    stop_us: Option<u64>,
    /// The LSL outlets (`--lsl`), and how a replay's times reach this
    /// process's clock.
    lsl: Option<crate::lsl_out::Outlets>,
    lsl_shift: crate::lsl_out::ReplayShift,
    /// What each GPU frame moved between the CPU and the GPU
    /// (`Renderer::gpu_traffic`; empty on the CPU backend).
    traffic: Vec<Traffic>,
}

/// The newest valid gaze of a drain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Newest {
    /// The gaze, screen px.
    pub gaze_px: [f64; 2],
    /// Capture time on this process's monotonic clock (µs,
    /// [`tracker_hal::supervisor::capture_us`]).
    pub host_us: u64,
    /// Both eyes' points (screen px) when that sample had both.
    pub eyes_px: Option<[[f64; 2]; 2]>,
    /// The eyes' measured distance from the screen (mm), when the sample
    /// had eye positions.
    pub eye_distance_mm: Option<f64>,
}

/// Drains `rx` to its newest valid gaze; returns it with its capture time,
/// applies status lines and hands clock-model updates on. Invalid samples
/// keep the last valid gaze.
pub fn drain_newest(
    rx: &Receiver<TrackerMsg>,
    on_status: impl FnMut(String),
    on_clock: impl FnMut(tracker_hal::ClockState, tracker_hal::DeviceClock),
) -> Option<Newest> {
    drain_newest_each(rx, |_| {}, on_status, on_clock)
}

/// [`drain_newest`], handing every message to `on_each` first (every gaze
/// sample, valid or not: the LSL gaze stream takes them all).
pub fn drain_newest_each(
    rx: &Receiver<TrackerMsg>,
    mut on_each: impl FnMut(&TrackerMsg),
    mut on_status: impl FnMut(String),
    mut on_clock: impl FnMut(tracker_hal::ClockState, tracker_hal::DeviceClock),
) -> Option<Newest> {
    let mut newest = None;
    for m in rx.try_iter() {
        on_each(&m);
        match m {
            TrackerMsg::Gaze {
                received_us,
                arrival_us,
                mapped_us,
                gaze_px,
                eyes_px,
                eye_distance_mm,
                ..
            } => {
                if let Some(g) = gaze_px.filter(|g| g[0].is_finite() && g[1].is_finite()) {
                    newest = Some(Newest {
                        gaze_px: g,
                        host_us: tracker_hal::supervisor::capture_us(
                            received_us,
                            arrival_us,
                            mapped_us,
                        ),
                        eyes_px,
                        eye_distance_mm,
                    });
                }
            }
            TrackerMsg::Status(s) => on_status(s),
            TrackerMsg::Clock(c, d) => on_clock(c, d),
        }
    }
    newest
}

/// The renderer's plan as the session log names it: a line when the
/// session starts and whenever the plan changes, and the current plan for
/// every frame's line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlanLog {
    current: String,
}

impl PlanLog {
    /// Starts with the renderer's plan; the log's line for it.
    pub fn new(plan: String) -> (Self, String) {
        let line = format!("plan: {plan}");
        (Self { current: plan }, line)
    }

    /// The plan that drew a frame: the log's line if it changed.
    pub fn frame(&mut self, plan: String) -> Option<String> {
        if plan == self.current {
            return None;
        }
        self.current = plan;
        Some(format!("plan changed: {}", self.current))
    }

    /// The plan of the last frame (or of the start).
    pub fn current(&self) -> &str {
        &self.current
    }
}

impl Viewer<'_> {
    /// One line of the session log.
    fn say(&mut self, line: &str) {
        emit(self.out, &mut self.log_error, line);
    }

    fn drain(&mut self) {
        let (out, log_error, status) = (&mut *self.out, &mut self.log_error, &mut self.status);
        let clock = &mut self.clock;
        let (lsl, shift) = (&mut self.lsl, &mut self.lsl_shift);
        let newest = drain_newest_each(
            &self.feed.rx,
            |m| {
                if let (
                    Some(o),
                    TrackerMsg::Gaze {
                        received_us,
                        arrival_us,
                        mapped_us,
                        gaze_px,
                        eyes_px,
                        ..
                    },
                ) = (lsl.as_mut(), m)
                {
                    let t = shift.host_us(*received_us, *arrival_us, *mapped_us);
                    o.gaze(
                        t,
                        crate::lsl_out::GazeValues {
                            gaze_px: *gaze_px,
                            eyes_px: *eyes_px,
                        },
                    );
                }
            },
            |s| {
                if !s.is_empty() {
                    emit(out, log_error, &s);
                }
                *status = s;
            },
            |c, d| *clock = Some((c, d)),
        );
        // The clock model in the log: its first fit, then every 10 s.
        if let Some((c, d)) = self.clock {
            let now = monotonic_us();
            if self
                .clock_logged_us
                .is_none_or(|t| now.saturating_sub(t) >= 10_000_000)
            {
                self.clock_logged_us = Some(now);
                let line = clock_line(&c, &d);
                self.say(&line);
            }
        }
        if let Some(n) = newest {
            self.gaze = n.gaze_px;
            self.eyes_px = n.eyes_px;
            if n.eye_distance_mm.is_some() {
                self.eye_distance_mm = n.eye_distance_mm;
            }
            self.gaze_host_us = Some(n.host_us);
            self.gaze_shown = false;
        }
    }

    fn frame(&mut self) -> Result<(), String> {
        // The texture first: under FIFO this is where the display makes us
        // wait, and the gaze is latched after it.
        let tex = self.screen.as_ref().and_then(Screen::acquire);
        self.drain();
        let latch_us = monotonic_us();
        let fresh = !self.gaze_shown && self.gaze_host_us.is_some();
        let gaze = self.gaze;
        let vergence = self
            .eyes_px
            .and_then(|e| tracker_hal::plausibility::vergence_mm(&self.geometry, e));
        self.renderer.set_vergence_mm(vergence);
        if self.opts.eye_distance == EyeDistance::Measured
            && self.renderer.set_eye_distance_mm(self.eye_distance_mm)
        {
            let line = format!(
                "eye distance {:.0} mm (measured): ray masks built for it",
                self.renderer.eye_distance_mm()
            );
            self.say(&line);
        }
        // The frame stays on the GPU where the window draws from the
        // renderer's device and nothing on the CPU reads it (the layers
        // view does; the attention source is a pass of the plan).
        let stay = self.screen.as_ref().is_some_and(Screen::presents_from_gpu)
            && !self.layers
            && self.renderer.can_stay_on_gpu().is_ok();
        if stay != self.renderer.stays_on_gpu() {
            self.renderer.set_stay_on_gpu(stay)?;
        }
        let (mut frame, stats) = self.renderer.render(gaze).map_err(|e| e.to_string())?;
        self.traffic.extend(self.renderer.gpu_traffic());
        if self.attention {
            self.feed.attention_gaze(self.renderer.attention_gaze_px());
        }
        if self.layers {
            frame.rgb = layers_rgb(&frame);
        }
        let recording = self
            .feed
            .recording_failure()
            .map(|e| tracker_hal::supervisor::recording_stopped(&e));
        self.shown_lines.clear();
        if self.hud || !self.status.is_empty() || recording.is_some() {
            let fps = self.frames as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
            // The HUD's percentiles cover the last frames only: sorting the
            // whole session every frame would grow with its length.
            let recent = |v: &[f64]| p50_95_99(&v[v.len().saturating_sub(HUD_FRAMES)..]);
            let [a, b, c] = recent(&self.latency.submit);
            let [_, e95, _] = recent(&self.latency.excess);
            let hud = format!(
                "{fps:.1} fps  {} rays  gaze→submit p50 {a:.1} p95 {b:.1} p99 {c:.1} ms  beyond frame p95 {e95:.1} ms",
                stats.rays_total,
            );
            let lines: Vec<&str> = [
                self.hud.then_some(hud.as_str()),
                Some(self.status.as_str()),
                recording.as_deref(),
            ]
            .into_iter()
            .flatten()
            .filter(|l| !l.is_empty())
            .collect();
            if !frame.is_on_device() {
                draw_text_lines(&mut frame.rgb, (frame.width_px, frame.height_px), &lines)
                    .map_err(|e| e.to_string())?;
            }
            self.shown_lines = lines.iter().map(|l| l.to_string()).collect();
        }
        if frame.is_on_device() {
            self.refresh_overlay(frame.width_px)?;
        }
        let submit_us = match (&mut self.screen, tex) {
            (Some(s), Some(t)) => match self.renderer.gpu_frame_pixels() {
                Some((pixels, size)) if frame.is_on_device() => {
                    s.present_gpu(t, pixels, size).unwrap_or_else(monotonic_us)
                }
                _ => s.present(t, &frame.rgb, (frame.width_px, frame.height_px)),
            },
            _ => monotonic_us(),
        };
        let present_us = monotonic_us();
        let interval_ms = self
            .last_submit_us
            .map(|t| submit_us.saturating_sub(t) as f64 / 1e3);
        self.last_submit_us = Some(submit_us);
        let mut age = "held".to_string();
        if let (true, Some(t)) = (fresh, self.gaze_host_us) {
            let ms = |u: u64| u.saturating_sub(t) as f64 / 1e3;
            let l = &mut self.latency;
            l.latch.push(ms(latch_us));
            l.submit.push(ms(submit_us));
            l.present.push(ms(present_us));
            if let Some(i) = interval_ms {
                l.interval.push(i);
                l.excess.push(ms(submit_us) - i);
            }
            self.gaze_shown = true;
            self.fresh_frames += 1;
            age = format!("{:.1} ms", ms(submit_us));
        }
        let reuse = self.renderer.reuse_stats();
        let reused = match (reuse.frame_reused, reuse.pixels_reused, reuse.mask_reused) {
            (true, ..) => " copied the last frame (mask kept)".to_string(),
            (false, 0, false) => String::new(),
            (false, n, kept) => format!(
                " reused{} {n} of {} pixel hits",
                if kept { " the mask and" } else { "" },
                n + reuse.pixels_cast
            ),
        };
        self.first_submit_us.get_or_insert(submit_us);
        if reuse.frame_reused {
            self.copied_frames += 1;
        } else if stats.rays_mask > 0 && !reuse.mask_reused {
            self.new_masks += 1;
        }
        if let Some(line) = self.plan.frame(self.renderer.provenance()) {
            self.say(&line);
        }
        self.say(&format!(
            "frame {} gaze ({:.1}, {:.1}) age {age} rays {} render {:.1} ms{reused} [plan: {}]",
            self.frames,
            gaze[0],
            gaze[1],
            stats.rays_total,
            stats.time_ms,
            self.plan.current()
        ));
        if let Some(o) = &mut self.lsl {
            let text = format!(
                "frame={} method={} rays={} gaze_x={:.1} gaze_y={:.1} fresh={} present_us={present_us}",
                self.frames,
                self.renderer.method().name(),
                stats.rays_total,
                gaze[0],
                gaze[1],
                u8::from(fresh),
            );
            o.frame(present_us, &text);
        }
        self.frames += 1;
        // The previous frame's buffers serve the next one.
        if let Some((old, _)) = self.last.replace((frame, stats)) {
            self.renderer.recycle(old);
        }
        Ok(())
    }

    fn fail(&mut self, el: &ActiveEventLoop, e: String) {
        self.error = Some(e);
        self.exit(el);
    }

    /// Uploads the text lines over the frame as the window's overlay when
    /// they changed: lines that come or go at once, changed text at most
    /// every [`OVERLAY_REFRESH`] (the HUD's figures change every frame;
    /// each upload is a picture of the lines).
    fn refresh_overlay(&mut self, width_px: u32) -> Result<(), String> {
        let Some(screen) = &mut self.screen else {
            return Ok(());
        };
        let text = self.shown_lines.join("\n");
        let due = match &self.overlay {
            None => !text.is_empty(),
            Some((old, _)) if old == &text => false,
            Some((old, at)) => {
                old.lines().count() != text.lines().count() || at.elapsed() >= OVERLAY_REFRESH
            }
        };
        if !due {
            return Ok(());
        }
        if text.is_empty() {
            screen.set_overlay(None);
            self.overlay = None;
            return Ok(());
        }
        let lines: Vec<&str> = self.shown_lines.iter().map(String::as_str).collect();
        let (words, size) = text_overlay(&lines, width_px).map_err(|e| e.to_string())?;
        screen.set_overlay(Some(crate::screen::Overlay {
            words: &words,
            size,
            origin: (0, 0),
        }));
        self.overlay = Some((text, Instant::now()));
        Ok(())
    }

    /// Saves the last frame as the window showed it (read back from the
    /// GPU when it stayed there, its text lines drawn over it); `false`
    /// before the first frame.
    fn save_shown(&self, path: &Path) -> Result<bool, String> {
        let Some((f, _)) = &self.last else {
            return Ok(false);
        };
        if !f.is_on_device() {
            save_png(path, (f.width_px, f.height_px), &f.rgb).map_err(|e| e.to_string())?;
            return Ok(true);
        }
        let mut shown = self
            .renderer
            .read_last_gpu_frame()
            .map_err(|e| e.to_string())?;
        let lines: Vec<&str> = self.shown_lines.iter().map(String::as_str).collect();
        if !lines.is_empty() {
            draw_text_lines(&mut shown.rgb, (shown.width_px, shown.height_px), &lines)
                .map_err(|e| e.to_string())?;
        }
        save_png(path, (shown.width_px, shown.height_px), &shown.rgb).map_err(|e| e.to_string())?;
        Ok(true)
    }

    /// Ends the event loop, noting when it was asked to.
    fn exit(&mut self, el: &ActiveEventLoop) {
        self.stop_us.get_or_insert_with(monotonic_us);
        el.exit();
    }
}

impl ApplicationHandler for Viewer<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.screen.is_none() {
            let title = format!("gazecast — {}", self.renderer.scene().name);
            let cam = self.renderer.camera();
            let size = (cam.width_px, cam.height_px);
            match Screen::open(
                el,
                &title,
                size,
                self.opts.fullscreen,
                self.opts.monitor,
                self.opts.present_mode,
                self.renderer.gpu_device().as_ref(),
            ) {
                Ok(s) => {
                    let lines = [s.present_mode.clone(), s.how.clone()];
                    self.screen = Some(s);
                    for line in lines {
                        self.say(&line);
                    }
                }
                Err(e) => self.fail(el, e),
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match Input::from(event) {
            Input::Close => self.exit(el),
            Input::Cursor(x, y) => self.feed.cursor_moved(x, y),
            Input::Key(key) => match key.as_ref() {
                Key::Named(NamedKey::Escape) => self.exit(el),
                Key::Character("p") => {
                    let on = !self.renderer.por_overlay();
                    self.renderer.set_por_overlay(on);
                }
                Key::Character("l") => self.layers = !self.layers,
                Key::Character("h") => self.hud = !self.hud,
                Key::Character("s") => {
                    let p = Path::new("gazecast-screenshot.png");
                    let line = match self.save_shown(p) {
                        Ok(true) => format!("screenshot: {}", p.display()),
                        Ok(false) => "screenshot: no frame yet".to_string(),
                        Err(e) => format!("screenshot failed: {e}"),
                    };
                    self.say(&line);
                }
                _ => {}
            },
            Input::Redraw => {
                if crate::interrupt::interrupted() {
                    self.stop_us = crate::interrupt::interrupted_at_us().or(self.stop_us);
                    self.say("interrupted (Ctrl-C or SIGTERM): shutting down");
                    return self.exit(el);
                }
                if let Err(e) = self.frame() {
                    return self.fail(el, e);
                }
                if self.opts.frames.is_some_and(|n| self.frames >= n) {
                    return self.exit(el);
                }
                if let Some(s) = &self.screen {
                    s.window.request_redraw();
                }
            }
            Input::Other => {}
        }
    }
}

/// The scene and display the options name.
struct Loaded {
    scene: Scene,
    display: Display,
    geometry: ScreenGeometry,
    thresholds: Option<crate::args::Thresholds>,
}

impl Loaded {
    fn new(opts: &LiveOptions) -> Result<Self, String> {
        let scene = load_scene(&opts.scene)?;
        let display = config::load_display(&opts.display).map_err(|e| e.to_string())?;
        let geometry = display.geometry().map_err(|e| e.to_string())?;
        let thresholds = opts
            .thresholds
            .as_deref()
            .map(crate::args::Thresholds::load)
            .transpose()?;
        Ok(Self {
            scene,
            display,
            geometry,
            thresholds,
        })
    }

    /// The frame pipeline of the session: the scene's method and effects.
    fn renderer(&self, opts: &LiveOptions) -> Result<Renderer<'_>, String> {
        let model = crate::args::sampling_model_for(
            self.geometry,
            1.0,
            opts.gaze_tolerance_deg,
            self.thresholds.as_ref(),
        )?;
        let options = Options {
            method: opts.method,
            backend: opts.backend,
            por_overlay: opts.por_overlay,
            model_based: opts.model_based,
            // Fixations re-cast only what the cache lacks (same frames).
            reuse: true,
            ..Options::default()
        };
        let mut renderer = Renderer::new(&self.scene, Camera::new(&self.geometry), model, &options)
            .map_err(|e| e.to_string())?;
        if let Some(t) = &self.thresholds {
            t.apply(&mut renderer);
        }
        Ok(renderer)
    }
}

/// Writes the passes the session's frame pipeline would run, one a line,
/// without opening a window.
pub fn explain(opts: &LiveOptions, out: &mut dyn Write) -> Result<(), String> {
    let loaded = Loaded::new(opts)?;
    for l in loaded.renderer(opts)?.explain() {
        writeln!(out, "{l}").map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Runs a live session to its end, writing the session log to `out`.
pub fn run(opts: &LiveOptions, out: &mut dyn Write) -> Result<(), LiveError> {
    let loaded = Loaded::new(opts)?;
    let setup = GazeSetup::resolve(opts.tracker.as_deref(), opts.replay.as_deref())?;
    // The attention source: the model runs as the plan's last pass (it
    // declares the depth and object ids it reads).
    let mut renderer = loaded.renderer(opts)?;
    let attention = match &setup.tracker.driver {
        tracker_hal::Driver::Attention(a) if !setup.is_replay() => {
            let model = pipeline::frame_attention::FrameAttention::new(a.map_size)?;
            renderer.set_attention_gaze(Some(model));
            true
        }
        _ => false,
    };
    let (scene, display, geometry) = (&loaded.scene, &loaded.display, &loaded.geometry);
    let calibration = match &opts.calibration {
        Some(p) => Some(config::load_calibration(p).map_err(|e| e.to_string())?),
        None => None,
    };
    let event_loop = {
        crate::screen::close_recordings_if_the_x_server_goes();
        EventLoop::new()
    }
    .map_err(|e| LiveError::NoWindow(crate::screen::plain_error(&e)))?;
    crate::interrupt::catch_interrupts();
    let (lsl, lsl_lines) = match &opts.lsl {
        Some(o) => {
            let (outlets, lines) = crate::lsl_out::Outlets::open(o)?;
            (Some(outlets), lines)
        }
        None => (None, Vec::new()),
    };
    let header = format!(
        "gazecast view: {} on {}, gaze from {}{}",
        scene.name,
        renderer
            .adapter()
            .map_or("cpu".to_string(), |a| format!("gpu ({a})")),
        setup.name,
        opts.calibration
            .as_ref()
            .map_or(String::new(), |p| format!(" through {}", p.display()))
    );
    let feed = setup.with_screen(geometry.size_px()).spawn(
        calibration,
        opts.record.as_deref().map(|p| (p, display.name.as_str())),
    )?;
    let (plan, plan_line) = PlanLog::new(renderer.provenance());
    let mut viewer = Viewer {
        opts,
        out,
        log_error: None,
        renderer,
        plan,
        feed,
        screen: None,
        gaze: geometry.centre_px(),
        geometry: *geometry,
        attention,
        eyes_px: None,
        eye_distance_mm: None,
        gaze_host_us: None,
        clock: None,
        clock_logged_us: None,
        gaze_shown: false,
        status: String::new(),
        layers: false,
        hud: true,
        shown_lines: Vec::new(),
        overlay: None,
        frames: 0,
        fresh_frames: 0,
        new_masks: 0,
        copied_frames: 0,
        first_submit_us: None,
        latency: Latency::default(),
        last_submit_us: None,
        last: None,
        started: Instant::now(),
        error: None,
        stop_us: None,
        lsl,
        lsl_shift: crate::lsl_out::ReplayShift::new(opts.replay.is_some()),
        traffic: Vec::new(),
    };
    viewer.say(&header);
    viewer.say(&plan_line);
    for l in &lsl_lines {
        viewer.say(l);
    }
    let result = event_loop.run_app(&mut viewer);
    // Shut the tracker down and close the recording; then the last statuses.
    let recorded = viewer.feed.finish();
    viewer.drain();
    // The window may also close on its own (the event loop ended).
    let asked = viewer.stop_us.unwrap_or_else(monotonic_us);
    let took = monotonic_us().saturating_sub(asked) as f64 / 1e3;
    viewer.say(&format!("shut down {took:.0} ms after the stop request"));
    for l in viewer.feed.report() {
        viewer.say(&l);
    }
    let frames = format!(
        "{} frames, {} showed a new gaze sample",
        viewer.frames, viewer.fresh_frames
    );
    viewer.say(&frames);
    if let (Some(first), Some(last)) = (viewer.first_submit_us, viewer.last_submit_us) {
        let s = last.saturating_sub(first) as f64 / 1e6;
        let n = viewer.frames.saturating_sub(1);
        if n > 0 && s > 0.0 {
            let rate = format!(
                "{:.1} frames per second from the first frame's submit to the last's ({n} intervals in {s:.2} s); hybrid frames: {} with a new ray mask, {} the last frame copied (gaze tolerance {}°)",
                n as f64 / s,
                viewer.new_masks,
                viewer.copied_frames,
                viewer.opts.gaze_tolerance_deg
            );
            viewer.say(&rate);
        }
    }
    if let Some(line) = traffic_line(&viewer.traffic) {
        viewer.say(&line);
    }
    if let Some(s) = &viewer.screen {
        let line = presenting_line(s);
        viewer.say(&line);
    }
    if let Some((c, d)) = viewer.clock {
        let line = format!("at the end: {}", clock_line(&c, &d));
        viewer.say(&line);
    }
    for l in viewer.latency.summary() {
        viewer.say(&l);
    }
    if let Ok(Some(line)) = &recorded {
        viewer.say(line);
    }
    if let Some(o) = &viewer.lsl {
        o.linger();
        let line = o.summary();
        viewer.say(&line);
    }
    recorded?;
    if let Some(e) = viewer.error.take() {
        return Err(e.into());
    }
    result.map_err(|e| format!("window: {e}"))?;
    if let Some(path) = &opts.screenshot {
        if viewer
            .save_shown(path)
            .map_err(|e| format!("{}: {e}", path.display()))?
        {
            let line = format!("wrote {}", path.display());
            viewer.say(&line);
        }
    }
    viewer.log_error.map_or(Ok(()), |e| Err(e.into()))
}

/// How often, at most, the text over frames that stay on the GPU is
/// uploaded again when it changes.
const OVERLAY_REFRESH: std::time::Duration = std::time::Duration::from_millis(250);

/// The session summary's line on how the window presented: frames drawn
/// from the GPU's buffers (nothing read back or uploaded for them but the
/// text overlay) and frames copied from the CPU.
fn presenting_line(s: &Screen) -> String {
    let copied = format!(
        "{} B handed to write_texture in {} frames (the CPU frame copied into the window's surface)",
        s.presented_bytes, s.copied_from_cpu
    );
    if s.drawn_from_gpu == 0 {
        return format!("presenting: {copied}");
    }
    format!(
        "presenting: {} frames drawn from the GPU's buffers into the window (no read-back; {} B uploaded for the text overlay and the draw's sizes); {copied}",
        s.drawn_from_gpu, s.overlay_bytes
    )
}

/// The session summary's line on what the GPU frames moved between the
/// CPU and the GPU (counted at the `wgpu` calls, per frame: p50 and max);
/// `None` without GPU frames (the CPU backend).
pub fn traffic_line(frames: &[Traffic]) -> Option<String> {
    if frames.is_empty() {
        return None;
    }
    let p50_max = |f: &dyn Fn(&Traffic) -> u64| {
        let v: Vec<f64> = frames.iter().map(|t| f(t) as f64).collect();
        let [p50, _, _] = p50_95_99(&v);
        let max = frames.iter().map(f).max().unwrap_or(0);
        format!("p50 {p50:.0} max {max}")
    };
    Some(format!(
        "GPU traffic per frame over {} frames (counted at the wgpu calls): uploaded {} B, read back {} B, dispatches {}, submits {}",
        frames.len(),
        p50_max(&|t| t.uploaded_bytes),
        p50_max(&|t| t.read_back_bytes),
        p50_max(&|t| t.dispatches),
        p50_max(&|t| t.submits),
    ))
}

/// One log line about the tracker's clock model.
pub fn clock_line(c: &tracker_hal::ClockState, d: &tracker_hal::DeviceClock) -> String {
    format!(
        "tracker clock: {} samples, drift {:+.1} ppm{}, offset (mapped − device) {:.0} µs, newest sample delivered {:.1} ms after its mapped time; {} causality corrections, {} repeated or backwards timestamps, {} resets; device times: {}",
        c.samples,
        c.drift_ppm,
        if c.rate_clamped { " (the fit lay beyond ±500 ppm: check the tracker's nominal rate)" } else { "" },
        c.offset_us,
        c.delay_us / 1e3,
        c.corrections,
        c.non_increasing,
        c.resets,
        d.describe()
    )
}

/// Writes one log line; the first failure is kept (the session goes on).
fn emit(out: &mut dyn Write, error: &mut Option<String>, line: &str) {
    if let Err(e) = writeln!(out, "{line}") {
        error.get_or_insert(format!("writing the session log: {e}"));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary's traffic line: nothing on the CPU backend; on the GPU
    /// the median and the maximum of each figure over the frames.
    #[test]
    fn the_traffic_line_gives_p50_and_max_of_each_figure() {
        assert_eq!(traffic_line(&[]), None);
        let t = |up, down| Traffic {
            uploaded_bytes: up,
            read_back_bytes: down,
            dispatches: 7,
            draws: 0,
            submits: 1,
        };
        let line = traffic_line(&[t(128, 4000), t(330_000, 4000), t(128, 4016)]).expect("a line");
        assert!(line.contains("over 3 frames"), "{line}");
        assert!(line.contains("uploaded p50 128 max 330000 B"), "{line}");
        assert!(line.contains("read back p50 4000 max 4016 B"), "{line}");
        assert!(
            line.contains("dispatches p50 7 max 7, submits p50 1 max 1"),
            "{line}"
        );
    }

    /// A flood of samples (a 1000 Hz tracker behind a slow frame) drains to
    /// the newest valid one in one go: blinks and non-finite points keep the
    /// last valid gaze, statuses are all seen, nothing is left queued.
    #[test]
    fn draining_takes_the_newest_valid_sample_and_leaves_nothing() {
        let (tx, rx) = crossbeam_channel::unbounded();
        for k in 0..1000u64 {
            let g = [k as f64, 2.0 * k as f64];
            tx.send(TrackerMsg::Gaze {
                received_us: k + 7,
                device_us: Some(k),
                arrival_us: k + 7,
                mapped_us: k,
                time_order: tracker_hal::TimeOrder::Increasing,
                segment: 0,
                raw: Some(g),
                gaze_px: Some(g),
                eyes_px: None,
                eye_distance_mm: None,
                eyes: [tracker_hal::sample::EyeSample::MISSING; 2],
                eye_px: [None; 2],
            })
            .expect("send");
        }
        tx.send(TrackerMsg::Status("lost".into())).expect("send");
        for bad in [None, Some([f64::NAN, 1.0]), Some([1.0, f64::INFINITY])] {
            tx.send(TrackerMsg::Gaze {
                received_us: 5000,
                device_us: Some(5000),
                arrival_us: 5000,
                mapped_us: 5000,
                time_order: tracker_hal::TimeOrder::Increasing,
                segment: 0,
                raw: None,
                gaze_px: bad,
                eyes_px: None,
                eye_distance_mm: None,
                eyes: [tracker_hal::sample::EyeSample::MISSING; 2],
                eye_px: [None; 2],
            })
            .expect("send");
        }
        let mut statuses = Vec::new();
        let newest = drain_newest(&rx, |s| statuses.push(s), |_, _| {});
        assert_eq!(
            newest,
            Some(Newest {
                gaze_px: [999.0, 1998.0],
                host_us: 999,
                eyes_px: None,
                eye_distance_mm: None,
            })
        );
        assert_eq!(statuses, vec!["lost".to_string()]);
        assert!(rx.is_empty());
        assert_eq!(drain_newest(&rx, |_| {}, |_, _| {}), None);
    }

    /// The session log names the plan at the start and again whenever it
    /// changes: `P` adds the POR box pass, and takes it away.
    #[test]
    fn the_log_names_the_plan_at_the_start_and_at_each_change() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let opts = LiveOptions {
            scene: root.join("config/scenes/search-task.ron"),
            display: root.join("config/displays/tobii-et1750-17in.ron"),
            backend: BackendChoice::Cpu,
            method: pipeline::Method::Image,
            gaze_tolerance_deg: 0.5,
            ..LiveOptions::default()
        };
        let loaded = Loaded::new(&opts).expect("scene and display");
        let mut renderer = loaded.renderer(&opts).expect("renderer");
        let (mut log, line) = PlanLog::new(renderer.provenance());
        assert_eq!(
            line,
            "plan: image on cpu; passes: image-based foveation (cpu)"
        );
        assert_eq!(log.frame(renderer.provenance()), None);
        renderer.set_por_overlay(true);
        assert_eq!(
            log.frame(renderer.provenance()).as_deref(),
            Some("plan changed: image on cpu; passes: image-based foveation (cpu) → POR box (cpu)")
        );
        assert_eq!(
            log.current(),
            "image on cpu; passes: image-based foveation (cpu) → POR box (cpu)"
        );
        assert_eq!(log.frame(renderer.provenance()), None);
        renderer.set_por_overlay(false);
        assert_eq!(
            log.frame(renderer.provenance()).as_deref(),
            Some("plan changed: image on cpu; passes: image-based foveation (cpu)")
        );
    }

    #[test]
    fn latency_percentiles_and_an_empty_session() {
        let mut l = Latency::default();
        assert!(l.summary()[0].contains("no gaze sample arrived"));
        for k in 1..=100 {
            let a = f64::from(k);
            l.latch.push(0.5);
            l.submit.push(a);
            l.present.push(a + 1.0);
            l.interval.push(a - 0.5);
            l.excess.push(0.5);
        }
        let s = l.summary().join("\n");
        assert!(
            s.contains("gaze age at submit p50 51.0 ms, p95 95.0 ms, p99 99.0 ms"),
            "{s}"
        );
        assert!(
            s.contains("(age at submit − frame interval) p50 0.5 ms"),
            "{s}"
        );
    }
}
