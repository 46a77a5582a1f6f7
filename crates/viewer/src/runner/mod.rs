//! The experiment runner (`gazecast experiment run`): a design's session
//! for one participant in a window, written as it happens to a session
//! folder (`experiment::session`), resumable after a crash. What the
//! session decides apart from the window (the screens' order, the stimuli,
//! the design's checks, the simulated participant's behaviour, a trial's
//! events) is `experiment::run`; this module shows, renders and writes.
//!
//! The screens come from `experiment::run::flow`; each frame the runner
//! takes every tracker sample (all of them, not only the newest: each goes to
//! `samples.tsv`, to the calibration in progress and to the trial's
//! eye-movement events), handles keys and clicks (the window's, or the
//! simulated participant's — [`participant`]) with their host times, and
//! draws the screen: text, a calibration target, the target preview (full
//! resolution) or the search display through the frame pipeline with the
//! trial condition's method (`experiment::run::stimulus`).
//!
//! Timing, on the host's monotonic clock of this sitting (the clock the
//! gaze samples' device times are mapped onto, `mapped_us`): the search
//! starts when the present call of the search display's first frame
//! returns (`search_onset_us`), and ends at the Space key's event
//! (`response_us`, taken when the event reaches the runner; winit gives
//! key events no timestamp of their own; the simulated participant's keys
//! carry the time it planned them for). A trial's eye-movement events are
//! detected on the tracker's clock (tracker-hal `events`) over its samples
//! captured up to the response: its end waits for the tracker to deliver
//! them. Every frame is logged (`frames.tsv`), late when its interval
//! exceeds 1.5 periods of the nominal refresh rate, with the plan that
//! drew it (`pipeline::Renderer::provenance`: the search renderer's for the
//! search and confirm screens, the full-resolution renderer's for the
//! preview, `n/a` for text and targets); a trial's row has its search
//! frames' plan.
//!
//! Keys: `Space` go on (instructions, breaks, the preview) and "found"
//! (the search); a left click confirms the object found (designs with
//! `confirm_click`); in a failed validation `R` calibrates again and
//! `Space` continues; `Esc` ends the session (what was written stays;
//! `--resume` continues at the first unfinished trial).
//!
//! The files: [`options`] (what was asked), [`design_check`] (the design's
//! check with the renderer's part), `setup` (what is fixed for the
//! sitting), `state` (the runner and its screen changes), `calibrating`
//! (calibration and validation), `frame` (one frame), `window` (winit's
//! application), `trial` (a trial's renderer and record), `session_dir`
//! (the session folder), [`participant`] (the simulated participant's
//! thread) and `start` ([`run`]).

pub mod design_check;
pub mod options;
pub mod participant;

mod calibrating;
mod frame;
mod headless;
mod session_dir;
mod setup;
mod start;
mod state;
mod trial;
mod window;

pub use design_check::check_design;
pub use options::RunOptions;
pub use start::run;
