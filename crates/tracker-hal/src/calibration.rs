//! Calibration and validation: from raw tracker coordinates to screen
//! pixels, fitted on targets the person looked at, and checked on other
//! targets in degrees of visual angle, as labs report it.
//!
//! - [`Plan`]: the targets (5 or 9 points, or any grid), their order, and the
//!   timing of each (settle, then collect).
//! - [`Procedure`]: the state machine that shows the targets in order, takes
//!   the samples, accepts a target or asks for it again (the viewer draws).
//! - [`stable_window`]: per target, the window of lowest dispersion (e.g. the
//!   200 ms in which the eye was stillest), outliers rejected (median ± 3
//!   MAD), averaged.
//! - [`Calibration::fit`]: affine (6 parameters), homography (8, projective)
//!   or second-order polynomial (12), by least squares (SVD, `nalgebra`) on
//!   coordinates normalised to zero mean and mean distance √2 (Hartley), so
//!   the conditioning does not depend on the units.
//! - [`validate`]: accuracy (angle between the target and the mean gaze),
//!   precision as RMS of sample-to-sample angles and as the standard
//!   deviation (angular distance of the samples from their mean), per point
//!   and overall.
//!
//! Degenerate input — too few distinct targets for the model, collinear
//! targets, all samples invalid, non-finite values — is an error that says
//! so, never NaN and never a silently wrong mapping.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use foveation::ScreenGeometry;

/// The mapping model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Model {
    /// `u = a·x + b·y + c` (and v): 6 parameters, 3 points.
    Affine,
    /// Projective (8 parameters, 4 points).
    Homography,
    /// Second-order polynomial in x and y per axis: 12 parameters, 6 points.
    Polynomial2,
}

impl Model {
    /// Distinct targets needed.
    pub fn min_points(self) -> usize {
        match self {
            Model::Affine => 3,
            Model::Homography => 4,
            Model::Polynomial2 => 6,
        }
    }
}

/// Why a calibration could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error("{model:?} needs at least {need} distinct targets with data, got {got}")]
    TooFewPoints {
        model: Model,
        need: usize,
        got: usize,
    },
    #[error("the targets are degenerate for {model:?} (collinear, or too close to each other): the fit is not determined")]
    Degenerate { model: Model },
    #[error("non-finite coordinate in the input: {0}")]
    NonFinite(String),
    #[error("target {index}: {reason}")]
    Target { index: usize, reason: String },
}

/// Hartley normalisation: `(p − c)·s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Normaliser {
    pub centre: [f64; 2],
    pub scale: f64,
}

impl Normaliser {
    fn of(points: &[[f64; 2]]) -> Self {
        let n = points.len().max(1) as f64;
        let c = [
            points.iter().map(|p| p[0]).sum::<f64>() / n,
            points.iter().map(|p| p[1]).sum::<f64>() / n,
        ];
        let mean_dist = points
            .iter()
            .map(|p| (p[0] - c[0]).hypot(p[1] - c[1]))
            .sum::<f64>()
            / n;
        let scale = if mean_dist > 0.0 {
            std::f64::consts::SQRT_2 / mean_dist
        } else {
            1.0
        };
        Self { centre: c, scale }
    }
    fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        [
            (p[0] - self.centre[0]) * self.scale,
            (p[1] - self.centre[1]) * self.scale,
        ]
    }
    fn invert(&self, p: [f64; 2]) -> [f64; 2] {
        [
            p[0] / self.scale + self.centre[0],
            p[1] / self.scale + self.centre[1],
        ]
    }
}

/// A fitted mapping from raw tracker coordinates to screen pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Calibration")]
pub struct Calibration {
    pub model: Model,
    /// Parameters in normalised coordinates (see [`Model`] for the count).
    pub params: Vec<f64>,
    pub raw: Normaliser,
    pub screen: Normaliser,
    /// RMS distance (px) between the fitted targets and where the fit puts
    /// their raw points.
    pub rms_residual_px: f64,
    /// The (raw, target px) pairs it was fitted on.
    pub points: Vec<([f64; 2], [f64; 2])>,
}

fn monomials(model: Model, p: [f64; 2]) -> Vec<f64> {
    let [x, y] = p;
    match model {
        Model::Affine => vec![x, y, 1.0],
        Model::Polynomial2 => vec![1.0, x, y, x * y, x * x, y * y],
        Model::Homography => unreachable!("the homography has no linear design"),
    }
}

/// Ratio below which a design matrix counts as rank-deficient.
const RANK_TOL: f64 = 1e-9;

impl Calibration {
    /// Fits `model` to `(raw, target_px)` pairs (one per target, e.g. from
    /// [`stable_window`]).
    pub fn fit(model: Model, pairs: &[([f64; 2], [f64; 2])]) -> Result<Self, CalibrationError> {
        for (r, t) in pairs {
            if !(r.iter().chain(t).all(|v| v.is_finite())) {
                return Err(CalibrationError::NonFinite(format!("{r:?} → {t:?}")));
            }
        }
        let mut distinct: Vec<[f64; 2]> = Vec::new();
        for (_, t) in pairs {
            if !distinct
                .iter()
                .any(|d| (d[0] - t[0]).abs() < 1e-6 && (d[1] - t[1]).abs() < 1e-6)
            {
                distinct.push(*t);
            }
        }
        if distinct.len() < model.min_points() {
            return Err(CalibrationError::TooFewPoints {
                model,
                need: model.min_points(),
                got: distinct.len(),
            });
        }
        let raw_n = Normaliser::of(&pairs.iter().map(|p| p.0).collect::<Vec<_>>());
        let scr_n = Normaliser::of(&pairs.iter().map(|p| p.1).collect::<Vec<_>>());
        let xs: Vec<[f64; 2]> = pairs.iter().map(|p| raw_n.apply(p.0)).collect();
        let us: Vec<[f64; 2]> = pairs.iter().map(|p| scr_n.apply(p.1)).collect();
        // The targets themselves must span the plane (collinear targets
        // determine nothing across the line), and so must the raw points.
        for pts in [&xs, &us] {
            let m = DMatrix::from_fn(pts.len(), 3, |i, j| [pts[i][0], pts[i][1], 1.0][j]);
            if !full_rank(&m) {
                return Err(CalibrationError::Degenerate { model });
            }
        }
        let params = match model {
            Model::Affine | Model::Polynomial2 => {
                let k = monomials(model, [0.0, 0.0]).len();
                let m = DMatrix::from_fn(xs.len(), k, |i, j| monomials(model, xs[i])[j]);
                if !full_rank(&m) {
                    return Err(CalibrationError::Degenerate { model });
                }
                let svd = m.svd(true, true);
                let mut params = Vec::with_capacity(2 * k);
                for axis in 0..2 {
                    let b = DVector::from_iterator(us.len(), us.iter().map(|u| u[axis]));
                    let p = svd
                        .solve(&b, RANK_TOL)
                        .map_err(|_| CalibrationError::Degenerate { model })?;
                    params.extend(p.iter());
                }
                params
            }
            Model::Homography => {
                // DLT: A h = 0, h the right singular vector of the smallest
                // singular value.
                let n = xs.len();
                let a = DMatrix::from_fn(2 * n, 9, |r, c| {
                    let (i, row) = (r / 2, r % 2);
                    let ([x, y], [u, v]) = (xs[i], us[i]);
                    let rows = [
                        [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u],
                        [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v],
                    ];
                    rows[row][c]
                });
                // Pad to at least 9 rows so the SVD has 9 right vectors.
                let a = if a.nrows() < 9 {
                    a.resize_vertically(9, 0.0)
                } else {
                    a
                };
                let svd = a.svd(false, true);
                let Some(vt) = svd.v_t else {
                    return Err(CalibrationError::Degenerate { model });
                };
                let sv = &svd.singular_values;
                let mut order: Vec<usize> = (0..sv.len()).collect();
                order.sort_by(|&i, &j| sv[i].total_cmp(&sv[j]));
                // Rank 8 needed: the second-smallest singular value must not vanish.
                if sv[order[1]] <= RANK_TOL * sv[order[sv.len() - 1]] {
                    return Err(CalibrationError::Degenerate { model });
                }
                let h: Vec<f64> = vt.row(order[0]).iter().copied().collect();
                let s = h[8];
                if s.abs() < 1e-12 {
                    return Err(CalibrationError::Degenerate { model });
                }
                h.iter().map(|v| v / s).collect()
            }
        };
        let mut c = Calibration {
            model,
            params,
            raw: raw_n,
            screen: scr_n,
            rms_residual_px: 0.0,
            points: pairs.to_vec(),
        };
        let mut sq = 0.0;
        for (r, t) in pairs {
            let Some(p) = c.map(*r) else {
                return Err(CalibrationError::Degenerate { model });
            };
            sq += (p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2);
        }
        c.rms_residual_px = (sq / pairs.len() as f64).sqrt();
        Ok(c)
    }

    /// Maps a raw point to screen pixels. `None` for non-finite input or a
    /// point on the homography's horizon.
    pub fn map(&self, raw: [f64; 2]) -> Option<[f64; 2]> {
        if !(raw[0].is_finite() && raw[1].is_finite()) {
            return None;
        }
        let x = self.raw.apply(raw);
        let u = match self.model {
            Model::Affine | Model::Polynomial2 => {
                let m = monomials(self.model, x);
                let k = m.len();
                let dot = |o: usize| {
                    m.iter()
                        .zip(&self.params[o..o + k])
                        .map(|(a, b)| a * b)
                        .sum()
                };
                [dot(0), dot(k)]
            }
            Model::Homography => {
                let h = &self.params;
                let w = h[6] * x[0] + h[7] * x[1] + h[8];
                if w.abs() < 1e-12 {
                    return None;
                }
                [
                    (h[0] * x[0] + h[1] * x[1] + h[2]) / w,
                    (h[3] * x[0] + h[4] * x[1] + h[5]) / w,
                ]
            }
        };
        let p = self.screen.invert(u);
        (p[0].is_finite() && p[1].is_finite()).then_some(p)
    }
}

fn full_rank(m: &DMatrix<f64>) -> bool {
    if m.nrows() < m.ncols() {
        return false;
    }
    let sv = m.clone().svd(false, false).singular_values;
    let max = sv.iter().copied().fold(0.0, f64::max);
    let min = sv.iter().copied().fold(f64::INFINITY, f64::min);
    max > 0.0 && min > RANK_TOL * max
}

/// One raw sample taken while a target was shown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedPoint {
    pub t_us: u64,
    /// `None`: invalid (blink, lost eye).
    pub raw: Option<[f64; 2]>,
}

/// The stable fixation on one target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableWindow {
    /// Mean of the window's samples after outlier rejection.
    pub raw: [f64; 2],
    pub start_us: u64,
    pub end_us: u64,
    /// Samples kept / in the window.
    pub kept: usize,
    pub in_window: usize,
    /// Dispersion of the window: (max−min) in x plus (max−min) in y.
    pub dispersion: f64,
}

/// Finds the `window_us` span of valid samples with the lowest dispersion
/// (among windows holding at least `min_samples`), rejects samples beyond
/// 3 MAD of the median in either axis, and averages the rest.
pub fn stable_window(
    samples: &[TimedPoint],
    window_us: u64,
    min_samples: usize,
) -> Result<StableWindow, String> {
    let valid: Vec<(u64, [f64; 2])> = samples
        .iter()
        .filter_map(|s| {
            s.raw
                .filter(|p| p[0].is_finite() && p[1].is_finite())
                .map(|p| (s.t_us, p))
        })
        .collect();
    if valid.is_empty() {
        return Err("no valid samples (the tracker lost the eyes for the whole target)".into());
    }
    let min_samples = min_samples.max(1);
    let mut best: Option<(f64, usize, usize)> = None;
    let mut end = 0;
    for start in 0..valid.len() {
        end = end.max(start);
        while end + 1 < valid.len() && valid[end + 1].0 - valid[start].0 <= window_us {
            end += 1;
        }
        if end + 1 - start < min_samples {
            continue;
        }
        let w = &valid[start..=end];
        let span = |k: usize| {
            let (lo, hi) = w
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p.1[k]), hi.max(p.1[k]))
                });
            hi - lo
        };
        let d = span(0) + span(1);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, start, end));
        }
    }
    let Some((dispersion, s, e)) = best else {
        return Err(format!(
            "fewer than {min_samples} valid samples within any {} ms",
            window_us / 1000
        ));
    };
    let w = &valid[s..=e];
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let mut keep = vec![true; w.len()];
    for k in 0..2 {
        let mut xs: Vec<f64> = w.iter().map(|p| p.1[k]).collect();
        let m = median(&mut xs);
        let mut dev: Vec<f64> = w.iter().map(|p| (p.1[k] - m).abs()).collect();
        let mad = median(&mut dev);
        for (i, p) in w.iter().enumerate() {
            if mad > 0.0 && (p.1[k] - m).abs() > 3.0 * 1.4826 * mad {
                keep[i] = false;
            }
        }
    }
    let kept: Vec<[f64; 2]> = w
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(p, _)| p.1)
        .collect();
    let n = kept.len() as f64;
    Ok(StableWindow {
        raw: [
            kept.iter().map(|p| p[0]).sum::<f64>() / n,
            kept.iter().map(|p| p[1]).sum::<f64>() / n,
        ],
        start_us: w[0].0,
        end_us: w[w.len() - 1].0,
        kept: kept.len(),
        in_window: w.len(),
        dispersion,
    })
}

/// Target order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Order {
    /// Row by row from the top left.
    RowMajor,
    /// A seeded shuffle (the person cannot anticipate the next target).
    Shuffled { seed: u64 },
}

/// The targets and timing of a calibration or validation run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Target positions (screen px), in presentation order.
    pub targets_px: Vec<[f64; 2]>,
    /// Ignored at the start of each target (the saccade to it and settling).
    pub settle_ms: u32,
    /// Collected per target after settling.
    pub collect_ms: u32,
    /// Window of lowest dispersion used per target.
    pub window_ms: u32,
    /// Fewest valid samples in that window for the target to count.
    pub min_samples: usize,
    /// Largest dispersion (raw units) for the target to be accepted.
    pub max_dispersion: f64,
}

impl Plan {
    /// A `cols × rows` grid inset by `margin` (fraction of the screen) on a
    /// `w × h` px screen; 5 points = the centre and the four corners.
    pub fn grid(
        points: usize,
        screen_px: (u32, u32),
        margin: f64,
        order: Order,
    ) -> Result<Self, String> {
        let (w, h) = (f64::from(screen_px.0), f64::from(screen_px.1));
        if !(0.0..0.5).contains(&margin) || w <= 0.0 || h <= 0.0 {
            return Err(format!(
                "margin {margin} must be in [0, 0.5) and the screen non-empty"
            ));
        }
        let at = |fx: f64, fy: f64| {
            [
                w * (margin + (1.0 - 2.0 * margin) * fx),
                h * (margin + (1.0 - 2.0 * margin) * fy),
            ]
        };
        let mut targets: Vec<[f64; 2]> = match points {
            5 => vec![
                at(0.5, 0.5),
                at(0.0, 0.0),
                at(1.0, 0.0),
                at(0.0, 1.0),
                at(1.0, 1.0),
            ],
            n if n >= 4 && (n as f64).sqrt().fract() == 0.0 => {
                let k = (n as f64).sqrt() as usize;
                (0..n)
                    .map(|i| {
                        at(
                            (i % k) as f64 / (k - 1) as f64,
                            (i / k) as f64 / (k - 1) as f64,
                        )
                    })
                    .collect()
            }
            n => {
                return Err(format!(
                    "{n} points: use 5 or a square number (4, 9, 16, …)"
                ))
            }
        };
        if let Order::Shuffled { seed } = order {
            use rand::seq::SliceRandom;
            use rand::SeedableRng;
            targets.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
        }
        Ok(Self {
            targets_px: targets,
            settle_ms: 400,
            collect_ms: 800,
            window_ms: 200,
            min_samples: 5,
            max_dispersion: f64::INFINITY,
        })
    }
}

/// A target's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetResult {
    pub target_px: [f64; 2],
    pub samples: Vec<TimedPoint>,
    pub window: Result<StableWindow, String>,
}

impl TargetResult {
    pub fn accepted(&self, plan: &Plan) -> bool {
        self.window
            .as_ref()
            .is_ok_and(|w| w.dispersion <= plan.max_dispersion)
    }
}

/// A target ends with the first sample at least settle + collect − 1 ms
/// after it began (the millisecond keeps a sample that arrives a hair early
/// on the boundary from holding the target one more period).
pub const CHANGE_TOLERANCE_US: u64 = 1000;

/// The calibration state machine: show target i for settle + collect ms
/// (time from the samples' clock), keep the collect-phase samples, move on;
/// redo any target on request. The viewer asks [`Procedure::target`] what to
/// draw and feeds every sample.
///
/// Targets follow a schedule: the first starts with the first sample, each
/// next one exactly settle + collect later (not at the next sample), so
/// sample-arrival jitter never accumulates into drift between the screen's
/// targets and the samples' clock. A target whose whole time passes without
/// a sample (a tracker that sends nothing while the eyes are closed, or went
/// silent) is closed empty and so rejected. [`Procedure::restart`] starts
/// the schedule again at the next sample (after a pause).
#[derive(Debug, Clone)]
pub struct Procedure {
    pub plan: Plan,
    results: Vec<Option<TargetResult>>,
    /// Targets still to show, in order.
    queue: std::collections::VecDeque<usize>,
    shown_since_us: Option<u64>,
    /// When the next target is due on the schedule.
    next_since_us: Option<u64>,
    current: Vec<TimedPoint>,
}

impl Procedure {
    pub fn new(plan: Plan) -> Self {
        let n = plan.targets_px.len();
        Self {
            plan,
            results: vec![None; n],
            queue: (0..n).collect(),
            shown_since_us: None,
            next_since_us: None,
            current: Vec::new(),
        }
    }

    /// The target to draw now (index, px); `None` when all are done.
    pub fn target(&self) -> Option<(usize, [f64; 2])> {
        self.queue.front().map(|&i| (i, self.plan.targets_px[i]))
    }

    pub fn done(&self) -> bool {
        self.queue.is_empty()
    }

    /// Feeds one sample (raw coordinates, or `None` when invalid).
    pub fn feed(&mut self, sample: TimedPoint) {
        let settle = u64::from(self.plan.settle_ms) * 1000;
        let total = settle + u64::from(self.plan.collect_ms) * 1000;
        // A sample past the current target's end closes it, and any target
        // whose whole time passed without data (closed empty, so rejected).
        while let Some(&i) = self.queue.front() {
            // Due on the schedule, or now when there is none.
            let since = match self.shown_since_us {
                Some(t) => t,
                None => *self
                    .shown_since_us
                    .insert(self.next_since_us.take().unwrap_or(sample.t_us)),
            };
            let t = sample.t_us.saturating_sub(since);
            if t + CHANGE_TOLERANCE_US < total {
                if t >= settle {
                    self.current.push(sample);
                }
                return;
            }
            let samples = std::mem::take(&mut self.current);
            let window = stable_window(
                &samples,
                u64::from(self.plan.window_ms) * 1000,
                self.plan.min_samples,
            );
            self.results[i] = Some(TargetResult {
                target_px: self.plan.targets_px[i],
                samples,
                window,
            });
            self.queue.pop_front();
            self.shown_since_us = None;
            self.next_since_us = Some(since + total);
        }
    }

    /// Shows target `index` again (after the current queue), on the
    /// schedule; after a pause (waiting for a key) call [`Self::restart`].
    pub fn redo(&mut self, index: usize) {
        if index < self.results.len() && !self.queue.contains(&index) {
            self.queue.push_back(index);
        }
    }

    /// The next target starts with the next sample (after a pause).
    pub fn restart(&mut self) {
        self.next_since_us = None;
    }

    /// Continues `previous`'s schedule: this procedure's first target is
    /// due when `previous` would have shown its next one (a validation run
    /// straight after the calibration run).
    pub fn follow(&mut self, previous: &Procedure) {
        self.next_since_us = previous.next_since_us;
    }

    /// Targets that were not accepted (to offer a redo).
    pub fn rejected(&self) -> Vec<usize> {
        self.results
            .iter()
            .enumerate()
            .filter(|(_, r)| r.as_ref().is_some_and(|r| !r.accepted(&self.plan)))
            .map(|(i, _)| i)
            .collect()
    }

    pub fn results(&self) -> impl Iterator<Item = &TargetResult> {
        self.results.iter().flatten()
    }

    /// Fits `model` on the accepted targets.
    pub fn fit(&self, model: Model) -> Result<Calibration, CalibrationError> {
        let pairs: Vec<([f64; 2], [f64; 2])> = self
            .results()
            .filter(|r| r.accepted(&self.plan))
            .filter_map(|r| r.window.as_ref().ok().map(|w| (w.raw, r.target_px)))
            .collect();
        Calibration::fit(model, &pairs)
    }
}

/// Accuracy and precision at one validation target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointValidation {
    pub target_px: [f64; 2],
    /// Mean mapped gaze (px).
    pub mean_gaze_px: [f64; 2],
    /// Angle between the target and the mean gaze (degrees).
    pub accuracy_deg: f64,
    /// RMS of the angles between successive samples (degrees).
    pub precision_rms_deg: f64,
    /// Root mean square angular distance of the samples from their mean (degrees).
    pub precision_std_deg: f64,
    pub samples: usize,
}

/// A validation run's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validation {
    pub points: Vec<PointValidation>,
    /// Means over the points.
    pub accuracy_deg: f64,
    pub precision_rms_deg: f64,
    pub precision_std_deg: f64,
}

/// Validates `calibration` on separate targets: `runs` holds, per target,
/// its position and the raw samples taken while it was shown (the collect
/// phase). Angles use the display geometry (eye position and distance).
pub fn validate(
    calibration: &Calibration,
    geometry: &ScreenGeometry,
    runs: &[([f64; 2], Vec<TimedPoint>)],
) -> Result<Validation, CalibrationError> {
    let mut points = Vec::new();
    for (index, (target, samples)) in runs.iter().enumerate() {
        let gaze: Vec<[f64; 2]> = samples
            .iter()
            .filter_map(|s| s.raw.and_then(|r| calibration.map(r)))
            .collect();
        if gaze.len() < 2 {
            return Err(CalibrationError::Target {
                index,
                reason: format!("{} valid samples; at least 2 are needed", gaze.len()),
            });
        }
        let n = gaze.len() as f64;
        let mean = [
            gaze.iter().map(|p| p[0]).sum::<f64>() / n,
            gaze.iter().map(|p| p[1]).sum::<f64>() / n,
        ];
        let angle = |a: [f64; 2], b: [f64; 2]| geometry.eccentricity_deg(a, b);
        let s2s: f64 = gaze
            .windows(2)
            .map(|w| angle(w[0], w[1]).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        let std: f64 = gaze.iter().map(|p| angle(mean, *p).powi(2)).sum::<f64>() / n;
        points.push(PointValidation {
            target_px: *target,
            mean_gaze_px: mean,
            accuracy_deg: angle(*target, mean),
            precision_rms_deg: s2s.sqrt(),
            precision_std_deg: std.sqrt(),
            samples: gaze.len(),
        });
    }
    if points.is_empty() {
        return Err(CalibrationError::TooFewPoints {
            model: calibration.model,
            need: 1,
            got: 0,
        });
    }
    let m = points.len() as f64;
    let mean = |f: fn(&PointValidation) -> f64| points.iter().map(f).sum::<f64>() / m;
    Ok(Validation {
        accuracy_deg: mean(|p| p.accuracy_deg),
        precision_rms_deg: mean(|p| p.precision_rms_deg),
        precision_std_deg: mean(|p| p.precision_std_deg),
        points,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A tracker whose raw output is a known distortion of the screen.
    fn distort(model: Model, p: [f64; 2]) -> [f64; 2] {
        let [x, y] = [p[0] / 1280.0, p[1] / 1024.0];
        let q = match model {
            Model::Affine => [0.8 * x + 0.1 * y + 0.05, -0.05 * x + 0.7 * y + 0.1],
            Model::Homography => {
                let w = 1.0 + 0.15 * x - 0.1 * y;
                [
                    (0.8 * x + 0.1 * y + 0.05) / w,
                    (0.1 * x + 0.75 * y + 0.1) / w,
                ]
            }
            Model::Polynomial2 => [
                0.1 + 0.8 * x + 0.05 * y + 0.08 * x * x - 0.04 * x * y,
                0.05 + 0.02 * x + 0.85 * y + 0.06 * y * y + 0.03 * x * y,
            ],
        };
        [512.0 * q[0], 512.0 * q[1]]
    }

    fn session(model: Model, targets: &[[f64; 2]], noise: f64, seed: u64) -> Procedure {
        let mut plan = Plan::grid(9, (1280, 1024), 0.1, Order::RowMajor).expect("9 points");
        plan.targets_px = targets.to_vec();
        let mut p = Procedure::new(plan);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let gauss = Normal::new(0.0, noise.max(1e-12)).expect("sigma");
        let mut t = 0u64;
        while let Some((_, target)) = p.target() {
            let r = distort(model, target);
            p.feed(TimedPoint {
                t_us: t,
                raw: Some([r[0] + gauss.sample(&mut rng), r[1] + gauss.sample(&mut rng)]),
            });
            t += 4_000; // 250 Hz
        }
        p
    }

    fn grid(k: usize) -> Vec<[f64; 2]> {
        Plan::grid(k, (1280, 1024), 0.08, Order::RowMajor)
            .expect("grid")
            .targets_px
    }

    #[test]
    fn each_model_recovers_its_own_distortion() {
        for (model, targets) in [
            (Model::Affine, grid(9)),
            (Model::Homography, grid(9)),
            (Model::Polynomial2, grid(16)),
        ] {
            let p = session(model, &targets, 0.3, 1);
            let c = p.fit(model).expect("fits");
            // Check between the targets too.
            let mut worst: f64 = 0.0;
            for t in grid(25) {
                let got = c.map(distort(model, t)).expect("maps");
                worst = worst.max((got[0] - t[0]).hypot(got[1] - t[1]));
            }
            assert!(worst < 3.0, "{model:?}: worst error {worst} px");
            assert!(c.rms_residual_px < 3.0, "{model:?}: {}", c.rms_residual_px);
        }
    }

    #[test]
    fn an_affine_fit_cannot_follow_a_projective_distortion() {
        let p = session(Model::Homography, &grid(9), 0.0, 2);
        let affine = p.fit(Model::Affine).expect("fits");
        let homography = p.fit(Model::Homography).expect("fits");
        assert!(
            homography.rms_residual_px < 1e-6,
            "{}",
            homography.rms_residual_px
        );
        assert!(affine.rms_residual_px > 5.0, "{}", affine.rms_residual_px);
    }

    #[test]
    fn degenerate_input_is_an_error() {
        let line: Vec<([f64; 2], [f64; 2])> = (0..9)
            .map(|i| {
                let t = [100.0 * f64::from(i), 50.0 * f64::from(i)];
                (distort(Model::Affine, t), t)
            })
            .collect();
        for m in [Model::Affine, Model::Homography, Model::Polynomial2] {
            assert!(
                matches!(
                    Calibration::fit(m, &line),
                    Err(CalibrationError::Degenerate { .. })
                ),
                "{m:?} on collinear targets"
            );
        }
        let same: Vec<_> = (0..9).map(|_| ([1.0, 2.0], [640.0, 512.0])).collect();
        assert!(matches!(
            Calibration::fit(Model::Affine, &same),
            Err(CalibrationError::TooFewPoints { got: 1, .. })
        ));
        let five: Vec<_> = grid(9)[..5]
            .iter()
            .map(|t| (distort(Model::Affine, *t), *t))
            .collect();
        assert!(matches!(
            Calibration::fit(Model::Polynomial2, &five),
            Err(CalibrationError::TooFewPoints {
                need: 6,
                got: 5,
                ..
            })
        ));
        let mut nan = five.clone();
        nan[2].0[1] = f64::NAN;
        assert!(matches!(
            Calibration::fit(Model::Affine, &nan),
            Err(CalibrationError::NonFinite(_))
        ));
        // All samples invalid: the target is rejected, never averaged.
        let mut p = Procedure::new(Plan::grid(5, (1280, 1024), 0.1, Order::RowMajor).expect("5"));
        let mut t = 0;
        while !p.done() {
            p.feed(TimedPoint { t_us: t, raw: None });
            t += 10_000;
        }
        assert_eq!(p.rejected().len(), 5);
        assert!(p.fit(Model::Affine).is_err());
    }

    #[test]
    fn the_stable_window_ignores_the_saccade_and_outliers() {
        let mut s: Vec<TimedPoint> = (0..100)
            .map(|i| TimedPoint {
                t_us: i * 4_000,
                // Moving for the first 40 samples, then still at (10, 20).
                raw: Some(if i < 40 {
                    [i as f64, 2.0 * i as f64]
                } else {
                    [10.0 + 0.01 * (i % 3) as f64, 20.0]
                }),
            })
            .collect();
        s[70].raw = Some([500.0, 500.0]); // a spike
        s[71].raw = None; // a dropout
        let w = stable_window(&s, 200_000, 5).expect("window");
        assert!(
            (w.raw[0] - 10.01).abs() < 0.02 && (w.raw[1] - 20.0).abs() < 1e-9,
            "{w:?}"
        );
        assert!(w.start_us >= 40 * 4_000);
    }

    /// Arrival jitter must not drift the targets off the samples: the
    /// schedule keeps every target on its own stop for a long run, and a
    /// target with no data at all is closed empty (rejected).
    #[test]
    fn the_schedule_does_not_drift_with_jittered_arrivals_or_gaps() {
        use rand::Rng;
        let plan = Plan::grid(16, (1280, 1024), 0.1, Order::RowMajor).expect("plan");
        let total = u64::from(plan.settle_ms + plan.collect_ms) * 1000;
        let mut p = Procedure::new(plan.clone());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        // 60 Hz (1.2 s is exactly 72 periods), arrivals 0–3 ms late; stop k
        // is where the eye is; target 5 sends nothing at all.
        for k in 0..(16 * 72 + 2) {
            let truth = (f64::from(k) * 1e6 / 60.0).round() as u64;
            let stop = (truth / total) as usize;
            if stop == 5 {
                continue;
            }
            let at = plan.targets_px[stop.min(15)];
            p.feed(TimedPoint {
                t_us: truth + rng.random_range(0..3_000),
                raw: Some(at),
            });
        }
        assert!(p.done());
        assert_eq!(p.rejected(), vec![5]);
        for r in p.results() {
            for s in &r.samples {
                assert_eq!(s.raw, Some(r.target_px), "a sample of another stop");
            }
        }
    }

    #[test]
    fn validation_reports_degrees() {
        let g = foveation::Display {
            name: "t".into(),
            resolution_px: (1280, 1024),
            size_mm: (337.9, 270.3),
            eye_distance_mm: 600.0,
            eye_point_px: None,
        }
        .geometry()
        .expect("display");
        let p = session(Model::Affine, &grid(9), 0.0, 3);
        let c = p.fit(Model::Affine).expect("fits");
        // A validation target where the person looks 20 px right of it,
        // with ±2 px alternating jitter.
        let target = [400.0, 300.0];
        let samples: Vec<TimedPoint> = (0..50)
            .map(|i| {
                let dx = if i % 2 == 0 { 22.0 } else { 18.0 };
                TimedPoint {
                    t_us: i * 4_000,
                    raw: Some(distort(Model::Affine, [target[0] + dx, target[1]])),
                }
            })
            .collect();
        let v = validate(&c, &g, &[(target, samples)]).expect("validates");
        let px_deg = g.eccentricity_deg(target, [target[0] + 20.0, target[1]]);
        assert!(
            (v.accuracy_deg - px_deg).abs() < 1e-3,
            "{} vs {px_deg}",
            v.accuracy_deg
        );
        let four = g.eccentricity_deg([target[0] + 18.0, target[1]], [target[0] + 22.0, target[1]]);
        assert!(
            (v.precision_rms_deg - four).abs() < 1e-3,
            "{}",
            v.precision_rms_deg
        );
        assert!(
            (v.precision_std_deg - four / 2.0).abs() < 1e-3,
            "{}",
            v.precision_std_deg
        );
        assert!(validate(&c, &g, &[(target, vec![])]).is_err());
    }

    #[test]
    fn calibrations_round_trip_through_ron() {
        let c = session(Model::Homography, &grid(9), 0.2, 4)
            .fit(Model::Homography)
            .expect("fits");
        let text = ron::ser::to_string_pretty(&c, ron::ser::PrettyConfig::default()).expect("ron");
        let back: Calibration = ron::from_str(&text).expect("parses");
        assert_eq!(back.map([100.0, 200.0]), c.map([100.0, 200.0]));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Any input — huge, tiny, repeated, collinear, NaN — gives a
        /// mapping that maps finitely or an error; never NaN.
        #[test]
        fn fits_never_produce_nan(
            pts in prop::collection::vec(
                ((-1e12f64..1e12, -1e12f64..1e12), (prop_oneof![Just(0.0), -1e-9f64..1e-9, 0.0f64..2000.0], 0.0f64..2000.0)),
                0..12),
            model in prop_oneof![Just(Model::Affine), Just(Model::Homography), Just(Model::Polynomial2)],
        ) {
            let pairs: Vec<([f64; 2], [f64; 2])> = pts.iter().map(|((a, b), (c, d))| ([*a, *b], [*c, *d])).collect();
            if let Ok(c) = Calibration::fit(model, &pairs) {
                prop_assert!(c.rms_residual_px.is_finite());
                for (r, _) in &pairs {
                    if let Some(p) = c.map(*r) {
                        prop_assert!(p[0].is_finite() && p[1].is_finite());
                    }
                }
            }
        }
    }
}
