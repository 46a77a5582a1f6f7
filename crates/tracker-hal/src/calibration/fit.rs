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
        crate::mapping::check_grid(raw, screen, |p| self.map(p)).map_err(|m| ("params".into(), m))
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
