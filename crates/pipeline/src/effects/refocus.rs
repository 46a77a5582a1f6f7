//! Refocusing dynamics of the depth-of-field pass (Lee 2009 §6.1): how the
//! focal depth follows its target when the gaze moves to another depth.
//!
//! **Interpolated quantity: diopters** (accommodation, `D = 1000 / depth_mm`,
//! in 1/m), not depth. The eye's lens changes its refractive power, and a
//! lerp in depth spends most of a near-to-far transition near the far end
//! (and is undefined towards infinity); in diopters infinity is simply
//! 0 D, every value stays finite, and the thin lens's circle of confusion
//! (`∝ |1/d − 1/d_f|`, eq. 4.2–4.4) changes linearly along the transition.
//!
//! - `Instant`: the focus is the target, frame by frame.
//! - `Interpolate { ms }` (eq. 6.1): when the target **jumps** (by more than
//!   [`REFOCUS_JUMP_DIOPTERS`] between consecutive frames) a transition
//!   starts from the diopters shown at that frame; `t` ms later it shows
//!   `lerp(D_from, D_target(t), t/τ)`, τ = `ms`, the end tracking the
//!   target as it moves (Lee's `Z_n(t)`), and the target's own once `t ≥ τ`.
//!   Deviations from the seed: Lee's start `Z_p(t)` tracks the previously
//!   attended object; here it is frozen at the focus shown when the jump
//!   came (the gaze no longer says where that object is). A jump during a
//!   transition starts a new one from the focus then shown, so the focus is
//!   continuous and answers at once (Lee's lerp waits for the end).
//! - `LowPass { hz }`: a first-order low-pass of cut-off `f`, discretised
//!   exactly for a target held between frames:
//!   `D ← D_prev_target + (D − D_prev_target)·exp(−2π f Δt)`, so a jump
//!   decays as `exp(−2π f t)` whatever the frame times. (Lee's filter type
//!   and order are not given; his Fig. 6.1 overshoots, a first-order
//!   filter does not.)
//!
//! In every mode the frame on which a jump is first seen shows the focus of
//! before the jump (the transition begins there), and the first frame ever
//! starts at its target.
//!
//! **Time**: `time_s` is the frame's time (s). `None` (a frame without a
//! clock) refocuses at once, as `Instant`. A NaN or infinite time is
//! refused: the frame shows the focus held from the last frame, and its
//! target is not taken (the next timed frame sees it). A time step that
//! goes back is taken as 0; a huge one ends a transition or settles the
//! filter. A NaN or non-positive target is held (the last target stays).
//! The focus returned is never NaN: positive, or `inf` (0 D).

use raycast::scene::DofRefocus;

/// Smallest change of the target between consecutive frames, diopters,
/// that starts an `Interpolate` transition (about the eye's depth of focus,
/// ±0.3 D); smaller changes are tracked at once (a moving target).
pub const REFOCUS_JUMP_DIOPTERS: f64 = 0.25;

/// Eye distance (mm) → diopters (1/m); `inf` → 0.
pub fn diopters(depth_mm: f64) -> f64 {
    1000.0 / depth_mm
}

/// Diopters → eye distance (mm); 0 → `inf`.
pub fn depth_mm(diopters: f64) -> f64 {
    1000.0 / diopters.max(0.0)
}

/// The refocusing state of one depth-of-field pass.
#[derive(Debug, Clone, Default)]
pub struct Refocus {
    /// How the focus moves to a new target (at once, or over time).
    pub mode: DofRefocus,
    state: Option<State>,
}

#[derive(Debug, Clone, Copy)]
struct State {
    /// Diopters shown by the last frame.
    shown: f64,
    /// The last target taken, diopters.
    target: f64,
    /// Time of the last timed frame, s.
    time_s: Option<f64>,
    /// `Interpolate`: the running transition's start (diopters) and time
    /// elapsed since (s).
    transition: Option<(f64, f64)>,
}

impl Refocus {
    /// A refocusing state for `mode` that has shown no frame yet.
    pub fn new(mode: DofRefocus) -> Self {
        Self { mode, state: None }
    }

    /// The focus shown by the last frame, mm (`None` before any).
    pub fn focus_mm(&self) -> Option<f64> {
        self.state.map(|s| depth_mm(s.shown))
    }

    /// Forgets the state: the next frame starts at its target.
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// The focus (mm) for a frame at `time_s` whose target is `target_mm`.
    pub fn update(&mut self, target_mm: f64, time_s: Option<f64>) -> f64 {
        let target = if target_mm > 0.0 {
            Some(diopters(target_mm))
        } else {
            None // NaN or non-positive: held
        };
        let Some(mut s) = self.state else {
            let t = target.unwrap_or(0.0);
            self.state = Some(State {
                shown: t,
                target: t,
                time_s: time_s.filter(|t| t.is_finite()),
                transition: None,
            });
            return depth_mm(t);
        };
        let new_target = target.unwrap_or(s.target);
        let dt = match time_s {
            None => None,
            Some(t) if !t.is_finite() => return depth_mm(s.shown), // refused
            Some(t) => {
                let dt = s.time_s.map_or(0.0, |t0| (t - t0).max(0.0));
                s.time_s = Some(t);
                Some(if dt.is_nan() { 0.0 } else { dt })
            }
        };
        match (self.mode, dt) {
            (DofRefocus::Instant, _) | (_, None) => {
                s.shown = new_target;
                s.transition = None;
            }
            (DofRefocus::Interpolate { ms }, Some(dt)) => {
                let tau = ms / 1000.0;
                // The running transition at this time, towards `towards`.
                // (The relative slack absorbs the rounding of summed time
                // steps: 300 ms of frames end a 300-ms transition.)
                let at = |tr: Option<(f64, f64)>, towards: f64| match tr {
                    Some((from, elapsed)) if tau > 0.0 && elapsed < tau * (1.0 - 1e-9) => {
                        (from + (towards - from) * (elapsed / tau), tr)
                    }
                    _ => (towards, None),
                };
                if let Some((_, elapsed)) = &mut s.transition {
                    *elapsed += dt;
                }
                if (new_target - s.target).abs() > REFOCUS_JUMP_DIOPTERS {
                    // The focus of before the jump, at this time, starts
                    // the new transition.
                    let (now, _) = at(s.transition, s.target);
                    s.shown = now;
                    s.transition = Some((now, 0.0));
                } else {
                    (s.shown, s.transition) = at(s.transition, new_target);
                }
            }
            (DofRefocus::LowPass { hz }, Some(dt)) => {
                let k = (-2.0 * std::f64::consts::PI * hz * dt).exp();
                let k = if k.is_nan() { 0.0 } else { k.clamp(0.0, 1.0) };
                s.shown = s.target + (s.shown - s.target) * k;
            }
        }
        s.target = new_target;
        if !s.shown.is_finite() || s.shown < 0.0 {
            s.shown = new_target;
        }
        self.state = Some(s);
        depth_mm(s.shown)
    }
}
