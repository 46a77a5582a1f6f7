//! A window with a `wgpu` surface that shows frames rendered elsewhere.
//!
//! - A frame on the CPU (the CPU renderer, a GPU frame read back, the
//!   calibration and experiment screens) is copied into the surface
//!   texture ([`Screen::present`]), which is a plain 8-bit RGBA/BGRA format
//!   because the bytes are already gamma-encoded.
//! - A frame that stayed on the GPU is drawn into the surface texture by a
//!   render pass on the renderer's own device ([`Screen::present_gpu`],
//!   `present.rs`): nothing is read back or uploaded but the HUD's overlay
//!   when its text changes. That needs the surface to be made on the
//!   renderer's device ([`Screen::open`] with its [`SharedDevice`]).

mod present;

pub use present::{Overlay, OverlayBuf};

use std::sync::Arc;

use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::Key;
use winit::window::Window;

use raycast::gpu::SharedDevice;

/// Makes a lost X server close the open recordings before the process
/// ends. Xlib ends the process itself when its connection breaks (the
/// server was killed, a remote session dropped): no destructor runs, so a
/// recording would be left without its end chunk. The handler closes
/// every open recording ([`crate::gaze_feed::close_recordings_now`]),
/// says so on stderr and exits with status 1. Called before a window
/// opens; harmless where there is no Xlib (Wayland, no display).
pub fn close_recordings_if_the_x_server_goes() {
    #[cfg(target_os = "linux")]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            if let Ok(xlib) = x11_dl::xlib::Xlib::open() {
                // SAFETY: a plain C function pointer with Xlib's signature;
                // the handler is process-wide state of libX11, which
                // winit's own load of the library shares.
                // (x11-dl never unloads the library, so the handler stays.)
                unsafe { (xlib.XSetIOErrorHandler)(Some(on_x_io_error)) };
            }
        });
    }
}

#[cfg(target_os = "linux")]
unsafe extern "C" fn on_x_io_error(_display: *mut x11_dl::xlib::Display) -> std::os::raw::c_int {
    let closed = crate::gaze_feed::close_recordings_now(std::time::Duration::from_secs(2));
    use std::io::Write;
    let _ = std::io::stdout().flush();
    eprintln!(
        "gazecast: the connection to the X server was lost; closed {closed} open recording(s)"
    );
    // Xlib's contract: the handler must not return.
    std::process::exit(1)
}

/// What a window event means to gazecast's windows.
pub enum Input {
    /// The window was asked to close.
    Close,
    /// The cursor, in window pixels.
    Cursor(f64, f64),
    /// A key pressed (not released, not repeated).
    Key(Key),
    /// The window needs drawing.
    Redraw,
    /// Anything else.
    Other,
}

impl From<WindowEvent> for Input {
    fn from(event: WindowEvent) -> Self {
        match event {
            WindowEvent::CloseRequested => Input::Close,
            WindowEvent::CursorMoved { position, .. } => Input::Cursor(position.x, position.y),
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key,
                        state: ElementState::Pressed,
                        repeat: false,
                        ..
                    },
                ..
            } => Input::Key(logical_key),
            WindowEvent::RedrawRequested => Input::Redraw,
            _ => Input::Other,
        }
    }
}

/// A windowing error as a person reads it: winit's "os error at
/// SOURCE.rs:LINE: " prefix (the library's own source file) is removed.
pub fn plain_error(e: &dyn std::fmt::Display) -> String {
    let text = e.to_string();
    let mut out = String::with_capacity(text.len());
    let mut rest = text.as_str();
    while let Some(i) = rest.find("os error at ") {
        let after = &rest[i + "os error at ".len()..];
        // The location ends at ".rs:" + digits + ": ".
        let cut = after.find(".rs:").and_then(|j| {
            let tail = &after[j + 4..];
            let digits = tail.len() - tail.trim_start_matches(|c: char| c.is_ascii_digit()).len();
            tail[digits..]
                .starts_with(": ")
                .then_some(j + 4 + digits + 2)
        });
        match cut {
            Some(k) => {
                out.push_str(&rest[..i]);
                rest = &after[k..];
            }
            None => {
                out.push_str(&rest[..i + "os error at ".len()]);
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// How the window presents its frames (`view --present-mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum PresentChoice {
    /// The lowest latency without tearing: Mailbox (the newest frame
    /// replaces a waiting one at the next refresh) where the adapter
    /// offers it, FIFO (vsync) otherwise. Immediate is never picked
    /// automatically: it tears, which a stimulus display must not.
    #[default]
    Auto,
    /// FIFO: every frame waits for its refresh (vsync); what the
    /// experiment uses, whose onsets are tied to the refresh.
    Fifo,
    /// Mailbox, or an error naming what the adapter offers.
    Mailbox,
    /// Immediate (no wait, tears), or an error naming what the adapter
    /// offers.
    Immediate,
}

/// Picks the present mode for `choice` among the adapter's `offered`
/// ones: the mode and why, or an error naming what is offered.
pub fn pick_present_mode(
    choice: PresentChoice,
    offered: &[wgpu::PresentMode],
) -> Result<(wgpu::PresentMode, String), String> {
    use wgpu::PresentMode as M;
    let list = offered
        .iter()
        .map(|m| format!("{m:?}"))
        .collect::<Vec<_>>()
        .join(", ");
    let has = |m: M| offered.contains(&m);
    let (mode, why) = match choice {
        PresentChoice::Auto if has(M::Mailbox) => {
            (M::Mailbox, "auto: the lowest latency without tearing")
        }
        // Every adapter offers FIFO (WebGPU requires it).
        PresentChoice::Auto => (M::Fifo, "auto: no Mailbox offered, so vsync"),
        PresentChoice::Fifo => (M::Fifo, "asked"),
        PresentChoice::Mailbox if has(M::Mailbox) => (M::Mailbox, "asked"),
        PresentChoice::Immediate if has(M::Immediate) => (M::Immediate, "asked; it may tear"),
        PresentChoice::Mailbox | PresentChoice::Immediate => {
            return Err(format!(
                "--present-mode {}: the window's adapter offers {list}",
                format!("{choice:?}").to_lowercase()
            ))
        }
    };
    Ok((
        mode,
        format!("present mode {mode:?} ({why}; the adapter offers {list})"),
    ))
}

/// A window and its surface on a wgpu device: where gazecast's windows present their frames.
pub struct Screen {
    /// The window.
    pub window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    bgra: bool,
    /// The frame in the surface's byte order, reused from frame to frame.
    staging: Vec<u8>,
    /// Bytes handed to `write_texture` by every [`Screen::present`] so far
    /// (the CPU frame into the surface texture; issue 35 wants it gone on
    /// the GPU backend).
    pub presented_bytes: u64,
    /// The present mode in use and why ([`pick_present_mode`]).
    pub present_mode: String,
    /// Draws frames that stayed on the GPU: made when the surface is on
    /// the renderer's device.
    gpu: Option<present::GpuPresent>,
    /// Frames drawn from the GPU ([`Screen::present_gpu`]) and copied from
    /// the CPU ([`Screen::present`]) so far.
    pub drawn_from_gpu: u64,
    /// Frames copied from the CPU.
    pub copied_from_cpu: u64,
    /// Bytes uploaded for frames drawn from the GPU: the HUD's overlay
    /// when its text changed, the draw's uniform when the sizes changed.
    pub overlay_bytes: u64,
    /// How the window presents, in a line: on the renderer's device or by
    /// copies, and why.
    pub how: String,
}

impl Screen {
    /// Opens a `w × h` window — fullscreen on monitor `monitor` (0-based,
    /// in the platform's order) or on the current one when asked — and
    /// configures its surface for copies, presenting as `present` asks.
    /// With `shared` (a GPU renderer's device) the surface is made on that
    /// device where its adapter can present to the window, and frames that
    /// stay on the GPU can be drawn ([`Screen::presents_from_gpu`]);
    /// otherwise the window has a device of its own.
    pub fn open(
        el: &ActiveEventLoop,
        title: &str,
        (w, h): (u32, u32),
        fullscreen: bool,
        monitor: Option<usize>,
        present: PresentChoice,
        shared: Option<&SharedDevice>,
    ) -> Result<Self, String> {
        let mut attrs = Window::default_attributes()
            .with_title(title)
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h))
            .with_resizable(false);
        let on = match monitor {
            Some(i) => {
                let all: Vec<_> = el.available_monitors().collect();
                let names: Vec<String> = all
                    .iter()
                    .enumerate()
                    .map(|(k, m)| {
                        let s = m.size();
                        format!(
                            "{k}: {} {}×{}",
                            m.name().unwrap_or_default(),
                            s.width,
                            s.height
                        )
                    })
                    .collect();
                let m = all.get(i).cloned().ok_or_else(|| {
                    format!(
                        "--monitor {i}: this display has {} monitors ({})",
                        all.len(),
                        names.join(", ")
                    )
                })?;
                let s = m.size();
                if (s.width, s.height) != (w, h) {
                    eprintln!(
                        "gazecast: monitor {i} is {}×{} px, the display file says {w}×{h}: the frame is drawn at the file's size from the top left",
                        s.width, s.height
                    );
                }
                Some(Some(m))
            }
            None => fullscreen.then_some(None),
        };
        if let Some(m) = on {
            attrs = attrs.with_fullscreen(Some(winit::window::Fullscreen::Borderless(m)));
        }
        let window = Arc::new(
            el.create_window(attrs)
                .map_err(|e| format!("window: {}", plain_error(&e)))?,
        );
        // The renderer's device where its adapter can present to this
        // window; else a device of the window's own.
        let on_shared = shared.and_then(|d| {
            let surface = d.instance.create_surface(window.clone()).ok()?;
            d.adapter.is_surface_supported(&surface).then(|| {
                (
                    surface,
                    d.adapter.clone(),
                    d.device.clone(),
                    d.queue.clone(),
                )
            })
        });
        let shared_refused = shared.is_some() && on_shared.is_none();
        let (surface, adapter, device, queue) = match on_shared {
            Some(s) => s,
            None => {
                let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
                desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
                let instance = wgpu::Instance::new(desc);
                let surface = instance
                    .create_surface(window.clone())
                    .map_err(|e| format!("window surface: {e}"))?;
                let adapter =
                    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                        power_preference: wgpu::PowerPreference::HighPerformance,
                        compatible_surface: Some(&surface),
                        ..Default::default()
                    }))
                    .map_err(|e| format!("no adapter can present to the window: {e}"))?;
                let (device, queue) =
                    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))
                        .map_err(|e| format!("device: {e}"))?;
                (surface, adapter, device, queue)
            }
        };
        let caps = surface.get_capabilities(&adapter);
        if !caps.usages.contains(wgpu::TextureUsages::COPY_DST) {
            return Err("the window surface cannot be copied into (no COPY_DST)".into());
        }
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or("the window surface is not supported by the adapter")?;
        let format = [
            wgpu::TextureFormat::Bgra8Unorm,
            wgpu::TextureFormat::Rgba8Unorm,
        ]
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .ok_or("the window surface has no plain 8-bit RGBA/BGRA format")?;
        config.format = format;
        // Frames on the GPU are drawn into the surface: a render target.
        let draws = shared.is_some()
            && !shared_refused
            && caps.usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT);
        config.usage = if draws {
            wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::RENDER_ATTACHMENT
        } else {
            wgpu::TextureUsages::COPY_DST
        };
        let (mode, present_mode) = pick_present_mode(present, &caps.present_modes)?;
        config.present_mode = mode;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        surface.configure(&device, &config);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!("the window surface cannot be configured: {e}"));
        }
        let how = match (shared.is_some(), shared_refused, draws) {
            (false, ..) => "presenting by copies: the window has a device of its own".to_string(),
            (true, true, _) => "presenting by copies: the renderer's GPU cannot present to this window, so the window has a device of its own".to_string(),
            (true, false, false) => "presenting by copies: the window's surface cannot be a render target".to_string(),
            (true, false, true) => "presenting on the renderer's GPU: frames that stay there are drawn into the window without a read-back".to_string(),
        };
        Ok(Self {
            window,
            surface,
            gpu: draws.then(|| present::GpuPresent::new(&device, format)),
            device,
            queue,
            config,
            bgra: format == wgpu::TextureFormat::Bgra8Unorm,
            staging: Vec::new(),
            presented_bytes: 0,
            present_mode,
            drawn_from_gpu: 0,
            copied_from_cpu: 0,
            overlay_bytes: 0,
            how,
        })
    }

    /// Whether frames that stayed on the GPU can be drawn
    /// ([`Screen::present_gpu`]): the surface is on the renderer's device.
    pub fn presents_from_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    /// Replaces the overlay drawn over frames from the GPU (the HUD, the
    /// experiment's reference object; `None`: none). Call it only when the
    /// overlay changes: it uploads.
    pub fn set_overlay(&mut self, overlay: Option<Overlay<'_>>) {
        if let Some(g) = &mut self.gpu {
            self.overlay_bytes += g.set_overlay(&self.device, &self.queue, overlay);
        }
    }

    /// Draws the `w × h` frame whose pixel words (`pack`) are in `pixels`,
    /// on this window's device, into `tex`, with the overlay; submits and
    /// presents; returns the host time (µs) of the submit, or `None` (and
    /// presents nothing) when the window does not draw from the GPU.
    pub fn present_gpu(
        &mut self,
        tex: wgpu::SurfaceTexture,
        pixels: &wgpu::Buffer,
        size: (u32, u32),
    ) -> Option<u64> {
        let g = self.gpu.as_mut()?;
        let view = tex
            .texture
            .create_view(&wgpu::TextureViewDescriptor::default());
        let (commands, uploaded) = g.encode(&self.device, &self.queue, &view, pixels, size);
        self.overlay_bytes += uploaded;
        self.queue.submit([commands]);
        let submitted = tracker_hal::clock::monotonic_us();
        self.window.pre_present_notify();
        self.queue.present(tex);
        self.drawn_from_gpu += 1;
        Some(submitted)
    }

    /// The next surface texture (this is where FIFO waits for the display);
    /// `None` when this frame cannot be shown (surface lost and
    /// reconfigured, timeout, occluded) — skip the present, not the frame.
    pub fn acquire(&self) -> Option<wgpu::SurfaceTexture> {
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => Some(t),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                // A surface whose window system went away cannot be
                // configured again: wgpu reports that as a validation
                // error, which would panic outside a scope. The frame is
                // skipped; a lost X server ends the process through its
                // own handler, which closes the recordings first.
                let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
                self.surface.configure(&self.device, &self.config);
                let _ = pollster::block_on(scope.pop());
                None
            }
            _ => None,
        }
    }

    /// Copies a `w × h` RGB frame into `tex` (cropped to the surface),
    /// submits and presents; returns the host time (µs) of the submit.
    pub fn present(&mut self, tex: wgpu::SurfaceTexture, rgb: &[u8], (fw, fh): (u32, u32)) -> u64 {
        let (w, h) = (fw.min(self.config.width), fh.min(self.config.height));
        // RGB to RGBA (or BGRA) into a buffer sized once, a row at a time.
        let (wu, hu) = (w as usize, h as usize);
        self.staging.resize(4 * wu * hu, 255);
        let bgra = self.bgra;
        for (src, dst) in rgb
            .chunks_exact(3 * fw as usize)
            .zip(self.staging.chunks_exact_mut(4 * wu))
        {
            for (p, q) in src[..3 * wu].chunks_exact(3).zip(dst.chunks_exact_mut(4)) {
                let [r, g, b] = [p[0], p[1], p[2]];
                q.copy_from_slice(&if bgra { [b, g, r, 255] } else { [r, g, b, 255] });
            }
        }
        self.presented_bytes += self.staging.len() as u64;
        self.copied_from_cpu += 1;
        self.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &self.staging,
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
        self.queue.submit([]);
        let submitted = tracker_hal::clock::monotonic_us();
        self.window.pre_present_notify();
        self.queue.present(tex);
        submitted
    }
}

#[cfg(test)]
mod tests {
    use super::{pick_present_mode, plain_error, PresentChoice};
    use wgpu::PresentMode as M;

    /// Auto takes Mailbox where offered and FIFO otherwise, never
    /// Immediate; an explicit mode the adapter lacks is an error naming
    /// what it offers.
    #[test]
    fn the_present_mode_is_the_lowest_latency_without_tearing() {
        let all = [M::Fifo, M::Immediate, M::Mailbox];
        let pick = |c, o: &[M]| pick_present_mode(c, o).map(|p| p.0);
        assert_eq!(pick(PresentChoice::Auto, &all), Ok(M::Mailbox));
        assert_eq!(
            pick(PresentChoice::Auto, &[M::Fifo, M::Immediate]),
            Ok(M::Fifo)
        );
        assert_eq!(pick(PresentChoice::Fifo, &all), Ok(M::Fifo));
        assert_eq!(pick(PresentChoice::Immediate, &all), Ok(M::Immediate));
        let err = pick(PresentChoice::Mailbox, &[M::Fifo]).unwrap_err();
        assert!(
            err.contains("--present-mode mailbox") && err.contains("Fifo"),
            "{err}"
        );
        let (_, said) = pick_present_mode(PresentChoice::Auto, &all).expect("picks");
        assert!(said.starts_with("present mode Mailbox (auto"), "{said}");
    }

    /// winit's "os error at …/x11/mod.rs:123: …" named the library's
    /// source file in the viewer's "cannot open a window" message.
    #[test]
    fn a_windowing_error_loses_the_library_source_path() {
        let e = "os error at /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/winit-0.30.13/src/platform_impl/linux/mod.rs:765: neither WAYLAND_DISPLAY nor WAYLAND_SOCKET nor DISPLAY is set.";
        assert_eq!(
            plain_error(&e),
            "neither WAYLAND_DISPLAY nor WAYLAND_SOCKET nor DISPLAY is set."
        );
        assert_eq!(plain_error(&"no display"), "no display");
        assert_eq!(plain_error(&"os error at odd"), "os error at odd");
    }
}
