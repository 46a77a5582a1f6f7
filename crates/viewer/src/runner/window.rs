//! The runner as winit's application: the window opened on resume (its
//! refresh rate sets when a frame is late), and the window's events: keys,
//! clicks, closing and the redraw that runs a frame.

use experiment::run::participant::Action;
use tracker_hal::clock::monotonic_us;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::{Key, NamedKey};
use winit::window::WindowId;

use super::calibrating::Checking;
use super::state::Runner;
use crate::screen::Screen;

impl ApplicationHandler for Runner<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.screen.is_none() {
            let size = self.size();
            let title = format!("gazecast experiment — {}", self.setup.design.name);
            // On the GPU backend one device serves the window and every
            // trial's renderer: search frames are drawn into the window
            // without a read-back.
            if self.setup.backend == pipeline::BackendChoice::Gpu && self.gpu.is_none() {
                match raycast::gpu::open_shared() {
                    Ok(d) => self.gpu = Some(d),
                    Err(e) => {
                        self.error = Some(e.to_string());
                        el.exit();
                        return;
                    }
                }
            }
            match Screen::open(
                el,
                &title,
                size,
                self.setup.fullscreen,
                self.setup.monitor,
                // Onsets are tied to the refresh: every frame waits for it.
                crate::screen::PresentChoice::Fifo,
                self.gpu.as_ref(),
            ) {
                Ok(s) => {
                    if let Some(hz) = s
                        .window
                        .current_monitor()
                        .and_then(|m| m.refresh_rate_millihertz())
                        .filter(|&mhz| mhz >= 10_000)
                    {
                        self.late_after_ms = 1.5 * 1e6 / f64::from(hz);
                    }
                    let how = s.how.clone();
                    self.screen = Some(s);
                    self.say(&how);
                }
                Err(e) => {
                    self.error = Some(e);
                    el.exit();
                }
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let now = monotonic_us();
        match event {
            WindowEvent::CloseRequested => {
                self.say("window closed: ending the session (--resume continues it)");
                self.quit()
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = [position.x, position.y];
                self.feed.cursor_moved(position.x, position.y);
            }
            WindowEvent::MouseInput {
                state: ElementState::Pressed,
                button: MouseButton::Left,
                ..
            } => {
                let px = self.cursor;
                self.act(Action::Click { host_us: now, px });
            }
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && !event.repeat =>
            {
                match event.logical_key.as_ref() {
                    Key::Named(NamedKey::Escape) => {
                        self.say("Esc: ending the session (--resume continues it)");
                        self.marker("key", "escape".into());
                        self.quit()
                    }
                    Key::Named(NamedKey::Space) => self.act(Action::Space { host_us: now }),
                    Key::Character("r") | Key::Character("R") => {
                        if matches!(self.checking, Some(Checking::Decide(_))) {
                            self.attempts = 0;
                            self.checking = None;
                            self.flow.recalibrate();
                            self.entered();
                        }
                    }
                    _ => {}
                }
            }
            WindowEvent::RedrawRequested => {
                if crate::interrupt::interrupted() {
                    self.say("interrupted (Ctrl-C or SIGTERM): ending the session");
                    self.quit();
                } else if let Err(e) = self.frame() {
                    // Keep the first error: it is the cause.
                    self.error.get_or_insert(e);
                    self.quit();
                } else if let Some(e) = &self.error {
                    let e = e.clone();
                    self.say(&format!("error: {e}"));
                    self.quit();
                } else if let Some(s) = &self.screen {
                    s.window.request_redraw();
                }
            }
            _ => {}
        }
        if self.quitting {
            el.exit();
        }
    }
}
