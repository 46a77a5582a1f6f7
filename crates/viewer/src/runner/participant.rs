//! A simulated participant for tests and demonstrations: it looks where a
//! person would look and presses what a person would press, through the
//! same paths a person uses. Its gaze goes to a tracker:
//! - the mouse tracker's cursor input (tracker-hal's mouse device then adds
//!   the tracker file's jitter, main-sequence saccades and latency), or
//! - an ISCAN on a pseudo-terminal: binary records at [`ISCAN_RATE_HZ`] in
//!   the raw units of an *uncalibrated* tracker
//!   (`tracker_hal::sim::uncalibrated_raw`: a perspective view of the
//!   screen plus a bow), with 0.1° of jitter, so the session's calibration
//!   has a real mapping to find;
//!
//! and the samples are decoded, recorded and mapped like any tracker's. Its
//! keys and clicks reach the runner's one input handler beside the
//! window's.
//!
//! The behaviour is a plausible stand-in, not fitted to people:
//! - a text screen (instructions, a break) is read for 0.4 s, then Space;
//! - calibration, validation and drift targets are fixated as shown;
//! - the target preview is examined for 0.5–0.9 s, then Space;
//! - a search starts at the centre (where the preview was), visits 3–8
//!   distractors (the nearest of three random candidates each time, as
//!   searches tend to go), fixating each for 200–400 ms, then the target
//!   for 300–500 ms, then presses Space; saccade times between fixations
//!   follow the main sequence;
//! - the confirming click goes to the fixated target, or with probability
//!   [`WRONG_CLICK`] to a neighbouring cell (so incorrect trials occur).
//!
//! Its search times are synthetic: they say nothing about people, and do
//! not depend on the condition (the model never looks at the image). The
//! session it runs is marked synthetic in every file.
//!
//! **Timing.** What it plans happens at the planned host time, however
//! late its own thread runs: a search's fixations go to the tracker as
//! gaze dated by the plan (the mouse device samples the cursor history at
//! each tick's scheduled time; the simulated ISCAN writes on a fixed
//! schedule from the same dated plan), and its keys and clicks carry the
//! time they were planned for. A busy machine delays delivery, not what
//! the tracker measured.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};
use foveation::ScreenGeometry;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tracker_hal::clock::monotonic_us;
use tracker_hal::iscan::{encode_binary, IscanConfig, IscanMode, IscanParam};
use tracker_hal::mouse::CursorEvent;
use tracker_hal::sim::{main_sequence_duration_ms, search_stops, uncalibrated_raw};

use super::flow::Phase;

/// Probability that the confirming click lands on a neighbouring cell.
pub const WRONG_CLICK: f64 = 0.05;

/// Records per second of the simulated ISCAN.
pub const ISCAN_RATE_HZ: f64 = 60.0;

/// Where the participant's gaze goes.
pub enum Eye {
    /// The mouse tracker's cursor input.
    Mouse(Sender<CursorEvent>),
    /// An ISCAN's serial line (the master side of a pseudo-terminal whose
    /// slave the tracker opens).
    Iscan {
        port: serialport::TTYPort,
        config: IscanConfig,
        screen_px: (u32, u32),
    },
}

/// What the participant does, with the host time it did it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    Space { host_us: u64 },
    Click { host_us: u64, px: [f64; 2] },
}

/// What the screen shows, as the participant needs to know it.
#[derive(Debug, Clone, Default)]
struct Seen {
    /// Incremented at every new screen.
    epoch: u64,
    phase: Option<Phase>,
    since_us: u64,
    /// A calibration/validation target (px).
    target_px: Option<[f64; 2]>,
    /// Search display: every object's centre and the target's.
    objects: Vec<[f64; 2]>,
    target_object: Option<[f64; 2]>,
}

/// The participant's thread.
pub struct Participant {
    seen: Arc<Mutex<Seen>>,
    actions: Receiver<Action>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    /// The ISCAN writer, when the eye is one.
    writer: Option<std::thread::JoinHandle<()>>,
}

/// Fixation plan of one search: (position, start ms after onset), and when
/// Space is pressed.
fn search_plan(
    geometry: &ScreenGeometry,
    objects: &[[f64; 2]],
    target: [f64; 2],
    rng: &mut ChaCha8Rng,
) -> (Vec<([f64; 2], f64)>, f64) {
    let stops = search_stops(geometry.centre_px(), objects, target, 3..=8, rng);
    let mut t = 0.0;
    let mut plan = Vec::with_capacity(stops.len());
    for (k, &p) in stops.iter().enumerate() {
        if k > 0 {
            let amp = geometry.eccentricity_deg(stops[k - 1], p);
            t += main_sequence_duration_ms(amp);
        }
        plan.push((p, t));
        let last = k + 1 == stops.len();
        t += if last {
            rng.random_range(300.0..500.0)
        } else {
            rng.random_range(200.0..400.0)
        };
    }
    (plan, t)
}

impl Participant {
    /// Starts the participant; its gaze goes to `eye`, its actions to
    /// [`Participant::take_actions`].
    pub fn spawn(eye: Eye, geometry: ScreenGeometry, seed: u64) -> Self {
        let seen = Arc::new(Mutex::new(Seen::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, actions) = crossbeam_channel::unbounded();
        let (s, st) = (seen.clone(), stop.clone());
        let gaze = Arc::new(Mutex::new(Gaze::new(geometry.centre_px())));
        let (cursor, writer) = match eye {
            Eye::Mouse(c) => (Some(c), None),
            Eye::Iscan {
                port,
                config,
                screen_px,
            } => {
                let (g, st) = (gaze.clone(), stop.clone());
                let w = std::thread::Builder::new()
                    .name("participant-iscan".into())
                    .spawn(move || iscan_writer(port, &config, screen_px, &g, &st, seed))
                    .ok();
                (None, w)
            }
        };
        let thread = std::thread::Builder::new()
            .name("participant".into())
            .spawn(move || behave(&s, &st, cursor.as_ref(), &gaze, &tx, geometry, seed))
            .ok();
        Self {
            seen,
            actions,
            stop,
            thread,
            writer,
        }
    }

    /// A new screen is shown (since `since_us`, host µs): for a search,
    /// `objects` (centres, px) and the target's centre.
    pub fn show(
        &self,
        phase: Phase,
        since_us: u64,
        objects: &[[f64; 2]],
        target: Option<[f64; 2]>,
    ) {
        if let Ok(mut s) = self.seen.lock() {
            s.epoch += 1;
            s.phase = Some(phase);
            s.since_us = since_us;
            s.target_px = None;
            s.objects = objects.to_vec();
            s.target_object = target;
        }
    }

    /// The calibration or validation target now shown (px), if any.
    pub fn show_target(&self, target: Option<[f64; 2]>) {
        if let Ok(mut s) = self.seen.lock() {
            s.target_px = target;
        }
    }

    /// What the participant did since the last call.
    pub fn take_actions(&self) -> Vec<Action> {
        self.actions.try_iter().collect()
    }
}

impl Drop for Participant {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in [self.thread.take(), self.writer.take()]
            .into_iter()
            .flatten()
        {
            let _ = t.join();
        }
    }
}

/// Where the participant looks over time: (host µs, px) in time order, for
/// the simulated ISCAN's scheduled ticks.
#[derive(Debug, Clone)]
struct Gaze {
    plan: std::collections::VecDeque<(u64, [f64; 2])>,
}

impl Gaze {
    fn new(at: [f64; 2]) -> Self {
        Self {
            plan: std::collections::VecDeque::from([(0, at)]),
        }
    }

    fn push(&mut self, t_us: u64, p: [f64; 2]) {
        self.plan.push_back((t_us, p));
    }

    /// Where the eye is at `t_us` (older entries are dropped).
    fn at(&mut self, t_us: u64) -> [f64; 2] {
        while self.plan.len() > 1 && self.plan[1].0 <= t_us {
            self.plan.pop_front();
        }
        self.plan.front().map_or([0.0, 0.0], |e| e.1)
    }
}

/// The simulated ISCAN: on a fixed schedule of 1/[`ISCAN_RATE_HZ`] s
/// (a late thread writes the ticks it missed, each from where the eye was
/// at its scheduled time), a binary record of the uncalibrated raw units
/// of where the participant looks (both eyes the same), with
/// Gaussian-like jitter of about 0.1° (the sum of four uniforms). Ends at
/// the stop flag; a record the line refuses (no reader yet) is dropped.
fn iscan_writer(
    mut port: serialport::TTYPort,
    config: &IscanConfig,
    screen_px: (u32, u32),
    gaze: &Mutex<Gaze>,
    stop: &AtomicBool,
    seed: u64,
) {
    use std::io::Write;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x15CA);
    let period_us = (1e6 / ISCAN_RATE_HZ).round() as u64;
    // 0.1 deg at about 35 px per degree, in raw units.
    let jitter_px = 3.5;
    let mut schedule = tracker_hal::mouse::Schedule::new(monotonic_us(), period_us);
    let catch_up = tracker_hal::mouse::MAX_CATCH_UP.as_micros() as u64;
    while !stop.load(Ordering::Relaxed) {
        let (ticks, _) = schedule.due(monotonic_us(), catch_up);
        for (t, _) in ticks {
            let p = gaze.lock().map(|mut g| g.at(t)).unwrap_or([0.0, 0.0]);
            let mut j =
                || (0..4).map(|_| rng.random_range(-1.0..1.0)).sum::<f64>() * jitter_px / 2.0;
            let px = [p[0] + j(), p[1] + j()];
            let raw = uncalibrated_raw(px, screen_px, config.frame);
            let values: Vec<Option<f64>> = config
                .parameters
                .iter()
                .map(|k| match k {
                    IscanParam::LeftPorH | IscanParam::RightPorH => Some(raw[0]),
                    IscanParam::LeftPorV | IscanParam::RightPorV => Some(raw[1]),
                    IscanParam::LeftPupil | IscanParam::RightPupil => Some(30.0),
                    IscanParam::Other => Some(0.0),
                })
                .collect();
            let record = match config.mode {
                IscanMode::Binary => encode_binary(&values),
                IscanMode::Ascii => tracker_hal::iscan::encode_ascii(&values),
            };
            // Until the tracker has opened the slave (and while it
            // reconnects) the master may refuse writes (EIO); ending here
            // would close the master, the slave's path would vanish, and
            // the tracker would retry forever. The record is dropped, as a
            // line would lose it.
            let _ = port.write_all(&record);
        }
        let now = monotonic_us();
        let next = schedule.next_us();
        if next > now {
            std::thread::sleep(Duration::from_micros(next - now));
        }
    }
}

/// The participant's loop: every 4 ms, look where the screen asks and act
/// when the time has come; one act per screen.
fn behave(
    seen: &Mutex<Seen>,
    stop: &AtomicBool,
    cursor: Option<&Sender<CursorEvent>>,
    gaze: &Mutex<Gaze>,
    actions: &Sender<Action>,
    geometry: ScreenGeometry,
    seed: u64,
) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut epoch = u64::MAX;
    let mut acted = false;
    let mut wait_ms = 0.0;
    let mut search: (Vec<([f64; 2], f64)>, f64) = (Vec::new(), 0.0);
    let mut click_px = geometry.centre_px();
    let mut looking: Option<[f64; 2]> = None;
    // The newest time a look was dated for: later looks are never dated
    // before it (the tracker's cursor history is in time order).
    let mut last_t = 0u64;
    let mut look = |p: [f64; 2], t_us: u64, looking: &mut Option<[f64; 2]>| {
        if *looking != Some(p) {
            *looking = Some(p);
            let t = t_us.max(last_t);
            last_t = t;
            if let Ok(mut g) = gaze.lock() {
                g.push(t, p);
            }
            if let Some(c) = cursor {
                let _ = c.send(CursorEvent {
                    t_us: t,
                    position_px: p,
                    blink: false,
                });
            }
        }
    };
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(4));
        let s = match seen.lock() {
            Ok(s) => s.clone(),
            Err(_) => return,
        };
        let Some(phase) = s.phase else { continue };
        let now = monotonic_us();
        let elapsed_ms = now.saturating_sub(s.since_us) as f64 / 1e3;
        // When something planned `ms` after the screen's start happens.
        let at = |ms: f64| s.since_us + (ms * 1e3).round() as u64;
        if s.epoch != epoch {
            epoch = s.epoch;
            acted = false;
            match phase {
                Phase::Preview => wait_ms = rng.random_range(500.0..900.0),
                Phase::Search => {
                    if let Some(t) = s.target_object {
                        search = search_plan(&geometry, &s.objects, t, &mut rng);
                        // The whole search, dated: each fixation happens
                        // at its planned time whenever this thread runs.
                        for &(p, t_ms) in &search.0 {
                            look(p, at(t_ms), &mut looking);
                        }
                    }
                }
                Phase::Confirm => {
                    let t = s.target_object.unwrap_or(geometry.centre_px());
                    click_px = t;
                    if rng.random::<f64>() < WRONG_CLICK && s.objects.len() > 1 {
                        // The nearest other object.
                        if let Some(o) = s.objects.iter().filter(|o| **o != t).min_by(|a, b| {
                            let d = |p: &[f64; 2]| (p[0] - t[0]).hypot(p[1] - t[1]);
                            d(a).total_cmp(&d(b))
                        }) {
                            click_px = *o;
                        }
                    }
                    wait_ms = rng.random_range(250.0..450.0);
                }
                _ => wait_ms = 400.0,
            }
        }
        match phase {
            Phase::Instructions | Phase::Rest { .. } => {
                if !acted && elapsed_ms >= wait_ms {
                    acted = true;
                    let _ = actions.send(Action::Space {
                        host_us: at(wait_ms),
                    });
                }
            }
            Phase::Calibration | Phase::Validation { .. } | Phase::DriftCheck => {
                if let Some(t) = s.target_px {
                    look(t, now, &mut looking);
                }
            }
            Phase::Preview => {
                look(geometry.centre_px(), s.since_us, &mut looking);
                if !acted && elapsed_ms >= wait_ms {
                    acted = true;
                    let _ = actions.send(Action::Space {
                        host_us: at(wait_ms),
                    });
                }
            }
            Phase::Search => {
                if !acted && elapsed_ms >= search.1 {
                    acted = true;
                    let _ = actions.send(Action::Space {
                        host_us: at(search.1),
                    });
                }
            }
            Phase::Confirm => {
                look(click_px, s.since_us, &mut looking);
                if !acted && elapsed_ms >= wait_ms {
                    acted = true;
                    let _ = actions.send(Action::Click {
                        host_us: at(wait_ms),
                        px: click_px,
                    });
                }
            }
            Phase::Done => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> ScreenGeometry {
        foveation::Display {
            name: "t".into(),
            resolution_px: (1280, 1024),
            size_mm: (337.9, 270.3),
            eye_distance_mm: 540.0,
            eye_point_px: None,
        }
        .geometry()
        .expect("geometry")
    }

    #[test]
    fn a_search_plan_ends_on_the_target_after_visiting_distractors() {
        let g = geometry();
        let objects: Vec<[f64; 2]> = (0..25)
            .map(|k| {
                [
                    200.0 + 200.0 * f64::from(k % 5),
                    112.0 + 200.0 * f64::from(k / 5),
                ]
            })
            .collect();
        for seed in 0..50 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let target = objects[(seed % 25) as usize];
            let (plan, space_ms) = search_plan(&g, &objects, target, &mut rng);
            assert_eq!(plan.first().map(|p| p.0), Some(g.centre_px()));
            assert_eq!(plan.last().map(|p| p.0), Some(target));
            assert!((5..=10).contains(&plan.len()), "{}", plan.len());
            assert!(plan.windows(2).all(|w| w[1].1 > w[0].1));
            assert!(space_ms > plan[plan.len() - 1].1 + 299.0);
            // Distractors are visited once each and never the target early.
            let mid = &plan[1..plan.len() - 1];
            assert!(mid.iter().all(|p| p.0 != target));
        }
    }
}
