//! `gazecast view`: the live gaze-contingent loop in a window.
//!
//! Threads: a tracker thread runs the driver (a replayed recording at its
//! original pacing, the mouse emulator fed by the window's cursor, an ISCAN
//! on its serial port or a HID tracker) and sends samples over a
//! `crossbeam-channel`; the window thread drains the channel to the newest
//! sample each frame (never an old gaze, never waiting for the tracker),
//! renders foveated (CPU or GPU core), and presents by copying the frame into
//! the window's surface (wgpu). Invalid samples (blinks) keep the last valid
//! gaze; a tracker that fails is reopened with backoff while rendering goes
//! on with a status line. Closing the window or the frame limit ends it.
//!
//! Keys: `P` POR box, `L` layers view, `H` HUD, `S` screenshot (to
//! `gazecast-screenshot.png`), `Esc` quit.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use foveation::SamplingModel;
use raycast::gpu::GpuRenderer;
use raycast::render::{layers_rgb, render, Frame, Settings, Stats, Triggers};
use raycast::{Camera, Scene};
use tracker_hal::clock::monotonic_us;
use tracker_hal::mouse::{spawn_device, CursorEvent};
use tracker_hal::{
    Driver, ErrorKind, GazeSource, MonotonicClock, Pacing, Recording, ReplayTransport,
    StreamDriver, TrackerConfig,
};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::config;
use crate::render_cmd::{draw_por_box, load_scene, Backend};

#[derive(Debug, Clone, clap::Args)]
pub struct ViewArgs {
    #[arg(long, value_name = "FILE")]
    pub scene: PathBuf,
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Tracker file (RON). Not needed with --replay (the recording's header
    /// carries it).
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: Option<PathBuf>,
    /// Play a tracker-hal recording at its original pacing as the gaze.
    #[arg(long, value_name = "FILE.gzrec")]
    pub replay: Option<PathBuf>,
    /// Exit after this many frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
    /// Write the last frame (with overlays) here on exit.
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// Force the POR box on.
    #[arg(long, value_name = "por")]
    pub overlay: Option<String>,
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
    /// Fullscreen on the current monitor.
    #[arg(long)]
    pub fullscreen: bool,
    /// Print the passes the scene's effects make the pipeline run, and exit.
    #[arg(long)]
    pub explain: bool,
}

/// The passes a scene's effect list makes the pipeline run (and what it
/// leaves out), as `--explain` prints them.
pub fn explain(scene: &Scene, overlay: bool) -> Vec<String> {
    use raycast::scene::Effect;
    let mut out = vec![format!("scene {}: effects {:?}", scene.name, scene.effects)];
    if scene.has(Effect::FoveatedSampling) {
        let t = Triggers::from_scene(scene);
        out.push("per gaze (CPU): ray mask and pixel ownership, uploaded to the GPU core".into());
        let stages: Vec<&str> = raycast::gpu::foveated_stages(&t)
            .iter()
            .map(|&k| raycast::gpu::FOVEATED_STAGES[k])
            .collect();
        out.push(format!("per frame: {}", stages.join(" → ")));
        let mut triggers = Vec::new();
        if t.silhouette {
            triggers.push("silhouette (+ one-cell margin)".to_string());
        }
        if let Some(d) = t.crease_deg {
            triggers.push(format!("crease > {d}°"));
        }
        if let Some(j) = t.depth_jump {
            triggers.push(format!("depth jump > {:.0} %", 100.0 * j));
        }
        out.push(format!(
            "refinement triggers: {}",
            if triggers.is_empty() {
                "none (no cell is classified or refined)".to_string()
            } else {
                triggers.join(", ")
            }
        ));
    } else {
        out.push("per frame: cast and shade every pixel (FoveatedSampling is not in the scene's effects: no mask, no foveated buffers)".into());
    }
    out.push(format!(
        "overlay: {}",
        if overlay {
            "POR box"
        } else {
            "none (P toggles the POR box)"
        }
    ));
    out
}

/// What the tracker thread tells the window.
#[derive(Debug, Clone)]
pub enum TrackerMsg {
    /// A sample: host arrival (µs, monotonic) and the gaze in screen pixels
    /// (`None`: invalid, e.g. a blink).
    Gaze {
        host_us: u64,
        gaze_px: Option<[f64; 2]>,
    },
    /// A status line (disconnect, reconnect, end of recording).
    Status(String),
}

type Source = Box<dyn GazeSource + Send>;

/// Opens the configured tracker (again, after a failure).
type Opener = Box<dyn FnMut() -> Result<Source, String> + Send>;

/// Runs a tracker until `stop`: samples to `tx`, reopening with backoff
/// (0.25 s doubling to 4 s) when the device fails; a replay ends at its end.
pub fn tracker_thread(
    mut open: Opener,
    map: Box<dyn Fn([f64; 2]) -> [f64; 2] + Send>,
    tx: Sender<TrackerMsg>,
    stop: Arc<AtomicBool>,
    ends: bool,
) {
    let mut backoff = Duration::from_millis(250);
    while !stop.load(Ordering::Relaxed) {
        let mut source = match open() {
            Ok(s) => s,
            Err(e) => {
                let _ = tx.send(TrackerMsg::Status(format!(
                    "tracker: {e}; retrying in {:.2} s",
                    backoff.as_secs_f64()
                )));
                std::thread::sleep(backoff);
                backoff = (backoff * 2).min(Duration::from_secs(4));
                continue;
            }
        };
        if let Err(e) = source.start() {
            let _ = tx.send(TrackerMsg::Status(format!("tracker: {e}")));
        }
        let _ = tx.send(TrackerMsg::Status(String::new()));
        backoff = Duration::from_millis(250);
        while !stop.load(Ordering::Relaxed) {
            match source.next_sample() {
                Ok(Some(s)) => {
                    let _ = tx.send(TrackerMsg::Gaze {
                        host_us: monotonic_us(),
                        gaze_px: s.gaze().map(&map),
                    });
                }
                Ok(None) => {
                    let _ = tx.send(TrackerMsg::Status(
                        "tracker: end of stream; keeping the last gaze".into(),
                    ));
                    if ends {
                        return;
                    }
                    break;
                }
                Err(e) if e.kind == ErrorKind::TimedOut => {}
                Err(e) => {
                    let _ = tx.send(TrackerMsg::Status(format!(
                        "tracker: {e}; keeping the last gaze, reconnecting"
                    )));
                    break;
                }
            }
        }
        let _ = source.stop();
    }
}

/// The gaze source the arguments describe, with its mapping to pixels.
#[allow(clippy::type_complexity)]
fn tracker_source(
    args: &ViewArgs,
    cursor_rx: Receiver<CursorEvent>,
) -> Result<
    (
        Opener,
        Box<dyn Fn([f64; 2]) -> [f64; 2] + Send>,
        bool,
        String,
    ),
    String,
> {
    if let Some(path) = &args.replay {
        let rec = Recording::read(path).map_err(|e| e.to_string())?;
        let tracker = rec.header.tracker.clone();
        let (frame, mapping) = (tracker.frame(), tracker.mapping.clone());
        let mut once = Some(rec);
        let open: Opener = Box::new(move || {
            let rec = once.take().ok_or("the recording has been played")?;
            let t = ReplayTransport::from_recording(&rec, Pacing::RealTime);
            let clock = t.clock();
            Ok(Box::new(StreamDriver::new(t, tracker.decoder(), Box::new(clock))) as Source)
        });
        let map = Box::new(move |p| mapping.to_screen(p, frame));
        return Ok((open, map, true, format!("replay of {}", path.display())));
    }
    let Some(path) = &args.tracker else {
        return Err(
            "give --tracker FILE.ron (config/trackers/mouse.ron for the mouse) or --replay FILE"
                .into(),
        );
    };
    let tracker: TrackerConfig = config::load_tracker(path).map_err(|e| e.to_string())?;
    let (frame, mapping) = (tracker.frame(), tracker.mapping.clone());
    let map = Box::new(move |p| mapping.to_screen(p, frame));
    let name = format!("{} ({})", tracker.driver_name(), path.display());
    let open: Opener = match tracker.driver.clone() {
        Driver::Mouse(c) => {
            let mut cursor = Some(cursor_rx);
            Box::new(move || {
                let rx = cursor.take().ok_or("the mouse device has stopped")?;
                let link = spawn_device(c.clone(), rx).map_err(|e| e.to_string())?;
                Ok(Box::new(StreamDriver::new(
                    link,
                    tracker_hal::mouse::MouseDecoder::new(),
                    Box::new(MonotonicClock),
                )) as Source)
            })
        }
        Driver::Iscan(c) => {
            let tracker = tracker.clone();
            Box::new(move || {
                let name = c
                    .port
                    .clone()
                    .ok_or("the ISCAN tracker file has no `port`")?;
                let port = tracker_hal::serial::open(&name, c.baud, Duration::from_millis(250))
                    .map_err(|e| e.to_string())?;
                Ok(Box::new(StreamDriver::new(
                    port,
                    tracker.decoder(),
                    Box::new(MonotonicClock),
                )) as Source)
            })
        }
        Driver::TobiiHid(c) => Box::new(move || {
            let t = tracker_hal::hid::driver::hidapi_transport::HidApiTransport::open(&c)
                .map_err(|e| e.to_string())?;
            Ok(Box::new(tracker_hal::hid::driver::HidDriver::new(
                t,
                c.clone(),
                Box::new(MonotonicClock),
            )) as Source)
        }),
    };
    Ok((open, map, false, name))
}

/// Percentile (nearest rank) of sorted values.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let k = ((p / 100.0) * (sorted.len() - 1) as f64).round() as usize;
    sorted[k.min(sorted.len() - 1)]
}

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    bgra: bool,
}

struct Viewer<'a> {
    args: &'a ViewArgs,
    scene: Scene,
    cam: Camera,
    model: SamplingModel,
    settings: Settings,
    gpu: Option<GpuRenderer>,
    rx: Receiver<TrackerMsg>,
    cursor_tx: Option<Sender<CursorEvent>>,
    gfx: Option<Gfx>,
    gaze: [f64; 2],
    gaze_host_us: Option<u64>,
    status: String,
    por: bool,
    layers: bool,
    hud: bool,
    frames: u64,
    ages_ms: Vec<f64>,
    last: Option<(Frame, Stats)>,
    started: Instant,
    log: Vec<String>,
    error: Option<String>,
}

impl Viewer<'_> {
    fn create(&mut self, el: &ActiveEventLoop) -> Result<(), String> {
        let (w, h) = (self.cam.width_px, self.cam.height_px);
        let mut attrs = Window::default_attributes()
            .with_title(format!("gazecast — {}", self.scene.name))
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h))
            .with_resizable(false);
        if self.args.fullscreen {
            attrs = attrs.with_fullscreen(Some(winit::window::Fullscreen::Borderless(None)));
        }
        let window = Arc::new(
            el.create_window(attrs)
                .map_err(|e| format!("window: {e}"))?,
        );
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| format!("window surface: {e}"))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| format!("no adapter can present to the window: {e}"))?;
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))
                .map_err(|e| format!("device: {e}"))?;
        let caps = surface.get_capabilities(&adapter);
        if !caps.usages.contains(wgpu::TextureUsages::COPY_DST) {
            return Err("the window surface cannot be copied into (no COPY_DST)".into());
        }
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or("the window surface is not supported by the adapter")?;
        // Plain 8-bit formats: the frame's bytes are already gamma-encoded.
        let format = [
            wgpu::TextureFormat::Bgra8Unorm,
            wgpu::TextureFormat::Rgba8Unorm,
        ]
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .ok_or("the window surface has no plain 8-bit RGBA/BGRA format")?;
        config.format = format;
        config.usage = wgpu::TextureUsages::COPY_DST;
        config.present_mode = wgpu::PresentMode::Fifo;
        surface.configure(&device, &config);
        self.gfx = Some(Gfx {
            window,
            surface,
            device,
            queue,
            config,
            bgra: format == wgpu::TextureFormat::Bgra8Unorm,
        });
        Ok(())
    }

    fn drain(&mut self) {
        for m in self.rx.try_iter() {
            match m {
                TrackerMsg::Gaze { host_us, gaze_px } => {
                    // Invalid samples keep the last valid gaze.
                    if let Some(g) = gaze_px.filter(|g| g[0].is_finite() && g[1].is_finite()) {
                        self.gaze = g;
                        self.gaze_host_us = Some(host_us);
                    }
                }
                TrackerMsg::Status(s) => {
                    if !s.is_empty() {
                        self.log.push(s.clone());
                    }
                    self.status = s;
                }
            }
        }
    }

    fn frame(&mut self) -> Result<(), String> {
        self.drain();
        let gaze = self.gaze;
        let (mut frame, stats) = match self.gpu.as_mut() {
            Some(g) => {
                let mask = foveation::mask::build(&self.model, self.settings.layout, gaze)
                    .map_err(|e| e.to_string())?;
                g.render_foveated(&self.cam, &mask, &self.settings.triggers)
                    .map_err(|e| e.to_string())?
            }
            None => render(&self.scene, &self.cam, &self.model, &self.settings, gaze)
                .map_err(|e| e.to_string())?,
        };
        if self.layers {
            frame.rgb = layers_rgb(&frame);
        }
        if self.por {
            draw_por_box(&mut frame.rgb, frame.width, frame.height, gaze);
        }
        let submit_us = monotonic_us();
        let age_ms = self
            .gaze_host_us
            .map(|t| submit_us.saturating_sub(t) as f64 / 1e3);
        if let Some(a) = age_ms {
            self.ages_ms.push(a);
        }
        if self.hud || !self.status.is_empty() {
            let mut sorted = self.ages_ms.clone();
            sorted.sort_by(f64::total_cmp);
            let fps = self.frames as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
            let hud = format!(
                "{:.1} fps  {} rays  gaze age p50 {:.1} p95 {:.1} p99 {:.1} ms",
                fps,
                stats.rays_total,
                percentile(&sorted, 50.0),
                percentile(&sorted, 95.0),
                percentile(&sorted, 99.0)
            );
            let lines: Vec<&str> = [self.hud.then_some(hud.as_str()), Some(self.status.as_str())]
                .into_iter()
                .flatten()
                .filter(|l| !l.is_empty())
                .collect();
            crate::plots::draw_text_lines(&mut frame.rgb, (frame.width, frame.height), &lines)
                .map_err(|e| e.to_string())?;
        }
        self.present(&frame)?;
        self.log.push(format!(
            "frame {} gaze ({:.1}, {:.1}) age {} ms rays {} render {:.1} ms",
            self.frames,
            gaze[0],
            gaze[1],
            age_ms.map_or("-".into(), |a| format!("{a:.1}")),
            stats.rays_total,
            stats.time_ms
        ));
        self.frames += 1;
        self.last = Some((frame, stats));
        Ok(())
    }

    fn present(&mut self, frame: &Frame) -> Result<(), String> {
        let Some(g) = &self.gfx else { return Ok(()) };
        let tex = match g.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                g.surface.configure(&g.device, &g.config);
                return Ok(());
            }
            _ => return Ok(()), // timeout or occluded: skip this present
        };
        let (w, h) = (
            frame.width.min(g.config.width),
            frame.height.min(g.config.height),
        );
        let mut rgba = Vec::with_capacity(4 * (w * h) as usize);
        for y in 0..h as usize {
            for x in 0..w as usize {
                let i = 3 * (y * frame.width as usize + x);
                let (r, gg, b) = (frame.rgb[i], frame.rgb[i + 1], frame.rgb[i + 2]);
                if g.bgra {
                    rgba.extend_from_slice(&[b, gg, r, 255]);
                } else {
                    rgba.extend_from_slice(&[r, gg, b, 255]);
                }
            }
        }
        g.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &rgba,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * w),
                rows_per_image: Some(h),
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        g.queue.submit([]);
        g.window.pre_present_notify();
        g.queue.present(tex);
        Ok(())
    }

    fn fail(&mut self, el: &ActiveEventLoop, e: String) {
        self.error = Some(e);
        el.exit();
    }
}

impl ApplicationHandler for Viewer<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.gfx.is_none() {
            if let Err(e) = self.create(el) {
                self.fail(el, e);
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::CursorMoved { position, .. } => {
                if let Some(tx) = &self.cursor_tx {
                    let _ = tx.send(CursorEvent {
                        t_us: monotonic_us(),
                        position_px: [position.x, position.y],
                        blink: false,
                    });
                }
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key,
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => match logical_key.as_ref() {
                Key::Named(NamedKey::Escape) => el.exit(),
                Key::Character("p") => self.por = !self.por,
                Key::Character("l") => self.layers = !self.layers,
                Key::Character("h") => self.hud = !self.hud,
                Key::Character("s") => {
                    if let Some((f, _)) = &self.last {
                        let p = Path::new("gazecast-screenshot.png");
                        match crate::plots::save_png(p, (f.width, f.height), &f.rgb) {
                            Ok(()) => self.log.push(format!("screenshot: {}", p.display())),
                            Err(e) => self.log.push(format!("screenshot failed: {e}")),
                        }
                    }
                }
                _ => {}
            },
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame() {
                    return self.fail(el, e);
                }
                if self.args.frames.is_some_and(|n| self.frames >= n) {
                    return el.exit();
                }
                if let Some(g) = &self.gfx {
                    g.window.request_redraw();
                }
            }
            _ => {}
        }
    }
}

/// Runs `gazecast view`.
pub fn run(args: &ViewArgs, out: &mut dyn Write) -> Result<(), String> {
    if let Some(o) = &args.overlay {
        if o != "por" {
            return Err(format!("--overlay {o}: the only overlay is `por`"));
        }
    }
    let scene = load_scene(&args.scene)?;
    if args.explain {
        let overlay = args.overlay.is_some() || scene.has(raycast::scene::Effect::PorOverlay);
        for l in explain(&scene, overlay) {
            writeln!(out, "{l}").map_err(|e| e.to_string())?;
        }
        return Ok(());
    }
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let model = crate::render_cmd::sampling_model(geometry, 1.0).map_err(|e| e.to_string())?;
    let (cursor_tx, cursor_rx) = crossbeam_channel::unbounded();
    let (open, map, ends, source_name) = tracker_source(args, cursor_rx)?;
    let gpu = match args.backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(GpuRenderer::new(&scene).map_err(|e| format!("--backend gpu: {e}"))?),
        Backend::Auto => match raycast::gpu::probe() {
            Ok((_, false)) => GpuRenderer::new(&scene).ok(),
            _ => None,
        },
    };
    let (tx, rx) = crossbeam_channel::unbounded();
    let stop = Arc::new(AtomicBool::new(false));
    let tracker = {
        let stop = stop.clone();
        std::thread::Builder::new()
            .name("tracker".into())
            .spawn(move || tracker_thread(open, map, tx, stop, ends))
            .map_err(|e| e.to_string())?
    };
    let event_loop = EventLoop::new().map_err(|e| {
        format!("cannot open a window ({e}); on a machine without a display use `gazecast demo` or run under Xvfb")
    })?;
    let mut viewer = Viewer {
        args,
        settings: crate::render_cmd::foveated_settings(&scene),
        cam: Camera::new(&geometry),
        scene,
        model,
        gpu,
        rx,
        cursor_tx: Some(cursor_tx),
        gfx: None,
        gaze: geometry.centre_px(),
        gaze_host_us: None,
        status: String::new(),
        por: args.overlay.is_some(),
        layers: false,
        hud: true,
        frames: 0,
        ages_ms: Vec::new(),
        last: None,
        started: Instant::now(),
        log: Vec::new(),
        error: None,
    };
    viewer.por |= viewer.scene.has(raycast::scene::Effect::PorOverlay);
    let result = event_loop.run_app(&mut viewer);
    // Shut the tracker down: the flag, and the mouse device's cursor channel.
    stop.store(true, Ordering::Relaxed);
    viewer.cursor_tx = None;
    let _ = tracker.join();
    viewer.drain();
    let w = |out: &mut dyn Write, s: &str| writeln!(out, "{s}").map_err(|e| e.to_string());
    w(
        out,
        &format!(
            "gazecast view: {} on {}, gaze from {}",
            viewer.scene.name,
            viewer
                .gpu
                .as_ref()
                .map_or("cpu".to_string(), |g| format!("gpu ({})", g.adapter())),
            source_name
        ),
    )?;
    for l in &viewer.log {
        w(out, l)?;
    }
    let mut sorted = viewer.ages_ms.clone();
    sorted.sort_by(f64::total_cmp);
    let ages = if sorted.is_empty() {
        "no gaze sample arrived".to_string()
    } else {
        format!(
            "gaze age at submit p50 {:.1} ms, p95 {:.1} ms, p99 {:.1} ms",
            percentile(&sorted, 50.0),
            percentile(&sorted, 95.0),
            percentile(&sorted, 99.0)
        )
    };
    w(out, &format!("{} frames; {ages}", viewer.frames))?;
    if let Some(e) = viewer.error {
        return Err(e);
    }
    result.map_err(|e| format!("window: {e}"))?;
    if let (Some(path), Some((f, _))) = (&args.screenshot, &viewer.last) {
        crate::plots::save_png(path, (f.width, f.height), &f.rgb)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        w(out, &format!("wrote {}", path.display()))?;
    }
    Ok(())
}
