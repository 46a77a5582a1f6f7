//! Which part of a circle around the POR lies on the screen.
//!
//! Rings are only generated (and meshed) where they can touch the screen, so a
//! POR in a corner costs a quarter of the rings' points, not all of them.
//! Angles are measured from +x towards +y (screen y points down).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Intervals an [`ArcList`] holds at most. A circle meets a rectangle's
/// four edges in at most four forbidden arcs, so what is left of it on the
/// screen is at most four arcs, and widening or merging never adds one.
pub const MAX_ARCS: usize = 8;

/// Up to [`MAX_ARCS`] intervals, held in place: building a mask allocates
/// nothing for them.
#[derive(Debug, Clone, Copy, Default)]
pub struct ArcList {
    len: usize,
    arcs: [(f64, f64); MAX_ARCS],
}

/// Equal intervals (the unused slots do not count).
impl PartialEq for ArcList {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl ArcList {
    /// The intervals.
    pub fn as_slice(&self) -> &[(f64, f64)] {
        &self.arcs[..self.len]
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends `arc`; false (and nothing added) when full.
    fn push(&mut self, arc: (f64, f64)) -> bool {
        if self.len == MAX_ARCS {
            return false;
        }
        self.arcs[self.len] = arc;
        self.len += 1;
        true
    }

    fn as_mut_slice(&mut self) -> &mut [(f64, f64)] {
        &mut self.arcs[..self.len]
    }

    fn pop(&mut self) {
        self.len = self.len.saturating_sub(1);
    }

    /// A list of these intervals (at most [`MAX_ARCS`] are kept; the
    /// callers' lists are shorter).
    pub fn from_slice(arcs: &[(f64, f64)]) -> Self {
        let mut l = Self::default();
        for &a in arcs {
            l.push(a);
        }
        l
    }
}

/// A set of angles on the circle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArcSet {
    /// Every angle.
    Full,
    /// Disjoint intervals `[a, b]`, sorted, `a < b`, all within one turn
    /// starting at the first `a` (the first may start below 0).
    Arcs(ArcList),
}

/// The one turn [`ArcSet::intervals`] gives for [`ArcSet::Full`].
const FULL_TURN: [(f64, f64); 1] = [(0.0, TAU)];

impl ArcSet {
    /// No angle.
    pub const EMPTY: ArcSet = ArcSet::Arcs(ArcList {
        len: 0,
        arcs: [(0.0, 0.0); MAX_ARCS],
    });

    /// Whether the set holds no angle.
    pub fn is_empty(&self) -> bool {
        matches!(self, ArcSet::Arcs(a) if a.is_empty())
    }

    /// Widens every interval by `margin` radians on both sides and joins
    /// intervals closer than `join_gap`.
    pub fn expanded(&self, margin: f64, join_gap: f64) -> ArcSet {
        match self {
            ArcSet::Full => ArcSet::Full,
            ArcSet::Arcs(arcs) => from_intervals(
                arcs.as_slice()
                    .iter()
                    .map(|&(a, b)| (a - margin, b + margin)),
                join_gap,
            ),
        }
    }

    /// The intervals, or one full turn.
    pub fn intervals(&self) -> &[(f64, f64)] {
        match self {
            ArcSet::Full => &FULL_TURN,
            ArcSet::Arcs(a) => a.as_slice(),
        }
    }
}

/// The screen seen from the POR.
#[derive(Debug, Clone, Copy)]
pub struct ScreenFromPor {
    por: [f64; 2],
    /// Distances from the POR to the right, bottom, left and top edges
    /// (negative when the POR is beyond that edge).
    margins: [f64; 4],
    /// Nearest and farthest screen distance from the POR.
    pub min_distance_px: f64,
    /// Farthest screen distance from the POR (a corner's).
    pub max_distance_px: f64,
}

impl ScreenFromPor {
    /// The screen `width_px × height_px` (pixels, origin top-left) seen from `por`.
    pub fn new(por: [f64; 2], width_px: f64, height_px: f64) -> Self {
        let margins = [width_px - por[0], height_px - por[1], por[0], por[1]];
        let dx = (-por[0]).max(por[0] - width_px).max(0.0);
        let dy = (-por[1]).max(por[1] - height_px).max(0.0);
        let max_distance_px = [
            (0.0, 0.0),
            (width_px, 0.0),
            (0.0, height_px),
            (width_px, height_px),
        ]
        .iter()
        .map(|&(x, y)| (x - por[0]).hypot(y - por[1]))
        .fold(0.0, f64::max);
        Self {
            por,
            margins,
            min_distance_px: dx.hypot(dy),
            max_distance_px,
        }
    }

    fn por_inside(&self) -> bool {
        self.margins.iter().all(|&m| m >= 0.0)
    }

    /// Angles at which the circle of `radius_px` around the POR is on the
    /// screen (boundary included). Empty when the circle misses the screen.
    pub fn visible_arcs(&self, radius_px: f64) -> ArcSet {
        if radius_px <= 0.0 || !radius_px.is_finite() {
            return if radius_px == 0.0 && self.por_inside() {
                ArcSet::Full
            } else {
                ArcSet::EMPTY
            };
        }
        if radius_px < self.min_distance_px || radius_px > self.max_distance_px {
            return ArcSet::EMPTY;
        }
        if !self.por_inside() {
            return self.screen_angular_span();
        }
        // Each edge forbids the arc of angles whose point lies beyond it:
        // an edge at distance m in direction c forbids |φ - c| < acos(m / r).
        let directions = [0.0, FRAC_PI_2, PI, 3.0 * FRAC_PI_2];
        let mut forbidden = ArcList::default();
        for (m, c) in self.margins.iter().zip(directions) {
            if *m < radius_px {
                let half = (m / radius_px).acos();
                forbidden.push((c - half, c + half));
            }
        }
        if forbidden.is_empty() {
            return ArcSet::Full;
        }
        let forbidden = match from_intervals(forbidden.as_slice().iter().copied(), 0.0) {
            ArcSet::Full => return ArcSet::EMPTY,
            ArcSet::Arcs(f) => f,
        };
        let forbidden = forbidden.as_slice();
        // Complement within the turn that starts where the first forbidden arc ends.
        let start = forbidden[0].1;
        let mut allowed = ArcList::default();
        for (i, &(_, end)) in forbidden.iter().enumerate() {
            let next_start = forbidden.get(i + 1).map_or(forbidden[0].0 + TAU, |n| n.0);
            if next_start > end {
                // At most one gap per forbidden arc: never more than the list holds.
                allowed.push((end, next_start));
            }
        }
        debug_assert!(allowed.as_slice().iter().all(|&(a, _)| a >= start));
        ArcSet::Arcs(allowed)
    }

    /// For a POR off the screen: the single interval of directions that hit it.
    fn screen_angular_span(&self) -> ArcSet {
        let [right, bottom, left, top] = self.margins;
        let (w, h) = (right + left, bottom + top);
        let centre = ((w / 2.0) - self.por[0], (h / 2.0) - self.por[1]);
        let c = centre.1.atan2(centre.0);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (x, y) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)] {
            let a = (y - self.por[1]).atan2(x - self.por[0]);
            let rel = wrap_pi(a - c);
            lo = lo.min(rel);
            hi = hi.max(rel);
        }
        ArcSet::Arcs(ArcList::from_slice(&[(c + lo, c + hi)]))
    }
}

/// Normalises to (-π, π].
fn wrap_pi(a: f64) -> f64 {
    let r = a.rem_euclid(TAU);
    if r > PI {
        r - TAU
    } else {
        r
    }
}

/// Builds a set from intervals of any start (each shorter than a turn or
/// covering it), merging overlaps and gaps below `join_gap`. More than
/// [`MAX_ARCS`] intervals (no caller makes them) give the whole turn: a
/// superset, so a mask built from it only has more cells, never a hole.
pub fn from_intervals(intervals: impl Iterator<Item = (f64, f64)>, join_gap: f64) -> ArcSet {
    let mut v = ArcList::default();
    for (a, b) in intervals {
        if b - a >= TAU - join_gap {
            return ArcSet::Full;
        }
        let s = a.rem_euclid(TAU);
        if !v.push((s, s + (b - a))) {
            return ArcSet::Full;
        }
    }
    if v.is_empty() {
        return ArcSet::Arcs(v);
    }
    v.as_mut_slice()
        .sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
    let mut merged = ArcList::default();
    for &(a, b) in v.as_slice() {
        match merged.as_mut_slice().last_mut() {
            Some(last) if a <= last.1 + join_gap => last.1 = last.1.max(b),
            _ => {
                merged.push((a, b));
            }
        }
    }
    // An interval that runs past one turn may reach the first ones again.
    while merged.len > 1 {
        let m = merged.as_mut_slice();
        let last = m[m.len() - 1];
        let first = m[0];
        if last.1 - TAU + join_gap >= first.0 {
            m[0] = (last.0 - TAU, first.1.max(last.1 - TAU));
            merged.pop();
        } else {
            break;
        }
    }
    let m = merged.as_slice();
    if m.len() == 1 && m[0].1 - m[0].0 >= TAU - join_gap {
        return ArcSet::Full;
    }
    ArcSet::Arcs(merged)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contains(set: &ArcSet, phi: f64) -> bool {
        match set {
            ArcSet::Full => true,
            ArcSet::Arcs(a) => a.as_slice().iter().any(|&(lo, hi)| {
                let p = lo + (phi - lo).rem_euclid(TAU);
                p <= hi
            }),
        }
    }

    #[test]
    fn visible_arcs_agree_with_point_tests() {
        for por in [
            [640.0, 512.0],
            [0.0, 0.0],
            [1279.0, 3.0],
            [-200.0, 300.0],
            [2000.0, 2000.0],
        ] {
            let s = ScreenFromPor::new(por, 1280.0, 1024.0);
            for r in [1.0, 100.0, 520.0, 700.0, 900.0, 1500.0, 2100.0] {
                let set = s.visible_arcs(r);
                for k in 0..720 {
                    let phi = k as f64 / 720.0 * TAU + 1e-4;
                    let p = [por[0] + r * phi.cos(), por[1] + r * phi.sin()];
                    let on = p[0] > 0.01 && p[0] < 1279.99 && p[1] > 0.01 && p[1] < 1023.99;
                    if on {
                        assert!(
                            contains(&set, phi),
                            "por {por:?} r {r} phi {phi} missing in {set:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn intervals_across_zero_are_joined() {
        let set = from_intervals([(6.0, 6.5), (0.1, 0.3)].into_iter(), 0.0);
        assert_eq!(set, ArcSet::Arcs(ArcList::from_slice(&[(6.0 - TAU, 0.3)])));
    }

    #[test]
    fn more_intervals_than_the_list_holds_give_the_whole_turn() {
        let many = (0..MAX_ARCS + 1).map(|k| (k as f64 * 0.5, k as f64 * 0.5 + 0.1));
        assert_eq!(from_intervals(many, 0.0), ArcSet::Full);
        let fit = (0..MAX_ARCS).map(|k| (k as f64 * 0.5, k as f64 * 0.5 + 0.1));
        assert!(
            matches!(from_intervals(fit, 0.0), ArcSet::Arcs(a) if a.as_slice().len() == MAX_ARCS)
        );
    }
}
