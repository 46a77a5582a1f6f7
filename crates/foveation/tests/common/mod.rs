//! Displays and helpers shared by the foveation integration tests.
#![allow(dead_code)]

use foveation::sampling::SEED_MAX_SPACING_PX;
use foveation::{Display, GeislerPerry, SamplingModel};

/// Four shipped display set-ups, read from `config/displays` (the seed's
/// 17" first).
pub fn displays() -> Vec<Display> {
    [
        "tobii-et1750-17in",
        "v8-hmd",
        "desktop-24in-1080p",
        "desktop-27in-4k",
    ]
    .iter()
    .map(|name| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/displays")
            .join(format!("{name}.ron"));
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        ron::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    })
    .collect()
}

pub fn model(display: &Display, contrast: f64) -> SamplingModel {
    let g = display.geometry().expect("valid test display");
    SamplingModel::new(g, GeislerPerry::default(), contrast, SEED_MAX_SPACING_PX)
        .expect("valid model")
}

/// Area of a simple polygon (shoelace), absolute.
pub fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let mut s = 0.0;
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        s += a[0] * b[1] - b[0] * a[1];
    }
    (s / 2.0).abs()
}

/// Sutherland–Hodgman clip of a convex-or-not polygon to `[0,w]×[0,h]`.
pub fn clip_to_rect(poly: &[[f64; 2]], w: f64, h: f64) -> Vec<[f64; 2]> {
    type Inside = fn(&[f64; 2], f64, f64) -> bool;
    let planes: [(Inside, usize, bool); 4] = [
        (|p, _, _| p[0] >= 0.0, 0, false),
        (|p, w, _| p[0] <= w, 0, true),
        (|p, _, _| p[1] >= 0.0, 1, false),
        (|p, _, h| p[1] <= h, 1, true),
    ];
    let mut out = poly.to_vec();
    for (inside, axis, far) in planes {
        let edge = if far {
            if axis == 0 {
                w
            } else {
                h
            }
        } else {
            0.0
        };
        let input = std::mem::take(&mut out);
        for i in 0..input.len() {
            let (cur, prev) = (input[i], input[(i + input.len() - 1) % input.len()]);
            let (ci, pi) = (inside(&cur, w, h), inside(&prev, w, h));
            let cross = || {
                let t = (edge - prev[axis]) / (cur[axis] - prev[axis]);
                [
                    prev[0] + t * (cur[0] - prev[0]),
                    prev[1] + t * (cur[1] - prev[1]),
                ]
            };
            if ci {
                if !pi {
                    out.push(cross());
                }
                out.push(cur);
            } else if pi {
                out.push(cross());
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

/// Area of the disc of radius `r` around `c` inside `[0,w]×[0,h]`, by
/// integrating the clipped chord length over y (Simpson, fine steps).
pub fn disc_rect_area(c: [f64; 2], r: f64, w: f64, h: f64) -> f64 {
    let (y0, y1) = ((c[1] - r).max(0.0), (c[1] + r).min(h));
    if y1 <= y0 {
        return 0.0;
    }
    let n = 20_000;
    let chord = |y: f64| {
        let half = (r * r - (y - c[1]).powi(2)).max(0.0).sqrt();
        ((c[0] + half).min(w) - (c[0] - half).max(0.0)).max(0.0)
    };
    let hstep = (y1 - y0) / n as f64;
    let mut s = chord(y0) + chord(y1);
    for i in 1..n {
        s += chord(y0 + i as f64 * hstep) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * hstep / 3.0
}

/// Nearest-point queries over a fixed set of points (uniform grid buckets).
pub struct PointIndex {
    cell: f64,
    buckets: std::collections::HashMap<(i64, i64), Vec<[f64; 2]>>,
}

impl PointIndex {
    pub fn new(points: impl Iterator<Item = [f64; 2]>, cell: f64) -> Self {
        let mut buckets: std::collections::HashMap<(i64, i64), Vec<[f64; 2]>> = Default::default();
        for p in points {
            buckets
                .entry(((p[0] / cell).floor() as i64, (p[1] / cell).floor() as i64))
                .or_default()
                .push(p);
        }
        Self { cell, buckets }
    }

    /// Distance to the nearest point within `max` (or `None`).
    pub fn nearest_within(&self, q: [f64; 2], max: f64) -> Option<f64> {
        let reach = (max / self.cell).ceil() as i64 + 1;
        let (bx, by) = (
            (q[0] / self.cell).floor() as i64,
            (q[1] / self.cell).floor() as i64,
        );
        let mut best: Option<f64> = None;
        for dx in -reach..=reach {
            for dy in -reach..=reach {
                for p in self.buckets.get(&(bx + dx, by + dy)).into_iter().flatten() {
                    let d = (p[0] - q[0]).hypot(p[1] - q[1]);
                    if d <= max && best.is_none_or(|b| d < b) {
                        best = Some(d);
                    }
                }
            }
        }
        best
    }
}

/// Asserts that `plain` and `other` build the same masks (fovea, vertices,
/// cells) on every shipped display, for PORs at, near and off the screen,
/// in both layouts; `other` is `plain` with a setting that should change
/// nothing (`with(model)`).
pub fn assert_same_masks(with: impl Fn(SamplingModel) -> SamplingModel) {
    use foveation::mask::{self, Layout};
    for d in displays() {
        let plain = model(&d, 1.0);
        let other = with(plain);
        for por in [[300.0, 200.0], [0.0, 0.0], [-500.0, 40.0]] {
            for layout in [Layout::Nyquist, Layout::Seed] {
                let a = mask::build(&plain, layout, por).expect("mask");
                let b = mask::build(&other, layout, por).expect("mask");
                assert_eq!(a.fovea, b.fovea, "{}: fovea", d.name);
                assert_eq!(a.vertices, b.vertices, "{}: vertices", d.name);
                assert_eq!(a.cells, b.cells, "{}: cells", d.name);
            }
        }
    }
}
