//! Binocular gaze and eye-movement events: vergence depth (Murphy &
//! Duchowski 2001 §4.2), the cyclopean gaze the renderer uses, velocity-
//! threshold fixation/saccade classification (I-VT), blinks from validity
//! gaps, and the device-to-host clock model.

use screen_geometry::ScreenGeometry;
use serde::Serialize;

use crate::timing::TimeOrder;

/// A 3-D gaze point from the two eyes' points in the near view plane
/// (Murphy & Duchowski eqs. 1–3): `s = b / (x_l − x_r + b)`,
/// `g = (1 − s)·h + s·((x_l + x_r)/2, (y_l + y_r)/2, f)`.
///
/// `baseline` is the distance b between the eye centres, `head` the head
/// position h and `plane_distance` f, all in the same units as the eye
/// points. Returns `None` ("no depth") when the lines of sight are parallel
/// or diverge (s ≤ 0 or s > `max_scale`) or the input is not finite: a
/// near-singular denominator never becomes an infinity.
pub fn vergence_point(
    left: [f64; 2],
    right: [f64; 2],
    baseline: f64,
    head: [f64; 3],
    plane_distance: f64,
    max_scale: f64,
) -> Option<[f64; 3]> {
    let finite = left
        .iter()
        .chain(&right)
        .chain(&head)
        .chain([baseline, plane_distance].iter())
        .all(|v| v.is_finite());
    if !finite || baseline <= 0.0 {
        return None;
    }
    let denominator = left[0] - right[0] + baseline;
    // |denominator| ≤ b / max_scale means s beyond the range: checked
    // before dividing, so a tiny denominator cannot overflow.
    if denominator <= baseline / max_scale {
        return None;
    }
    let s = baseline / denominator;
    let c = [(left[0] + right[0]) / 2.0, (left[1] + right[1]) / 2.0];
    let g = [
        (1.0 - s) * head[0] + s * c[0],
        (1.0 - s) * head[1] + s * c[1],
        (1.0 - s) * head[2] + s * plane_distance,
    ];
    g.iter().all(|v| v.is_finite()).then_some(g)
}

/// The 2-D gaze for the renderer: the mean of both eyes, or the one eye
/// that is valid (one-eye fallback), or `None`.
pub fn cyclopean(left: Option<[f64; 2]>, right: Option<[f64; 2]>) -> Option<[f64; 2]> {
    let ok = |p: Option<[f64; 2]>| p.filter(|p| p[0].is_finite() && p[1].is_finite());
    match (ok(left), ok(right)) {
        (Some(l), Some(r)) => Some([(l[0] + r[0]) / 2.0, (l[1] + r[1]) / 2.0]),
        (Some(p), None) | (None, Some(p)) => Some(p),
        (None, None) => None,
    }
}

/// A classified stretch of the gaze signal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum EventKind {
    /// Mean position (px) over the fixation.
    Fixation {
        /// Mean gaze over the fixation, screen px.
        centroid_px: [f64; 2],
    },
    /// Amplitude (start to end, degrees) and peak velocity (°/s).
    Saccade {
        /// Angle from the first to the last sample, degrees.
        amplitude_deg: f64,
        /// Peak angular velocity, degrees per second.
        peak_deg_s: f64,
    },
    /// Both eyes missing for a blink-like time.
    Blink,
    /// Missing for longer than a blink (tracking lost).
    Lost,
}

/// An eye-movement event. Its extent is computed on the **device clock**
/// (the tracker's own sample times: a busy host cannot change it) and
/// reported on both clocks: `start_us`/`end_us` are the mapped device
/// times (host clock, [`crate::timing`]) of its first and last sample,
/// `start_device_us`/`end_device_us` the device times.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Event {
    /// Which kind of event, with its measures.
    pub kind: EventKind,
    /// Mapped device time (host monotonic clock, µs) of the first sample.
    pub start_us: u64,
    /// Mapped device time of the last sample.
    pub end_us: u64,
    /// Device time (tracker clock, µs) of the first sample.
    pub start_device_us: u64,
    /// Device time of the last sample.
    pub end_device_us: u64,
    /// The clock segment (a device clock reset starts a new one).
    pub segment: u32,
    /// Index of the first and last sample in the classified slice (for a
    /// blink or loss: the valid samples before and after the gap).
    pub first: usize,
    /// Index of the last sample (see `first`).
    pub last: usize,
}

/// One sample as the classifier needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedGaze {
    /// Device time (µs, tracker clock); the mapped time for a sample that
    /// has none ([`TimeOrder::NoDeviceTime`]).
    pub device_us: u64,
    /// Mapped device time (µs, host monotonic clock).
    pub mapped_us: u64,
    /// How the device time relates to the previous sample's (first, increasing, repeated, backwards…).
    pub order: TimeOrder,
    /// The clock segment (a device clock reset starts a new one).
    pub segment: u32,
    /// Gaze in px, `None` when invalid.
    pub gaze: Option<[f64; 2]>,
}

impl TimedGaze {
    /// From a mapped [`crate::GazeSample`] and the gaze it gave.
    pub fn of(s: &crate::GazeSample, gaze: Option<[f64; 2]>) -> Self {
        Self {
            device_us: s.device_time_us.unwrap_or(s.mapped_time_us),
            mapped_us: s.mapped_time_us,
            order: s.time_order,
            segment: s.clock_segment,
            gaze,
        }
    }

    /// A sample on an ideal clock (device = mapped), for tests and synthetic
    /// streams.
    pub fn ideal(t_us: u64, gaze: Option<[f64; 2]>) -> Self {
        Self {
            device_us: t_us,
            mapped_us: t_us,
            order: TimeOrder::Increasing,
            segment: 0,
            gaze,
        }
    }
}

/// What [`classify`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Classification {
    /// The events, in time order.
    pub events: Vec<Event>,
    /// Samples left out because their device time did not increase
    /// (repeated or backwards: no velocity can be computed over them).
    pub non_increasing: usize,
}

/// I-VT settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IvtConfig {
    /// Faster than this (°/s) is a saccade (the seed's analysis: 15°/s).
    pub velocity_deg_s: f64,
    /// Missing spans from this long up to `max_blink_us` are blinks; longer
    /// ones are tracking loss; shorter ones are ignored.
    pub min_blink_us: u64,
    /// Missing spans longer than this are tracking loss, µs.
    pub max_blink_us: u64,
    /// A device-time step longer than this between samples counts as
    /// missing data (a HID tracker sends nothing while it sees no eyes).
    pub max_sample_gap_us: u64,
}

impl Default for IvtConfig {
    fn default() -> Self {
        Self {
            velocity_deg_s: 15.0,
            min_blink_us: 50_000,
            max_blink_us: 500_000,
            max_sample_gap_us: 50_000,
        }
    }
}

/// Classifies samples into fixations, saccades, blinks and losses (I-VT,
/// Salvucci & Goldberg 2000): the velocity of each sample is the angle
/// from the previous valid sample (display geometry) over their
/// **device-time** interval. A sample whose device time does not increase
/// is left out and counted (never a velocity of 0 or ∞); a device-time step
/// above `max_sample_gap_us`, an invalid stretch or a clock segment change
/// ends the current event (gaps of blink length become blinks).
pub fn classify(
    samples: &[TimedGaze],
    geometry: &ScreenGeometry,
    config: &IvtConfig,
) -> Classification {
    #[derive(PartialEq, Clone, Copy)]
    enum State {
        Fix,
        Sac,
    }
    struct Run {
        /// (index, position, velocity)
        items: Vec<(usize, [f64; 2], f64)>,
        state: Option<State>,
    }
    let mut events = Vec::new();
    let mut non_increasing = 0;
    let mut run = Run {
        items: Vec::new(),
        state: None,
    };
    // Index of the last valid sample before the current missing stretch.
    let mut missing_since: Option<usize> = None;
    let mut last: Option<usize> = None;
    let event = |kind: EventKind, a: usize, b: usize| Event {
        kind,
        start_us: samples[a].mapped_us,
        end_us: samples[b].mapped_us,
        start_device_us: samples[a].device_us,
        end_device_us: samples[b].device_us,
        segment: samples[a].segment,
        first: a,
        last: b,
    };
    let close_run = |run: &mut Run, events: &mut Vec<Event>| {
        if let (Some(s), Some(first), Some(lastp)) =
            (run.state, run.items.first(), run.items.last())
        {
            let kind = match s {
                State::Fix => {
                    let n = run.items.len() as f64;
                    EventKind::Fixation {
                        centroid_px: [
                            run.items.iter().map(|r| r.1[0]).sum::<f64>() / n,
                            run.items.iter().map(|r| r.1[1]).sum::<f64>() / n,
                        ],
                    }
                }
                State::Sac => EventKind::Saccade {
                    amplitude_deg: geometry.eccentricity_deg(first.1, lastp.1),
                    peak_deg_s: run.items.iter().map(|r| r.2).fold(0.0, f64::max),
                },
            };
            events.push(event(kind, first.0, lastp.0));
        }
        run.items.clear();
        run.state = None;
    };
    let close_gap = |from: usize, to: usize, events: &mut Vec<Event>| {
        if samples[from].segment != samples[to].segment {
            return; // a clock reset: the gap's length is unknown
        }
        let d = samples[to]
            .device_us
            .saturating_sub(samples[from].device_us);
        if d >= config.min_blink_us {
            let kind = if d <= config.max_blink_us {
                EventKind::Blink
            } else {
                EventKind::Lost
            };
            events.push(event(kind, from, to));
        }
    };
    for (i, s) in samples.iter().enumerate() {
        if !s.order.is_timed() {
            non_increasing += 1;
            continue;
        }
        let p = s.gaze.filter(|p| p[0].is_finite() && p[1].is_finite());
        match p {
            None => {
                if missing_since.is_none() {
                    close_run(&mut run, &mut events);
                    missing_since = Some(last.unwrap_or(i));
                }
            }
            Some(p) => {
                let new_segment = last.is_some_and(|l| samples[l].segment != s.segment);
                let gap_start = match (missing_since.take(), last) {
                    (Some(m), _) => Some(m),
                    (None, Some(l))
                        if new_segment
                            || s.device_us.saturating_sub(samples[l].device_us)
                                > config.max_sample_gap_us =>
                    {
                        close_run(&mut run, &mut events);
                        Some(l)
                    }
                    _ => None,
                };
                if let Some(g) = gap_start {
                    close_gap(g, i, &mut events);
                    last = None;
                }
                let v = match last {
                    Some(l) if s.device_us > samples[l].device_us => {
                        let lp = samples[l].gaze.unwrap_or(p);
                        geometry.eccentricity_deg(lp, p)
                            / ((s.device_us - samples[l].device_us) as f64 * 1e-6)
                    }
                    Some(_) => {
                        // Not later on the device clock than the previous
                        // valid sample (after a reset within a segment):
                        // no velocity; left out.
                        non_increasing += 1;
                        continue;
                    }
                    None => 0.0,
                };
                let st = if v > config.velocity_deg_s {
                    State::Sac
                } else {
                    State::Fix
                };
                if run.state != Some(st) {
                    close_run(&mut run, &mut events);
                    run.state = Some(st);
                }
                run.items.push((i, p, v));
                last = Some(i);
            }
        }
    }
    close_run(&mut run, &mut events);
    if let (Some(m), Some(end)) = (
        missing_since,
        samples.iter().rposition(|s| s.order.is_timed()),
    ) {
        close_gap(m, end, &mut events);
    }
    Classification {
        events,
        non_increasing,
    }
}

/// Murphy 2007 §7.3: "the centroid of all congruent fixations determines
/// the mean fixation coordinates". Tracker noise above the I-VT threshold
/// (0.15° of jitter at 120 Hz is about 25°/s between samples) splits one
/// fixation into fragments joined by tiny "saccades"; this joins each
/// fixation to the previous one when only saccades lie between them, both
/// are in the same clock segment, the gap between them is at most
/// `max_gap_us` of device time and the centroids are at most
/// `max_distance_deg` apart. The joined centroid is the duration-weighted
/// mean (each fragment weighted by its device-time duration plus 1 ms, so
/// a one-sample fragment counts); the saccades in between are dropped.
/// Blinks and losses are never bridged. Chosen here (the seed gives no
/// numbers): see the callers.
pub fn merge_congruent_fixations(
    events: &[Event],
    geometry: &ScreenGeometry,
    max_distance_deg: f64,
    max_gap_us: u64,
) -> Vec<Event> {
    let mut out: Vec<Event> = Vec::with_capacity(events.len());
    for e in events {
        if let EventKind::Fixation { centroid_px } = e.kind {
            let last_fix = out
                .iter()
                .rposition(|o| !matches!(o.kind, EventKind::Saccade { .. }));
            if let Some(i) = last_fix {
                if let EventKind::Fixation { centroid_px: c0 } = out[i].kind {
                    let o = out[i];
                    let close = geometry.eccentricity_deg(c0, centroid_px) <= max_distance_deg;
                    let soon = o.segment == e.segment
                        && e.start_device_us.saturating_sub(o.end_device_us) <= max_gap_us;
                    if close && soon {
                        let w0 = (o.end_device_us.saturating_sub(o.start_device_us) + 1000) as f64;
                        let w1 = (e.end_device_us.saturating_sub(e.start_device_us) + 1000) as f64;
                        let mix = |a: f64, b: f64| (a * w0 + b * w1) / (w0 + w1);
                        let later = e.end_device_us >= o.end_device_us;
                        out[i].kind = EventKind::Fixation {
                            centroid_px: [mix(c0[0], centroid_px[0]), mix(c0[1], centroid_px[1])],
                        };
                        if later {
                            out[i].end_us = e.end_us;
                            out[i].end_device_us = e.end_device_us;
                            out[i].last = e.last;
                        }
                        out.truncate(i + 1);
                        continue;
                    }
                }
            }
        }
        out.push(*e);
    }
    out
}

/// The device clock against the host clock: `host ≈ host0 + rate·(device − device0)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ClockModel {
    /// Device time of the model's origin, µs (tracker clock).
    pub device0_us: u64,
    /// Host time at that device time, µs (host monotonic clock).
    pub host0_us: f64,
    /// Host µs per device µs (1 + drift).
    pub rate: f64,
    /// Median absolute deviation of host − model over the fit samples, µs:
    /// the median of |host − model|, the typical spread of arrival times
    /// around the model. (host − model itself has median 0 by construction:
    /// the median latency is absorbed into `host0_us`.) Not scaled to a
    /// standard deviation.
    pub residual_mad_us: f64,
}

impl ClockModel {
    /// Drift of the device clock relative to the host, parts per million
    /// (positive: the device clock runs fast).
    pub fn drift_ppm(&self) -> f64 {
        (1.0 / self.rate - 1.0) * 1e6
    }

    /// Host time (µs) of a device timestamp.
    pub fn host_time_us(&self, device_us: u64) -> f64 {
        self.host0_us + self.rate * (device_us as f64 - self.device0_us as f64)
    }

    /// Offset host − device at device time `device_us` (µs).
    pub fn offset_us(&self, device_us: u64) -> f64 {
        self.host_time_us(device_us) - device_us as f64
    }

    /// Robust fit of `(device_us, host_us)` pairs: the slope is the median
    /// of the slopes between pairs half the series apart (a Theil–Sen
    /// estimator, Theil 1950, Sen 1968, on the pairs (i, i + ⌊n/2⌋) instead
    /// of all n(n−1)/2), the intercept the median of host − slope·device.
    /// Outliers (late arrivals) up to nearly half the samples do not move
    /// it. "Median" is the middle element after sorting, the upper of the
    /// two middle ones for an even count. `None` with fewer than 4 pairs or
    /// no time span.
    pub fn fit(pairs: &[(u64, u64)]) -> Option<Self> {
        if pairs.len() < 4 {
            return None;
        }
        let (d0, h0) = pairs[0];
        let rel: Vec<(f64, f64)> = pairs
            .iter()
            .map(|&(d, h)| (d as f64 - d0 as f64, h as f64 - h0 as f64))
            .collect();
        let half = rel.len() / 2;
        let mut slopes: Vec<f64> = (0..rel.len() - half)
            .filter_map(|i| {
                let (a, b) = (rel[i], rel[i + half]);
                let dx = b.0 - a.0;
                (dx > 0.0).then(|| (b.1 - a.1) / dx)
            })
            .collect();
        if slopes.is_empty() {
            return None;
        }
        slopes.sort_by(f64::total_cmp);
        let rate = slopes[slopes.len() / 2];
        let mut intercepts: Vec<f64> = rel.iter().map(|(d, h)| h - rate * d).collect();
        intercepts.sort_by(f64::total_cmp);
        let b = intercepts[intercepts.len() / 2];
        let mut dev: Vec<f64> = intercepts.iter().map(|i| (i - b).abs()).collect();
        dev.sort_by(f64::total_cmp);
        (rate.is_finite() && rate > 0.0).then_some(Self {
            device0_us: d0,
            host0_us: h0 as f64 + b,
            rate,
            residual_mad_us: dev[dev.len() / 2],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn vergence_follows_the_seed_equations() {
        // Eyes 64 mm apart, plane at 500 mm, head at the origin. Points in
        // the plane 64 mm apart in the eyes' own order: parallel → no depth.
        let b = 64.0;
        assert_eq!(
            vergence_point([-32.0, 0.0], [32.0, 0.0], b, [0.0; 3], 500.0, 1e4),
            None
        );
        // Converging on the plane itself: both eyes see the same point, s = 1.
        let g = vergence_point([10.0, 5.0], [10.0, 5.0], b, [0.0; 3], 500.0, 1e4).expect("depth");
        assert_eq!(g, [10.0, 5.0, 500.0]);
        // Crossed beyond the plane by 32 mm: s = 64/(32+64) = 2/3.
        let g = vergence_point([16.0, 0.0], [-16.0, 0.0], b, [0.0; 3], 500.0, 1e4).expect("depth");
        assert!((g[2] - 500.0 * 2.0 / 3.0).abs() < 1e-9, "{g:?}");
        // Nearly parallel: the denominator is 1e-12·b → beyond max_scale.
        assert_eq!(
            vergence_point([-32.0 + 64e-12, 0.0], [32.0, 0.0], b, [0.0; 3], 500.0, 1e4),
            None
        );
        assert_eq!(
            vergence_point([f64::NAN, 0.0], [0.0, 0.0], b, [0.0; 3], 500.0, 1e4),
            None
        );
        assert_eq!(
            cyclopean(Some([0.0, 0.0]), Some([2.0, 4.0])),
            Some([1.0, 2.0])
        );
        assert_eq!(cyclopean(None, Some([2.0, 4.0])), Some([2.0, 4.0]));
        assert_eq!(cyclopean(Some([f64::NAN, 0.0]), None), None);
    }

    proptest! {
        #[test]
        fn vergence_is_finite_or_none(
            xl in prop_oneof![-1e12f64..1e12, Just(-32.0), -33.0f64..-31.0],
            xr in prop_oneof![-1e12f64..1e12, Just(32.0), 31.0f64..33.0],
            y in -1e6f64..1e6,
            b in prop_oneof![Just(0.0), 1e-9f64..1e3],
            f in 0.0f64..1e6,
        ) {
            if let Some(g) = vergence_point([xl, y], [xr, y], b, [1.0, 2.0, 3.0], f, 1e4) {
                prop_assert!(g.iter().all(|v| v.is_finite()));
            }
        }
    }

    fn geometry() -> ScreenGeometry {
        crate::test_support::seed_display(600.0)
    }

    #[test]
    fn ivt_finds_fixations_saccades_and_blinks() {
        // 250 Hz: fixation at 300 px for 300 ms, a 40 ms saccade to 900 px,
        // fixation 300 ms, a 150 ms blink, fixation 200 ms.
        let mut s = Vec::new();
        let mut t = 0u64;
        let push = |s: &mut Vec<TimedGaze>, p: Option<[f64; 2]>, t: &mut u64| {
            s.push(TimedGaze::ideal(*t, p));
            *t += 4_000;
        };
        for _ in 0..75 {
            push(&mut s, Some([300.0, 500.0]), &mut t);
        }
        for k in 1..=10 {
            push(&mut s, Some([300.0 + 60.0 * f64::from(k), 500.0]), &mut t);
        }
        for _ in 0..75 {
            push(&mut s, Some([900.0, 500.0]), &mut t);
        }
        for _ in 0..37 {
            push(&mut s, None, &mut t);
        }
        for _ in 0..50 {
            push(&mut s, Some([900.0, 500.0]), &mut t);
        }
        let e = classify(&s, &geometry(), &IvtConfig::default()).events;
        let kinds: Vec<&str> = e
            .iter()
            .map(|e| match e.kind {
                EventKind::Fixation { .. } => "F",
                EventKind::Saccade { .. } => "S",
                EventKind::Blink => "B",
                EventKind::Lost => "L",
            })
            .collect();
        assert_eq!(kinds, ["F", "S", "F", "B", "F"], "{e:?}");
        let EventKind::Saccade { amplitude_deg, .. } = e[1].kind else {
            unreachable!()
        };
        assert!(amplitude_deg > 10.0, "{amplitude_deg}");
        assert!(
            (e[3].end_us - e[3].start_us).abs_diff(152_000) <= 8_000,
            "{:?}",
            e[3]
        );
    }

    /// A noisy fixation split by jitter becomes one; a real saccade and a
    /// blink are kept.
    #[test]
    fn congruent_fixations_merge_and_real_saccades_stay() {
        let g = geometry();
        let ev = |kind: EventKind, t0: u64, t1: u64| Event {
            kind,
            start_us: t0,
            end_us: t1,
            start_device_us: t0,
            end_device_us: t1,
            segment: 0,
            first: 0,
            last: 0,
        };
        let fix = |t0: u64, t1: u64, x: f64| {
            ev(
                EventKind::Fixation {
                    centroid_px: [x, 300.0],
                },
                t0,
                t1,
            )
        };
        let sac = |t0: u64, t1: u64| {
            ev(
                EventKind::Saccade {
                    amplitude_deg: 0.3,
                    peak_deg_s: 30.0,
                },
                t0,
                t1,
            )
        };
        let blink = ev(EventKind::Blink, 700_000, 800_000);
        let events = vec![
            fix(0, 99_000, 100.0),
            sac(99_000, 108_000),
            fix(108_000, 299_000, 104.0), // 4 px away: the same fixation
            sac(299_000, 340_000),
            fix(340_000, 600_000, 500.0), // 400 px away: a new one
            blink,
            fix(800_000, 900_000, 500.0), // after a blink: not bridged
        ];
        let m = merge_congruent_fixations(&events, &g, 1.0, 100_000);
        assert_eq!(m.len(), 5, "{m:?}");
        match m[0].kind {
            EventKind::Fixation { centroid_px } => {
                // Weighted by 100 ms and 192 ms.
                let want = (100.0 * 100.0 + 104.0 * 192.0) / 292.0;
                assert!((centroid_px[0] - want).abs() < 1e-9, "{centroid_px:?}");
            }
            other => panic!("{other:?}"),
        }
        assert_eq!((m[0].start_us, m[0].end_us), (0, 299_000));
        assert!(matches!(m[1].kind, EventKind::Saccade { .. }));
        assert!(matches!(m[3].kind, EventKind::Blink));
        // Idempotent, and an empty list stays empty.
        assert_eq!(merge_congruent_fixations(&m, &g, 1.0, 100_000), m);
        assert!(merge_congruent_fixations(&[], &g, 1.0, 100_000).is_empty());
    }

    #[test]
    fn a_silent_gap_is_missing_data() {
        // A HID tracker sends nothing during a blink: a 120 ms hole.
        let mut s: Vec<TimedGaze> = (0..50)
            .map(|i| TimedGaze::ideal(i * 20_000, Some([500.0, 500.0])))
            .collect();
        s.retain(|t| !(400_000..520_000).contains(&t.device_us));
        let e = classify(&s, &geometry(), &IvtConfig::default()).events;
        assert!(e.iter().any(|e| e.kind == EventKind::Blink), "{e:?}");
    }

    /// Samples whose device time repeats or goes back are left out and
    /// counted: six samples of a saccade with one device time used to get
    /// velocity 0 and become a "fixation".
    #[test]
    fn equal_device_times_never_make_a_velocity() {
        let g = geometry();
        let mut s: Vec<TimedGaze> = (0..30)
            .map(|i| TimedGaze::ideal(i * 8_333, Some([300.0, 500.0])))
            .collect();
        // A saccade 8.3 ms apart on the tracker, then the same positions
        // again with a repeated device time (a duplicated burst).
        for k in 0..6u64 {
            s.push(TimedGaze::ideal(
                (30 + k) * 8_333,
                Some([330.0 + 30.0 * k as f64, 500.0]),
            ));
        }
        for k in 0..6u64 {
            let mut t = TimedGaze::ideal((35) * 8_333, Some([330.0 + 30.0 * k as f64, 500.0]));
            t.order = if k == 0 {
                TimeOrder::Repeated
            } else {
                TimeOrder::Backwards
            };
            s.push(t);
        }
        for i in 36..70 {
            s.push(TimedGaze::ideal(i * 8_333, Some([480.0, 500.0])));
        }
        let c = classify(&s, &g, &IvtConfig::default());
        assert_eq!(c.non_increasing, 6);
        let kinds: Vec<_> = c
            .events
            .iter()
            .map(|e| matches!(e.kind, EventKind::Fixation { .. }))
            .collect();
        assert_eq!(kinds, [true, false, true], "{:?}", c.events);
    }

    proptest! {
        /// The events depend on the device times only: the mapped times
        /// (which a busy host perturbs) change the reported host times of an
        /// event, never which samples it holds.
        #[test]
        fn events_do_not_depend_on_the_mapped_times(
            seed in any::<u64>(),
            lag in proptest::collection::vec(0u64..200_000, 300),
        ) {
            let g = geometry();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut pos = [640.0, 512.0];
            let s: Vec<TimedGaze> = (0..300u64)
                .map(|i| {
                    if rng.random::<f64>() < 0.05 {
                        pos = [rng.random_range(0.0..1280.0), rng.random_range(0.0..1024.0)];
                    }
                    let p = (rng.random::<f64>() > 0.03)
                        .then(|| [pos[0] + rng.random_range(-3.0..3.0), pos[1]]);
                    TimedGaze::ideal(i * 8_333, p)
                })
                .collect();
            let mut shifted = s.clone();
            let mut acc = 0;
            for (t, l) in shifted.iter_mut().zip(&lag) {
                acc += l / 100;
                t.mapped_us = t.device_us + 1_000_000 + acc;
            }
            let a = classify(&s, &g, &IvtConfig::default()).events;
            let b = classify(&shifted, &g, &IvtConfig::default()).events;
            let key = |e: &Event| (e.first, e.last, e.start_device_us, e.end_device_us);
            prop_assert_eq!(a.iter().map(key).collect::<Vec<_>>(), b.iter().map(key).collect::<Vec<_>>());
            for x in &b {
                prop_assert_eq!(x.start_us, shifted[x.first].mapped_us);
            }
        }
    }

    #[test]
    fn the_clock_fit_recovers_offset_and_drift() {
        // Device clock 40 ppm fast with a 5000 s offset; host arrival 2 ms
        // later plus 0–1.5 ms jitter, and 10 % of reports 20–80 ms late.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let pairs: Vec<(u64, u64)> = (0..3000u64)
            .map(|k| {
                let t = 1_000_000 + k * 20_000;
                let device = 5_000_000_000 + t + t * 40 / 1_000_000;
                let mut host = t + 2_000 + rng.random_range(0..1_500);
                if rng.random::<f64>() < 0.1 {
                    host += rng.random_range(20_000..80_000);
                }
                (device, host)
            })
            .collect();
        let m = ClockModel::fit(&pairs).expect("fits");
        assert!((m.drift_ppm() - 40.0).abs() < 1.0, "{} ppm", m.drift_ppm());
        // At the middle of the run, the model's host time of a report is
        // its true time + about the median latency (2.75 ms).
        let t = 1_000_000 + 1500 * 20_000u64;
        let device = 5_000_000_000 + t + t * 40 / 1_000_000;
        let err = m.host_time_us(device) - t as f64;
        assert!((err - 2_750.0).abs() < 500.0, "{err}");
        assert!(ClockModel::fit(&pairs[..3]).is_none());
        assert!(ClockModel::fit(&[(5, 1), (5, 2), (5, 3), (5, 4)]).is_none());
    }
}
