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
//! What it does on each screen is `experiment::run::participant`'s
//! [`Behaviour`]; this is its thread and its eye. The session it runs is
//! marked synthetic in every file.
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
use experiment::run::flow::Phase;
use experiment::run::observer::ObserverModel;
use experiment::run::participant::{Action, Behaviour, Seen};
use foveation::ScreenGeometry;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tracker_hal::clock::monotonic_us;
use tracker_hal::iscan::{encode_binary, IscanConfig, IscanMode, IscanParam};
use tracker_hal::mouse::CursorEvent;
use tracker_hal::sim::uncalibrated_raw;

/// Records per second of the simulated ISCAN.
pub const ISCAN_RATE_HZ: f64 = 60.0;

/// Where the participant's gaze goes.
pub enum Eye {
    /// The mouse tracker's cursor input.
    Mouse(Sender<CursorEvent>),
    /// An ISCAN's serial line (the master side of a pseudo-terminal whose
    /// slave the tracker opens).
    Iscan {
        /// The master side of the pseudo-terminal.
        port: serialport::TTYPort,
        /// The simulated ISCAN's settings.
        config: IscanConfig,
        /// The screen's size, pixels.
        screen_px: (u32, u32),
    },
}

/// The participant: its own thread (a session in a window), or stepped
/// by a headless simulation's loop on its virtual clock
/// ([`Participant::inline`]).
pub struct Participant {
    seen: Arc<Mutex<Seen>>,
    actions: Receiver<Action>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    /// The ISCAN writer, when the eye is one.
    writer: Option<std::thread::JoinHandle<()>>,
    /// Headless: the behaviour, stepped by [`Participant::step`], and
    /// where its actions go.
    inline: Option<(Mutex<Behaviour>, Sender<Action>)>,
}

impl Participant {
    /// Starts the participant; its gaze goes to `eye`, its actions to
    /// [`Participant::take_actions`].
    pub fn spawn(
        eye: Eye,
        geometry: ScreenGeometry,
        seed: u64,
        observer: Option<ObserverModel>,
    ) -> Self {
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
            .spawn(move || {
                let mut b = Behaviour::new(geometry, seed);
                if let Some(m) = observer {
                    b = b.with_observer(m);
                }
                behave(&s, &st, cursor.as_ref(), &gaze, &tx, b)
            })
            .ok();
        Self {
            seen,
            actions,
            stop,
            thread,
            writer,
            inline: None,
        }
    }

    /// A participant without a thread, for a headless simulation: its
    /// loop calls [`Participant::step`] with the virtual time each frame.
    pub fn inline(geometry: ScreenGeometry, seed: u64, observer: Option<ObserverModel>) -> Self {
        let (tx, actions) = crossbeam_channel::unbounded();
        let mut b = Behaviour::new(geometry, seed);
        if let Some(m) = observer {
            b = b.with_observer(m);
        }
        Self {
            seen: Arc::new(Mutex::new(Seen::default())),
            actions,
            stop: Arc::new(AtomicBool::new(false)),
            thread: None,
            writer: None,
            inline: Some((Mutex::new(b), tx)),
        }
    }

    /// Headless: one look at the screen at `now_us` (virtual): where the
    /// eye goes (dated, in time order), the act queued for
    /// [`Participant::take_actions`]. Nothing for a threaded participant.
    pub fn step(&self, now_us: u64) -> Vec<(u64, [f64; 2])> {
        let Some((behaviour, tx)) = &self.inline else {
            return Vec::new();
        };
        let seen = match self.seen.lock() {
            Ok(s) => s.clone(),
            Err(_) => return Vec::new(),
        };
        let Ok(mut b) = behaviour.lock() else {
            return Vec::new();
        };
        let response = b.step(&seen, now_us);
        if let Some(a) = response.action {
            let _ = tx.send(a);
        }
        response.looks
    }

    /// A new screen is shown (since `since_us`, host µs): for a search,
    /// `objects` (centres, px), the target's centre and the reference's.
    pub fn show(
        &self,
        phase: Phase,
        since_us: u64,
        objects: &[[f64; 2]],
        target: Option<[f64; 2]>,
        reference: Option<[f64; 2]>,
    ) {
        if let Ok(mut s) = self.seen.lock() {
            s.epoch += 1;
            s.phase = Some(phase);
            s.since_us = since_us;
            s.target_px = None;
            s.objects = objects.to_vec();
            s.target_object = target;
            s.reference = reference;
            s.fidelity = None;
        }
    }

    /// The newest search frame's gaze (px) and each object's visible
    /// fidelity in it, for an observer model.
    pub fn show_fidelity(&self, gaze: [f64; 2], fidelity: Vec<f64>) {
        if let Ok(mut s) = self.seen.lock() {
            s.fidelity = Some((gaze, fidelity));
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
/// when the time has come ([`Behaviour::step`]); its looks go to the
/// ISCAN writer's plan and the mouse tracker's cursor, its acts to the
/// runner.
fn behave(
    seen: &Mutex<Seen>,
    stop: &AtomicBool,
    cursor: Option<&Sender<CursorEvent>>,
    gaze: &Mutex<Gaze>,
    actions: &Sender<Action>,
    mut behaviour: Behaviour,
) {
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(4));
        let s = match seen.lock() {
            Ok(s) => s.clone(),
            Err(_) => return,
        };
        let response = behaviour.step(&s, monotonic_us());
        for (t, p) in response.looks {
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
        if let Some(a) = response.action {
            let _ = actions.send(a);
        }
    }
}
