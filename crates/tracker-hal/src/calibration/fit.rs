//! The mapping from raw tracker coordinates to screen pixels: affine (6
//! parameters), homography (8, projective) or second-order polynomial (12),
//! fitted by least squares (SVD, `nalgebra`) on coordinates normalised to
//! zero mean and mean distance √2 (Hartley 1997, "In defense of the
//! eight-point algorithm", IEEE TPAMI 19(6)), so the conditioning does not
//! depend on the units. The homography is the normalised direct linear
//! transform (Hartley & Zisserman 2004, *Multiple View Geometry*, 2nd ed.,
//! §4.1 and Algorithm 4.2).
//!
//! Degenerate input — too few distinct targets for the model, collinear
//! targets, non-finite values — is an error that says so, never NaN and
//! never a silently wrong mapping.

use nalgebra::{DMatrix, DVector};
use screen_geometry::{fmt_f64, MAX_SIDE_PX};
use serde::{Deserialize, Serialize};

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
    /// Fewer distinct targets with data than the model needs.
    #[error("{model:?} needs at least {need} distinct targets with data, got {got}")]
    TooFewPoints {
        /// The model asked for.
        model: Model,
        /// Distinct targets it needs.
        need: usize,
        /// Distinct targets with data.
        got: usize,
    },
    /// The targets do not determine the fit (collinear, or too close together).
    #[error("the targets are degenerate for {model:?} (collinear, or too close to each other): the fit is not determined")]
    Degenerate {
        /// The model asked for.
        model: Model,
    },
    /// A coordinate in the input is NaN or infinite; the message says which.
    #[error("non-finite coordinate in the input: {0}")]
    NonFinite(String),
    /// A target's data is unusable; the message says why.
    #[error("target {index}: {reason}")]
    Target {
        /// The target's index in the plan.
        index: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// The fit is determined but the mapping fails [`Calibration::check`]
    /// (it collapses the tracker's range, folds it, or leaves the screen).
    #[error("the fitted mapping is unusable: {0}")]
    Unusable(String),
}

/// Hartley normalisation: `(p − c)·s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Normaliser {
    /// Mean of the points, `c`.
    pub centre: [f64; 2],
    /// Factor `s` that makes the mean distance from `c` equal √2.
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
    /// The mapping's form (affine, homography or second-order polynomial).
    pub model: Model,
    /// Parameters in normalised coordinates (see [`Model`] for the count).
    pub params: Vec<f64>,
    /// Normalisation of the raw (tracker) points.
    pub raw: Normaliser,
    /// Normalisation of the screen (pixel) points.
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
    /// [`stable_window`](super::stable_window)).
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
        // The same test as a calibration read from a file: a fit that is
        // determined can still collapse or fold the tracker's range.
        c.check()
            .map_err(|(_, reason)| CalibrationError::Unusable(reason))?;
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

/// How far (in normalised units) the normalised tracker range may reach
/// from the origin: a fit puts its points within a few units of it.
const NORMALISED_REACH: f64 = 1e6;

/// How far from zero the raw range a calibration is checked over may reach
/// (tracker units): far beyond any device's, well within `f64`.
const MAX_RAW_UNITS: f64 = 1e12;

/// Smallest ratio of the homography's denominator, over the tracker's
/// range, to its largest: below it the mapping nears its horizon.
const MIN_DENOMINATOR_RATIO: f64 = 0.1;

/// Smallest side (px) of the screen rectangle a calibration is checked
/// against (its targets' bounding box): targets closer together than this
/// determine no usable mapping.
pub const MIN_TARGET_SPREAD_PX: f64 = 16.0;

/// Smallest singular value of the mapping's Jacobian over the tracker's
/// range, in screen pixels per tracker range (the raw range's width and
/// height each scaled to 1), as a fraction of the diagonal of the targets'
/// rectangle: crossing the tracker's whole range in its narrowest
/// direction must move the gaze by at least 1/16 of the targets' diagonal
/// (a fitted calibration moves it about 1.5 times the targets' spread). A
/// rank-1 mapping (every gaze on a line) has 0; parameters of 1e-300 or a
/// screen scale of 1e308 (every gaze on one point) have about 0.
pub const MIN_STRETCH: f64 = 1.0 / 16.0;

/// Largest condition number (largest over smallest singular value) of that
/// Jacobian anywhere on the tracker's range: a mapping may stretch one
/// direction at most this much more than the other (a 16:9 target grid
/// gives about 1.8).
pub const MAX_CONDITION: f64 = 64.0;

impl Calibration {
    /// Parameters `model` needs.
    pub fn param_count(model: Model) -> usize {
        match model {
            Model::Affine => 6,
            Model::Homography => 9,
            Model::Polynomial2 => 12,
        }
    }

    /// The raw range the calibration is checked over and the screen
    /// rectangle it must map near, both `(x0, y0, x1, y1)`.
    ///
    /// With at least [`Model::min_points`] fitted pairs: the raw points'
    /// bounding box grown by a quarter of its size on every side (the
    /// targets sit inside the screen's margins; the tracker reaches its
    /// edges), and the targets' bounding box. Without (a hand-written
    /// file): the normalisers' regions, `centre ± 2 / scale` (normalised
    /// coordinates have mean distance √2 from the origin).
    pub fn ranges(&self) -> ([f64; 4], [f64; 4]) {
        let bbox = |pts: &mut dyn Iterator<Item = [f64; 2]>| {
            pts.fold(
                [f64::INFINITY, f64::INFINITY, -f64::INFINITY, -f64::INFINITY],
                |b, p| {
                    [
                        b[0].min(p[0]),
                        b[1].min(p[1]),
                        b[2].max(p[0]),
                        b[3].max(p[1]),
                    ]
                },
            )
        };
        if self.points.len() >= self.model.min_points() {
            let r = bbox(&mut self.points.iter().map(|p| p.0));
            let (gx, gy) = ((r[2] - r[0]) / 4.0, (r[3] - r[1]) / 4.0);
            let raw = [r[0] - gx, r[1] - gy, r[2] + gx, r[3] + gy];
            (raw, bbox(&mut self.points.iter().map(|p| p.1)))
        } else {
            let around = |n: &Normaliser| {
                let h = 2.0 / n.scale;
                [
                    n.centre[0] - h,
                    n.centre[1] - h,
                    n.centre[0] + h,
                    n.centre[1] + h,
                ]
            };
            (around(&self.raw), around(&self.screen))
        }
    }

    /// Checks a calibration read from a file: every value, and that it maps
    /// the whole raw range ([`Calibration::ranges`]) onto finite points
    /// within one screen diagonal of the screen, a homography's denominator
    /// keeping its sign and staying away from zero. The error names the
    /// field (`params[4]`, `screen.scale`, `points[2]`, …).
    pub fn check(&self) -> Result<(), (String, String)> {
        let need = Self::param_count(self.model);
        if self.params.len() != need {
            return Err((
                "params".into(),
                format!(
                    "{:?} needs {need} parameters, found {}",
                    self.model,
                    self.params.len()
                ),
            ));
        }
        if let Some((i, v)) = self.params.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err((
                format!("params[{i}]"),
                format!(
                    "{:?} needs {need} finite parameters; parameter {i} is {v}",
                    self.model
                ),
            ));
        }
        for (name, n) in [("raw", &self.raw), ("screen", &self.screen)] {
            for k in 0..2 {
                if !n.centre[k].is_finite() {
                    return Err((
                        format!("{name}.centre.{k}"),
                        format!("{} must be finite", n.centre[k]),
                    ));
                }
            }
            if !(n.scale.is_finite() && n.scale > 0.0) {
                return Err((
                    format!("{name}.scale"),
                    format!(
                        "{} must be a finite number greater than zero",
                        fmt_f64(n.scale)
                    ),
                ));
            }
        }
        let max = f64::from(MAX_SIDE_PX);
        // Targets lie within a screen, whose diagonal is at most √2·16384:
        // their mean distance from their centre is no more.
        if self.screen.scale < 1.0 / max {
            return Err((
                "screen.scale".into(),
                format!(
                    "{} is below 1/{MAX_SIDE_PX}: the targets would spread wider than any screen",
                    fmt_f64(self.screen.scale)
                ),
            ));
        }
        for k in 0..2 {
            if !(0.0..=max).contains(&self.screen.centre[k]) {
                return Err((
                    format!("screen.centre.{k}"),
                    format!(
                        "{} px: the targets' centre must be on a screen (0 to {MAX_SIDE_PX} px)",
                        fmt_f64(self.screen.centre[k])
                    ),
                ));
            }
        }
        if !(self.rms_residual_px.is_finite() && self.rms_residual_px >= 0.0) {
            return Err((
                "rms_residual_px".into(),
                format!("{} must be zero or positive", fmt_f64(self.rms_residual_px)),
            ));
        }
        for (i, (r, t)) in self.points.iter().enumerate() {
            if !r.iter().chain(t).all(|v| v.is_finite()) {
                return Err((
                    format!("points[{i}]"),
                    format!("{r:?} → {t:?} is not finite"),
                ));
            }
            if !t.iter().all(|v| (0.0..=max).contains(v)) {
                return Err((
                    format!("points[{i}]"),
                    format!(
                        "target ({}, {}) px is off any screen (0 to {MAX_SIDE_PX} px)",
                        fmt_f64(t[0]),
                        fmt_f64(t[1])
                    ),
                ));
            }
        }
        let (raw, screen) = self.ranges();
        // No tracker reports raw units this large (pixels, ISCAN counts,
        // HID micrometres); a range beyond it only overflows arithmetic.
        if let Some(v) = raw.iter().find(|v| v.is_nan() || v.abs() > MAX_RAW_UNITS) {
            return Err((
                if self.points.len() >= self.model.min_points() {
                    "points".into()
                } else {
                    "raw.scale".into()
                },
                format!(
                    "the raw range reaches {}: beyond ±{} tracker units",
                    fmt_f64(*v),
                    fmt_f64(MAX_RAW_UNITS)
                ),
            ));
        }
        let corners = [
            [raw[0], raw[1]],
            [raw[2], raw[1]],
            [raw[0], raw[3]],
            [raw[2], raw[3]],
        ];
        let normalised = corners.map(|p| self.raw.apply(p));
        let reach = normalised.iter().flatten().fold(0.0f64, |m, v| {
            if v.is_finite() {
                m.max(v.abs())
            } else {
                f64::INFINITY
            }
        });
        if !(raw.iter().all(|v| v.is_finite()) && reach <= NORMALISED_REACH) {
            return Err((
                "raw".into(),
                format!(
                    "the normaliser (centre {:?}, scale {}) takes the raw range ({}, {})–({}, {}) \
                     beyond ±{} normalised units",
                    self.raw.centre,
                    fmt_f64(self.raw.scale),
                    fmt_f64(raw[0]),
                    fmt_f64(raw[1]),
                    fmt_f64(raw[2]),
                    fmt_f64(raw[3]),
                    fmt_f64(NORMALISED_REACH)
                ),
            ));
        }
        if self.model == Model::Homography {
            // The denominator is affine in x: its extremes over the range
            // are at the corners.
            let h = &self.params;
            let w = normalised.map(|x| h[6] * x[0] + h[7] * x[1] + h[8]);
            let most = w.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let least = w.iter().fold(f64::INFINITY, |m, v| m.min(v.abs()));
            let same_sign = w.iter().all(|v| *v > 0.0) || w.iter().all(|v| *v < 0.0);
            if !(same_sign && least >= MIN_DENOMINATOR_RATIO * most) {
                return Err((
                    "params".into(),
                    format!(
                        "the homography's denominator goes from {} to {} over the raw range \
                         ({}, {})–({}, {}): {}; its horizon is too near",
                        fmt_f64(w.iter().copied().fold(f64::INFINITY, f64::min)),
                        fmt_f64(w.iter().copied().fold(-f64::INFINITY, f64::max)),
                        fmt_f64(raw[0]),
                        fmt_f64(raw[1]),
                        fmt_f64(raw[2]),
                        fmt_f64(raw[3]),
                        if same_sign {
                            "it nears zero"
                        } else {
                            "it changes sign"
                        }
                    ),
                ));
            }
        }
        crate::mapping::check_grid(raw, screen, |p| self.map(p))
            .map_err(|m| ("params".into(), m))?;
        self.check_conditioning(raw, screen)
    }

    /// The area part of [`Calibration::check`]: the targets' rectangle is
    /// at least [`MIN_TARGET_SPREAD_PX`] a side, and over a grid of the raw
    /// range (9 × 9 points, corners included) the Jacobian of the mapping,
    /// in pixels per raw range, keeps the sign of its determinant (the
    /// mapping never folds the range over itself), has its smallest
    /// singular value at least [`MIN_STRETCH`] of the targets' diagonal and
    /// its condition number at most [`MAX_CONDITION`]. So the tracker's
    /// range lands on a region of the screen of non-trivial area, never on
    /// a line or a point.
    fn check_conditioning(&self, raw: [f64; 4], screen: [f64; 4]) -> Result<(), (String, String)> {
        let (sw, sh) = (screen[2] - screen[0], screen[3] - screen[1]);
        if !(sw >= MIN_TARGET_SPREAD_PX && sh >= MIN_TARGET_SPREAD_PX) {
            let field = if self.points.len() >= self.model.min_points() {
                "points"
            } else {
                "screen.scale"
            };
            return Err((
                field.into(),
                format!(
                    "the targets span {} × {} px: a calibration's targets must spread over at \
                     least {MIN_TARGET_SPREAD_PX} px in each direction",
                    fmt_f64(sw),
                    fmt_f64(sh)
                ),
            ));
        }
        let diagonal = sw.hypot(sh);
        let mut sign = 0.0f64;
        for (p, big, small, det) in self.jacobian_grid(raw) {
            let at = || format!("({}, {})", fmt_f64(p[0]), fmt_f64(p[1]));
            if !(big.is_finite() && small.is_finite()) {
                return Err((
                    "params".into(),
                    format!(
                        "the mapping's slope at the tracker point {} is not finite",
                        at()
                    ),
                ));
            }
            if small < MIN_STRETCH * diagonal {
                return Err((
                    "params".into(),
                    format!(
                        "at the tracker point {} the mapping squeezes the tracker's range to \
                         {} px in its narrowest direction (at least {} px needed, 1/{} of the \
                         targets' {} px diagonal): it maps the gaze onto a line or a point",
                        at(),
                        fmt_f64(small),
                        fmt_f64(MIN_STRETCH * diagonal),
                        (1.0 / MIN_STRETCH).round(),
                        fmt_f64(diagonal)
                    ),
                ));
            }
            if big > MAX_CONDITION * small {
                return Err((
                    "params".into(),
                    format!(
                        "at the tracker point {} the mapping stretches one direction {}× \
                         more than the other (at most {MAX_CONDITION}×): it nearly maps the \
                         gaze onto a line",
                        at(),
                        fmt_f64(big / small)
                    ),
                ));
            }
            if sign == 0.0 {
                sign = det.signum();
            } else if det.signum() != sign {
                return Err((
                    "params".into(),
                    format!(
                        "the mapping folds the tracker's range over itself (its orientation \
                         flips at the tracker point {}): two gazes would land on one point",
                        at()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Over a 9 × 9 grid of the raw range `raw` (corners included): each
    /// point, and the Jacobian's largest and smallest singular values and
    /// determinant there, in screen pixels per raw range (the range's width
    /// and height each scaled to 1).
    fn jacobian_grid(&self, raw: [f64; 4]) -> Vec<([f64; 2], f64, f64, f64)> {
        // Column scales (s_raw·width) / s_screen; the normalised range is
        // within ±NORMALISED_REACH (checked before this).
        let col = [
            self.raw.scale * (raw[2] - raw[0]) / self.screen.scale,
            self.raw.scale * (raw[3] - raw[1]) / self.screen.scale,
        ];
        const N: usize = 9;
        let t = |k: usize| k as f64 / (N - 1) as f64;
        let mut out = Vec::with_capacity(N * N);
        for i in 0..N {
            for j in 0..N {
                let p = [
                    raw[0] + (raw[2] - raw[0]) * t(i),
                    raw[1] + (raw[3] - raw[1]) * t(j),
                ];
                let jf = self.jacobian_normalised(self.raw.apply(p));
                let m = [
                    [jf[0][0] * col[0], jf[0][1] * col[1]],
                    [jf[1][0] * col[0], jf[1][1] * col[1]],
                ];
                let (big, small, det) = singular_values(m);
                out.push((p, big, small, det));
            }
        }
        out
    }

    /// ∂u/∂x of the normalised mapping (u the normalised screen point, x
    /// the normalised raw point), rows u, v; columns x, y.
    fn jacobian_normalised(&self, x: [f64; 2]) -> [[f64; 2]; 2] {
        let h = &self.params;
        let [px, py] = x;
        match self.model {
            Model::Affine => [[h[0], h[1]], [h[3], h[4]]],
            // Monomials 1, x, y, xy, x², y² per axis.
            Model::Polynomial2 => {
                let row = |o: usize| {
                    [
                        h[o + 1] + h[o + 3] * py + 2.0 * h[o + 4] * px,
                        h[o + 2] + h[o + 3] * px + 2.0 * h[o + 5] * py,
                    ]
                };
                [row(0), row(6)]
            }
            Model::Homography => {
                let w = h[6] * px + h[7] * py + h[8];
                let u = (h[0] * px + h[1] * py + h[2]) / w;
                let v = (h[3] * px + h[4] * py + h[5]) / w;
                [
                    [(h[0] - u * h[6]) / w, (h[1] - u * h[7]) / w],
                    [(h[3] - v * h[6]) / w, (h[4] - v * h[7]) / w],
                ]
            }
        }
    }
}

/// Singular values (largest, smallest) and determinant of a 2 × 2 matrix,
/// by the stable half-sum/half-difference of two hypotenuses.
fn singular_values(m: [[f64; 2]; 2]) -> (f64, f64, f64) {
    let [[a, b], [c, d]] = m;
    let p = (a + d).hypot(c - b);
    let q = (a - d).hypot(c + b);
    ((p + q) / 2.0, (p - q).abs() / 2.0, a * d - b * c)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::testing::{distort, grid, procedure_on};
    use crate::calibration::{Order, Plan, Procedure, TimedPoint};
    use proptest::prelude::*;

    #[test]
    fn each_model_recovers_its_own_distortion() {
        for (model, targets) in [
            (Model::Affine, grid(9)),
            (Model::Homography, grid(9)),
            (Model::Polynomial2, grid(16)),
        ] {
            let p = procedure_on(model, &targets, 0.3, 1);
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
        let p = procedure_on(Model::Homography, &grid(9), 0.0, 2);
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
    fn calibrations_round_trip_through_ron() {
        let c = procedure_on(Model::Homography, &grid(9), 0.2, 4)
            .fit(Model::Homography)
            .expect("fits");
        let text = ron::ser::to_string_pretty(&c, ron::ser::PrettyConfig::default()).expect("ron");
        let back: Calibration = ron::from_str(&text).expect("parses");
        assert_eq!(back.map([100.0, 200.0]), c.map([100.0, 200.0]));
    }

    #[test]
    fn fitted_calibrations_pass_their_own_check() {
        for (model, targets) in [
            (Model::Affine, grid(9)),
            (Model::Homography, grid(9)),
            (Model::Polynomial2, grid(16)),
        ] {
            let c = procedure_on(model, &targets, 0.3, 1)
                .fit(model)
                .expect("fits");
            assert_eq!(c.check(), Ok(()), "{model:?}");
        }
    }

    #[test]
    fn calibrations_that_miss_the_screen_fail_their_check() {
        let good = procedure_on(Model::Homography, &grid(9), 0.3, 1)
            .fit(Model::Homography)
            .expect("fits");
        let mut c = good.clone();
        c.params[4] = f64::NAN;
        let (field, msg) = c.check().unwrap_err();
        assert_eq!(field, "params[4]");
        assert!(msg.contains("parameter 4 is NaN"), "{msg}");
        let mut c = good.clone();
        c.screen.scale = 1e-300;
        let (field, msg) = c.check().unwrap_err();
        assert_eq!(field, "screen.scale");
        assert!(msg.len() < 200, "{msg}");
        // Put the horizon through the middle of the raw range.
        let mut c = good.clone();
        c.params[6] = 3.0;
        assert_eq!(c.check().unwrap_err().0, "params");
        let mut c = good.clone();
        c.raw.scale = 1e300;
        assert_eq!(c.check().unwrap_err().0, "raw");
        let mut c = good;
        c.points[3].1[0] = -1e308;
        assert_eq!(c.check().unwrap_err().0, "points[3]");
    }

    /// A hand-written calibration (no points): `model` with `params`,
    /// raw and screen normalisers as a 1280 × 1024 calibration would have.
    fn written(model: Model, params: Vec<f64>) -> Calibration {
        Calibration {
            model,
            params,
            raw: Normaliser {
                centre: [256.0, 256.0],
                scale: std::f64::consts::SQRT_2 / 150.0,
            },
            screen: Normaliser {
                centre: [640.0, 512.0],
                scale: std::f64::consts::SQRT_2 / 380.0,
            },
            rms_residual_px: 0.5,
            points: Vec::new(),
        }
    }

    #[test]
    fn calibrations_that_collapse_the_tracker_range_fail_their_check() {
        let id_affine = vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let id_homography = vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        assert_eq!(written(Model::Affine, id_affine.clone()).check(), Ok(()));
        assert_eq!(
            written(Model::Homography, id_homography.clone()).check(),
            Ok(())
        );
        let refused = |c: Calibration, what: &str| {
            let (field, msg) = c.check().expect_err(what);
            assert!(msg.len() < 400, "{what}: {msg}");
            (field, msg)
        };
        // Rank 1: v = u, every gaze on the diagonal.
        let (f, m) = refused(
            written(Model::Affine, vec![1.0, 0.5, 0.0, 1.0, 0.5, 0.0]),
            "rank-1 affine",
        );
        assert!(f == "params" && m.contains("line or a point"), "{m}");
        let (f, _) = refused(
            written(
                Model::Homography,
                vec![1.0, 0.5, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            ),
            "rank-1 homography",
        );
        assert_eq!(f, "params");
        // Every gaze on one point.
        let (f, _) = refused(
            written(Model::Affine, vec![1e-300, 0.0, 0.0, 0.0, 1e-300, 0.0]),
            "parameters of 1e-300",
        );
        assert_eq!(f, "params");
        let mut c = written(Model::Affine, id_affine.clone());
        c.screen.scale = 1e308;
        let (f, m) = refused(c, "a screen scale of 1e308");
        assert!(f == "screen.scale" && m.contains("16 px"), "{m}");
        // Nearly rank 1: one direction squeezed 1000×.
        let (_, m) = refused(
            written(Model::Affine, vec![1.0, 0.0, 0.0, 0.0, 1e-3, 0.0]),
            "squeezed",
        );
        assert!(m.contains("narrowest direction"), "{m}");
        // A fold: the polynomial's x-derivative 1 + 2·0.6·x changes sign
        // inside the range (x ≈ −0.83 normalised).
        let (_, m) = refused(
            written(
                Model::Polynomial2,
                vec![0.0, 1.0, 0.0, 0.0, 0.6, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            ),
            "folded",
        );
        assert!(m.contains("folds") || m.contains("narrowest"), "{m}");
        // A fitted calibration with one point moved onto the others' line
        // keeps its targets' rectangle, but a tracker range of 0 width.
        let good = procedure_on(Model::Affine, &grid(9), 0.3, 1)
            .fit(Model::Affine)
            .expect("fits");
        let mut c = good.clone();
        for p in &mut c.points {
            p.0[0] = 100.0;
        }
        assert!(c.check().is_err());
    }

    #[test]
    fn a_fit_that_collapses_the_range_is_an_error() {
        // A tracker that reports x and y moving together (one photodiode
        // wired to both): rank 1 in the data, caught by the fit's rank test,
        // or by the conditioning check when noise makes it rank 2.
        let pairs: Vec<([f64; 2], [f64; 2])> = grid(9)
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let r = t[0] / 4.0 + t[1] / 8.0;
                ([r, r * 0.5 + 1e-6 * (i as f64).sin()], *t)
            })
            .collect();
        for m in [Model::Affine, Model::Homography, Model::Polynomial2] {
            assert!(Calibration::fit(m, &pairs).is_err(), "{m:?}");
        }
    }

    /// Fitted calibrations stay far inside the bounds: noisy fits of every
    /// model on 5, 9 and 16 targets keep the smallest stretch at several
    /// times MIN_STRETCH and the condition number far below MAX_CONDITION.
    #[test]
    fn fitted_calibrations_stay_well_inside_the_conditioning_bounds() {
        let (mut least, mut most) = (f64::INFINITY, 0.0f64);
        for seed in 0..20 {
            for (model, targets) in [
                (Model::Affine, grid(5)),
                (Model::Affine, grid(9)),
                (Model::Homography, grid(9)),
                (Model::Polynomial2, grid(16)),
            ] {
                let c = procedure_on(model, &targets, 2.0, seed)
                    .fit(model)
                    .expect("a noisy fit passes its check");
                let (raw, screen) = c.ranges();
                let diagonal = (screen[2] - screen[0]).hypot(screen[3] - screen[1]);
                for (_, big, small, _) in c.jacobian_grid(raw) {
                    least = least.min(small / diagonal);
                    most = most.max(big / small);
                }
            }
        }
        println!(
            "fitted: smallest stretch {least:.3} of the diagonal, largest condition {most:.2}"
        );
        assert!(least > 4.0 * MIN_STRETCH, "{least}");
        assert!(most < MAX_CONDITION / 8.0, "{most}");
    }

    prop_compose! {
        /// A random affine or homography in normalised coordinates: a
        /// rotation, two scales, a shear and (homography) a small
        /// perspective part.
        fn arb_mapping()(
            model in prop_oneof![Just(Model::Affine), Just(Model::Homography)],
            angle in 0.0f64..std::f64::consts::TAU,
            sx in prop_oneof![Just(0.0), 1e-300f64..1e-6, 1e-3f64..10.0, 1e6f64..1e300],
            sy in prop_oneof![Just(0.0), 1e-300f64..1e-6, 1e-3f64..10.0, 1e6f64..1e300],
            shear in -2.0f64..2.0,
            persp in (-0.2f64..0.2, -0.2f64..0.2),
            screen_scale in prop_oneof![1e-4f64..1.0, 1.0f64..1e308],
        ) -> Calibration {
            let (c, s) = (angle.cos(), angle.sin());
            // R · [[sx, shear·sx], [0, sy]]
            let m = [[c * sx, c * shear * sx - s * sy], [s * sx, s * shear * sx + c * sy]];
            let params = match model {
                Model::Affine => vec![m[0][0], m[0][1], 0.0, m[1][0], m[1][1], 0.0],
                _ => vec![m[0][0], m[0][1], 0.0, m[1][0], m[1][1], 0.0, persp.0, persp.1, 1.0],
            };
            let mut cal = written(model, params);
            cal.screen.scale = screen_scale;
            cal
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(500)))]

        /// Whatever a calibration file holds: accepted means the tracker's
        /// range lands on the screen as a region of non-trivial area —
        /// the 9 × 9 grid of the raw range maps to points that are
        /// finite, pairwise apart, and whose cells all keep one
        /// orientation and an area of at least (MIN_STRETCH·diagonal/8)²/2
        /// px (the Jacobian bound over one cell of the grid, to first
        /// order, with a margin of 4 for curvature).
        #[test]
        fn accepted_calibrations_map_the_range_onto_an_area(cal in arb_mapping()) {
            if cal.check().is_err() {
                return Ok(());
            }
            let (raw, screen) = cal.ranges();
            let diagonal = (screen[2] - screen[0]).hypot(screen[3] - screen[1]);
            prop_assert!(screen[2] - screen[0] >= MIN_TARGET_SPREAD_PX);
            const N: usize = 9;
            let at = |i: usize, j: usize| {
                let t = |k: usize| k as f64 / (N - 1) as f64;
                cal.map([raw[0] + (raw[2] - raw[0]) * t(i), raw[1] + (raw[3] - raw[1]) * t(j)])
            };
            let cell = MIN_STRETCH * diagonal / (N - 1) as f64;
            let mut sign = 0.0f64;
            for i in 0..N - 1 {
                for j in 0..N - 1 {
                    let (a, b, c) = (at(i, j), at(i + 1, j), at(i, j + 1));
                    let (Some(a), Some(b), Some(c)) = (a, b, c) else {
                        return Err(TestCaseError::fail("an accepted mapping has a horizon"));
                    };
                    let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                    prop_assert!(cross.abs() / 2.0 >= cell * cell / 8.0, "cell ({i}, {j}): {cross}");
                    if sign == 0.0 {
                        sign = cross.signum();
                    }
                    prop_assert_eq!(cross.signum(), sign);
                }
            }
        }

        /// A well-conditioned mapping of a usable size is accepted.
        #[test]
        fn well_conditioned_mappings_are_accepted(
            angle in 0.0f64..std::f64::consts::TAU,
            sx in 0.5f64..2.0,
            sy in 0.5f64..2.0,
            shear in -0.3f64..0.3,
        ) {
            let (c, s) = (angle.cos(), angle.sin());
            let m = [[c * sx, c * shear * sx - s * sy], [s * sx, s * shear * sx + c * sy]];
            let cal = written(Model::Affine, vec![m[0][0], m[0][1], 0.0, m[1][0], m[1][1], 0.0]);
            prop_assert_eq!(cal.check(), Ok(()));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(300)))]
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
