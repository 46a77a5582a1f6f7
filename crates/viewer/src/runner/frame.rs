//! One frame of the session: the tracker's samples, the participant's acts
//! and the calibration taken first, then the screen drawn (text, target,
//! preview or search display), presented and logged (`frames.tsv`).

use experiment::run::flow::Phase;
use experiment::session::{FrameRow, MarkerRow};

use super::state::Runner;
use super::trial;
use crate::screen::{OverlayBuf, Screen};

impl Runner<'_> {
    pub(super) fn text(&mut self, lines: &[String]) {
        let size = self.size();
        trial::text_screen(&mut self.canvas, size, lines);
    }

    pub(super) fn frame(&mut self) -> Result<(), String> {
        if let Some(e) = self.dir.error() {
            return Err(format!("the session folder cannot be written: {e}"));
        }
        let tex = self.screen.as_ref().and_then(Screen::acquire);
        self.drain();
        if let Some(p) = &self.participant {
            for a in p.take_actions() {
                self.act(a);
            }
        }
        if self.quitting {
            return Ok(());
        }
        self.check();
        let phase = self.flow.phase();
        let design = &self.setup.design;
        let mut rays = 0;
        let mut render_ms = 0.0;
        let mut traffic = None;
        match phase {
            Phase::Instructions => {
                let mut lines = vec![
                    format!("Visual search: {}", design.name),
                    String::new(),
                    "First look at each dot as it appears (calibration).".into(),
                    "Each trial shows the target face at the centre: study it, then press Space."
                        .into(),
                    "Find the same face in the grid and press Space as soon as you have found it."
                        .into(),
                ];
                if design.response.confirm_click {
                    lines.push("Then click on the face you found.".into());
                }
                if let Some(p) = &design.practice {
                    lines.push(format!(
                        "The first {} trials are practice: take your time.",
                        p.trials
                    ));
                }
                lines.push(String::new());
                lines.push("Press Space to begin.".into());
                self.text(&lines);
            }
            Phase::PracticeOver => {
                let lines = vec![
                    "The practice trials are over.".into(),
                    "From now on each search is timed: press Space as soon as you find the face."
                        .into(),
                    "If you have a question, ask it now.".into(),
                    "Press Space to begin the experiment.".into(),
                ];
                self.text(&lines);
            }
            Phase::Rest { between_runs } => {
                let t = self
                    .flow
                    .trial()
                    .map(|t| (t.run, t.trial_in_run))
                    .unwrap_or((0, 0));
                let lines = if between_runs {
                    vec![
                        format!("End of run {} of {}.", t.0, design.runs),
                        "Please stand up and stretch.".into(),
                        "Press Space to go on.".into(),
                    ]
                } else {
                    vec![
                        "A short break: rest your eyes.".into(),
                        "Press Space to go on.".into(),
                    ]
                };
                self.text(&lines);
            }
            Phase::Done => {
                self.text(&["The session is complete. Thank you!".into()]);
                if !self.finished {
                    self.finished = true;
                    self.say("session complete");
                }
                if self.now().saturating_sub(self.phase_since_us) > 1_000_000 {
                    self.quit();
                }
            }
            Phase::Calibration | Phase::Validation { .. } | Phase::DriftCheck => {}
            Phase::Preview | Phase::Search | Phase::Confirm => {
                let Some(t) = &mut self.trial else {
                    return Err("no trial state for the trial's screen".into());
                };
                if phase == Phase::Search {
                    let (r, ms, moved) = t.render_search(self.gaze)?;
                    rays = r;
                    render_ms = ms;
                    traffic = moved;
                } else if phase == Phase::Confirm {
                    t.confirm_overlay();
                }
            }
        }
        if let Some(limit) = design.response.max_search_s {
            let now = self.now();
            let timed_out = phase == Phase::Search
                && self
                    .trial
                    .as_mut()
                    .is_some_and(|t| t.timed_out(limit, now) && t.respond(now));
            if timed_out {
                self.marker("timeout", format!("no response within {limit} s"));
                self.end_trial(None);
                return Ok(());
            }
        }
        let rgb: &[u8] = match (&self.trial, phase) {
            (Some(t), Phase::Preview | Phase::Search | Phase::Confirm) => t.rgb(phase),
            _ => &self.canvas,
        };
        // What drew the picture: a renderer for the trial's screens; the
        // text and target screens are drawn without one (`n/a`).
        let plan = match (&self.trial, phase) {
            (Some(t), Phase::Preview | Phase::Search | Phase::Confirm) => {
                Some(t.plan(phase).to_string())
            }
            _ => None,
        };
        let size = self.size();
        if let Some(dir) = &self.setup.screenshots {
            let name = self.flow.phase_name();
            if self.shot.insert(name) {
                let path = dir.join(format!("{name}.png"));
                // A search frame on the GPU is read back for its picture.
                let shown = match (&self.trial, phase) {
                    (Some(t), Phase::Search) => t.shown_rgb(phase)?,
                    _ => std::borrow::Cow::Borrowed(rgb),
                };
                if let Err(e) = crate::picture::save_png(&path, size, &shown) {
                    return Err(format!("{}: {e}", path.display()));
                }
            }
        }
        // A search frame that stayed on the GPU is drawn into the window
        // there, with the trial's reference object as the overlay.
        let on_gpu = match (&self.trial, phase) {
            (Some(t), Phase::Search) => t.gpu_frame(),
            _ => None,
        };
        let index = self.flow.trial().map(|t| t.index);
        let submit_us = match (&mut self.screen, tex, on_gpu) {
            (Some(s), Some(tex), Some((pixels, frame_size))) => {
                if self.overlay_trial != index {
                    let overlay = self.trial.as_ref().and_then(|t| t.reference_overlay());
                    s.set_overlay(overlay.as_ref().map(OverlayBuf::as_overlay));
                    self.overlay_trial = index;
                }
                s.present_gpu(tex, pixels, frame_size)
                    .unwrap_or_else(|| self.now())
            }
            (Some(s), Some(tex), None) => s.present(tex, rgb, size),
            _ => self.now(),
        };
        let present_us = self.now();
        let interval_ms = self
            .last_submit_us
            .map(|t| submit_us.saturating_sub(t) as f64 / 1e3);
        self.last_submit_us = Some(submit_us);
        let late = interval_ms.is_some_and(|i| i > self.late_after_ms);
        if phase == Phase::Search {
            if let Some(t) = &mut self.trial {
                let first = t.presented(present_us, rays, late);
                if first {
                    self.dir.marker(&MarkerRow {
                        sitting: self.dir.sitting(),
                        host_us: present_us,
                        trial: self.flow.trial().map(|t| t.index),
                        event: "search-onset".into(),
                        detail: "first frame of the search display presented".into(),
                    });
                    if let Some(p) = &self.participant {
                        let trial = self.flow.trial();
                        let target = trial.map(|t| self.setup.layout.centre_px(t.target_cell));
                        // The reference is never a stop of the search.
                        let objects = self
                            .setup
                            .layout
                            .search_centres(trial.and_then(|t| t.reference_cell));
                        let reference = trial
                            .and_then(|t| t.reference_cell)
                            .map(|c| self.setup.layout.centre_px(c));
                        p.show(Phase::Search, present_us, &objects, target, reference);
                    }
                }
            }
        }
        // What the observer model sees of the frame shown (after the
        // search's onset is shown to it).
        if let (Some(p), Some(t), Phase::Search) = (&self.participant, &self.trial, phase) {
            if let Some((gaze, q)) = t.fidelity() {
                p.show_fidelity(gaze, q);
            }
        }
        self.dir.frame(&FrameRow {
            sitting: self.dir.sitting(),
            host_us: present_us,
            trial: self
                .flow
                .trial()
                .map(|t| t.index)
                .filter(|_| phase.in_trial()),
            phase: self.flow.phase_name().into(),
            rays,
            render_ms,
            interval_ms,
            late,
            plan,
            gpu_uploaded_bytes: traffic.map(|t| t.uploaded_bytes),
            gpu_read_back_bytes: traffic.map(|t| t.read_back_bytes),
            gpu_dispatches: traffic.map(|t| t.dispatches),
            gpu_draws: traffic.map(|t| t.draws),
            gpu_submits: traffic.map(|t| t.submits),
        });
        Ok(())
    }
}
