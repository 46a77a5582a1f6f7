//! The simulated participant's behaviour, apart from any thread or
//! tracker: where it looks and what it presses on each screen, dated on
//! the host clock. The runner's thread feeds it what the screen shows and
//! sends its looks to a tracker and its keys and clicks to the runner.
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
//! not depend on the condition (the model never looks at the image) —
//! unless an observer model is given ([`Behaviour::with_observer`],
//! [`super::observer`]): its search then depends on what was rendered.
//!
//! **Timing.** What it plans is dated by the plan, not by when it is
//! asked: a search's fixations are all dated from the screen's start, and
//! its keys and clicks carry the time they were planned for. A busy
//! machine delays delivery, not what the tracker measured.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use screen_geometry::ScreenGeometry;
use tracker_hal::sim::{main_sequence_duration_ms, search_stops};

use super::flow::Phase;
use super::observer::{ObserverModel, ObserverSearch};

/// Probability that the confirming click lands on a neighbouring cell.
pub const WRONG_CLICK: f64 = 0.05;

/// What the participant does, with the host time it did it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Presses Space (ends a search, leaves a message screen).
    Space {
        /// Host time of the press, µs.
        host_us: u64,
    },
    /// Clicks on the screen: the confirming click on the object found.
    Click {
        /// Host time of the click, µs.
        host_us: u64,
        /// Where, screen pixels.
        px: [f64; 2],
    },
}

/// What the screen shows, as the participant needs to know it.
#[derive(Debug, Clone, Default)]
pub struct Seen {
    /// Incremented at every new screen.
    pub epoch: u64,
    /// Which screen is shown; `None` before the first.
    pub phase: Option<Phase>,
    /// When the screen started (host µs).
    pub since_us: u64,
    /// A calibration/validation target (px).
    pub target_px: Option<[f64; 2]>,
    /// Search display: every object's centre and the target's.
    pub objects: Vec<[f64; 2]>,
    /// Search display: the target object's centre (px), when there is one.
    pub target_object: Option<[f64; 2]>,
    /// Search display: the reference's centre (the target mesh shown for
    /// comparison), when the design has one.
    pub reference: Option<[f64; 2]>,
    /// For an observer model ([`Behaviour::with_observer`]): the newest
    /// search frame's gaze (px) and each object's visible fidelity in it
    /// (`observer::cell_fidelity`, in the order of `objects`).
    pub fidelity: Option<([f64; 2], Vec<f64>)>,
}

/// What one look at the screen gives: where the eye goes (host µs, px; in
/// time order, never dated before an earlier look) and what is pressed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Response {
    /// Where the eye goes: (host µs, screen px), in time order.
    pub looks: Vec<(u64, [f64; 2])>,
    /// What is pressed, if anything.
    pub action: Option<Action>,
}

/// Fixation plan of one search: (position, start ms after onset), and when
/// Space is pressed.
pub fn search_plan(
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

/// The participant's state from screen to screen: one act per screen.
#[derive(Debug, Clone)]
pub struct Behaviour {
    geometry: ScreenGeometry,
    rng: ChaCha8Rng,
    epoch: u64,
    acted: bool,
    wait_ms: f64,
    search: (Vec<([f64; 2], f64)>, f64),
    click_px: [f64; 2],
    looking: Option<[f64; 2]>,
    /// The newest time a look was dated for: later looks are never dated
    /// before it (the tracker's cursor history is in time order).
    last_t: u64,
    /// The search model that sees the rendering, when given.
    observer: Option<ObserverModel>,
    observer_search: Option<ObserverSearch>,
}

impl Behaviour {
    /// A participant on `geometry` whose choices follow `seed`.
    pub fn new(geometry: ScreenGeometry, seed: u64) -> Self {
        Self {
            geometry,
            rng: ChaCha8Rng::seed_from_u64(seed),
            epoch: u64::MAX,
            acted: false,
            wait_ms: 0.0,
            search: (Vec::new(), 0.0),
            click_px: geometry.centre_px(),
            looking: None,
            last_t: 0,
            observer: None,
            observer_search: None,
        }
    }

    /// Searches with `model` (`observer`): what it identifies at each
    /// fixation depends on what the condition rendered there. Without it
    /// the search is the stand-in described above, blind to the rendering.
    pub fn with_observer(mut self, model: ObserverModel) -> Self {
        self.observer = Some(model);
        self
    }

    /// Looks at `p` from `t_us` on, unless it already does.
    fn look(&mut self, p: [f64; 2], t_us: u64, out: &mut Response) {
        if self.looking != Some(p) {
            self.looking = Some(p);
            let t = t_us.max(self.last_t);
            self.last_t = t;
            out.looks.push((t, p));
        }
    }

    /// One look at the screen `s` at host time `now_us`: where the eye
    /// goes and, once the time has come, the screen's act.
    pub fn step(&mut self, s: &Seen, now_us: u64) -> Response {
        let mut out = Response::default();
        let Some(phase) = s.phase else {
            return out;
        };
        let geometry = self.geometry;
        let elapsed_ms = now_us.saturating_sub(s.since_us) as f64 / 1e3;
        // When something planned `ms` after the screen's start happens.
        let at = |ms: f64| s.since_us + (ms * 1e3).round() as u64;
        if s.epoch != self.epoch {
            self.epoch = s.epoch;
            self.acted = false;
            match phase {
                Phase::Preview => self.wait_ms = self.rng.random_range(500.0..900.0),
                Phase::Search if self.observer.is_some() => {
                    if let Some(m) = &self.observer {
                        let centre = geometry.centre_px();
                        self.observer_search = Some(ObserverSearch::start(
                            m,
                            centre,
                            s.reference,
                            s.objects.len(),
                            &mut self.rng,
                        ));
                        self.search = (Vec::new(), f64::INFINITY);
                        self.look(centre, s.since_us, &mut out);
                    }
                }
                Phase::Search => {
                    if let Some(t) = s.target_object {
                        self.search = search_plan(&geometry, &s.objects, t, &mut self.rng);
                        // The whole search, dated: each fixation happens
                        // at its planned time whenever this is asked.
                        for (p, t_ms) in self.search.0.clone() {
                            self.look(p, at(t_ms), &mut out);
                        }
                    }
                }
                Phase::Confirm if self.observer_search.is_some() => {
                    // Where it looks: the target if it found it.
                    if let Some(o) = &self.observer_search {
                        self.click_px = o.fixation();
                    }
                    self.wait_ms = self.rng.random_range(250.0..450.0);
                }
                Phase::Confirm => {
                    let t = s.target_object.unwrap_or(geometry.centre_px());
                    self.click_px = t;
                    if self.rng.random::<f64>() < WRONG_CLICK && s.objects.len() > 1 {
                        // The nearest other object.
                        if let Some(o) = s.objects.iter().filter(|o| **o != t).min_by(|a, b| {
                            let d = |p: &[f64; 2]| (p[0] - t[0]).hypot(p[1] - t[1]);
                            d(a).total_cmp(&d(b))
                        }) {
                            self.click_px = *o;
                        }
                    }
                    self.wait_ms = self.rng.random_range(250.0..450.0);
                }
                _ => self.wait_ms = 400.0,
            }
        }
        match phase {
            Phase::Instructions | Phase::Rest { .. } | Phase::PracticeOver => {
                if !self.acted && elapsed_ms >= self.wait_ms {
                    self.acted = true;
                    out.action = Some(Action::Space {
                        host_us: at(self.wait_ms),
                    });
                }
            }
            Phase::Calibration | Phase::Validation { .. } | Phase::DriftCheck => {
                if let Some(t) = s.target_px {
                    self.look(t, now_us, &mut out);
                }
            }
            Phase::Preview => {
                self.look(geometry.centre_px(), s.since_us, &mut out);
                if !self.acted && elapsed_ms >= self.wait_ms {
                    self.acted = true;
                    out.action = Some(Action::Space {
                        host_us: at(self.wait_ms),
                    });
                }
            }
            Phase::Search => {
                if let (Some(m), Some(search)) = (&self.observer, &mut self.observer_search) {
                    let target = s
                        .target_object
                        .and_then(|t| s.objects.iter().position(|o| *o == t));
                    let fidelity = s.fidelity.as_ref().map(|(g, q)| (*g, q.as_slice()));
                    let step = search.step(
                        m,
                        &geometry,
                        &s.objects,
                        target,
                        elapsed_ms,
                        fidelity,
                        &mut self.rng,
                    );
                    for (ms, p) in step.looks {
                        self.look(p, at(ms), &mut out);
                    }
                    if let Some(ms) = step.space_ms {
                        self.search.1 = ms;
                    }
                }
                if !self.acted && elapsed_ms >= self.search.1 {
                    self.acted = true;
                    out.action = Some(Action::Space {
                        host_us: at(self.search.1),
                    });
                }
            }
            Phase::Confirm => {
                self.look(self.click_px, s.since_us, &mut out);
                if !self.acted && elapsed_ms >= self.wait_ms {
                    self.acted = true;
                    out.action = Some(Action::Click {
                        host_us: at(self.wait_ms),
                        px: self.click_px,
                    });
                }
            }
            Phase::Done => {}
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> ScreenGeometry {
        screen_geometry::Display::seed_17in(1280, 1024)
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
