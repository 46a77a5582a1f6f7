//! The three times of a gaze sample, and the online clock model that maps
//! the tracker's clock onto the host's.
//!
//! Every sample carries:
//!
//! - **device time** ([`GazeSample::device_time_us`]): the tracker's own
//!   timestamp as decoded, µs on the tracker's clock (how each driver gets
//!   it is its [`DeviceClock`]);
//! - **arrival time** ([`GazeSample::host_time_us`]): host monotonic µs
//!   when the bytes holding the record's end were read — what the machine's
//!   load changes;
//! - **mapped time** ([`GazeSample::mapped_time_us`]): the device time on
//!   the host's monotonic clock, by this module's [`ClockMapper`]. Every
//!   file, event and latency figure downstream uses it.
//!
//! # The clock model
//!
//! Arrival = capture + transport latency, and latency is never negative:
//! the least-delayed arrivals trace a line under all the others (the lower
//! envelope). The mapper fits that line online:
//!
//! - **Rate** (host µs per device µs, 1 + drift): a Theil–Sen fit
//!   ([`ClockModel::fit`]) over the least-delayed pair of every block of
//!   [`BLOCK`] samples, the last [`MAX_BLOCKS`] blocks, refitted at every
//!   block from [`MIN_BLOCKS`] blocks on (1 until then); clamped to
//!   ±[`MAX_DRIFT`] (a fit beyond it is reported as
//!   [`ClockState::rate_clamped`]: a crystal drifts by tens of ppm, so more
//!   is a wrong nominal rate, e.g. an ISCAN's `rate_hz`).
//! - **Offset**: the first read anchors the last record it completed (the
//!   least delayed of a burst) at its arrival; afterwards the mapped time
//!   follows the device time at the fitted rate and is steered towards the
//!   envelope line (the minimum of arrival − rate·device over the window)
//!   by at most [`SLEW`] of each device interval — never faster, so mapped
//!   intervals stay the device's intervals within 0.02 %.
//! - **Causality**: a sample cannot be captured after it arrived. When the
//!   prediction lies after the arrival (the anchor was a delayed read),
//!   the mapped time steps back towards the arrival by at most
//!   [`MAX_STEP_US`] per sample, and stays strictly after the previous one.
//!   [`ClockState::corrections`] counts these steps.
//!
//! Mapped times therefore increase strictly, and each mapped interval
//! equals the device interval × rate within [`MAX_STEP_US`] (in practice
//! within a few µs); the constant part of the transport latency is not
//! observable from arrivals alone, so the mapped time is the capture time
//! plus the transport's *minimum* latency.
//!
//! # Bad device times
//!
//! A device time equal to the previous one is [`TimeOrder::Repeated`], an
//! earlier one [`TimeOrder::Backwards`], one that would put the capture
//! more than [`AHEAD_US`] after the sample's own arrival
//! [`TimeOrder::Ahead`]: all keep the previous mapped time, are counted,
//! must not enter a velocity, and do not become the reference for the next
//! sample (one corrupt timestamp cannot shift the ones after it). A jump of
//! more than [`RESET_US`] either way against the arrivals (a device clock
//! reset, a days-long timestamp), or [`JUMP_CONFIRM`] rejected samples in a
//! row (a smaller reset), is a [`TimeOrder::Reset`]: the mapper re-anchors
//! at the arrival and starts a new clock segment
//! ([`GazeSample::clock_segment`]); events never span segments.
//!
//! The mapper is a pure function of the (device time, arrival time)
//! sequence and the read boundaries, so a replayed recording (which keeps
//! every read with its arrival time) maps to the same times as the live
//! session did.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::events::ClockModel;
use crate::sample::GazeSample;

/// Samples per envelope block (the block keeps its least-delayed pair).
pub const BLOCK: usize = 32;
/// Blocks kept for the rate fit (4096 × 32 samples: about 18 minutes at
/// 120 Hz, 9 at 240 Hz).
pub const MAX_BLOCKS: usize = 4096;
/// Blocks needed before the rate is fitted (below it the rate is 1).
pub const MIN_BLOCKS: usize = 8;
/// The largest drift the rate may take, either way (500 ppm).
pub const MAX_DRIFT: f64 = 500e-6;
/// The most the mapped time is steered towards the envelope, as a
/// fraction of the device interval (100 ppm).
pub const SLEW: f64 = 100e-6;
/// The most one sample's mapped time steps back towards its arrival (µs).
pub const MAX_STEP_US: f64 = 50.0;
/// A device time this far (µs) from where the arrivals put it is a clock
/// reset, not a late sample (10 s: longer than any delivery stall seen).
pub const RESET_US: f64 = 10e6;
/// A device time that would put a sample's capture more than this (µs)
/// after its own arrival is not believed ([`TimeOrder::Ahead`]): no
/// delivery makes a sample arrive before it was captured.
pub const AHEAD_US: f64 = 1e6;
/// Consecutive samples whose device times are all rejected (backwards or
/// ahead) that confirm a device clock jump: the last of them starts a new
/// segment ([`TimeOrder::Reset`]). A single bad timestamp is only skipped.
pub const JUMP_CONFIRM: u32 = 8;

/// How a driver obtains the device time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum DeviceClock {
    /// The tracker stamps each record with its own clock (mouse emulator,
    /// HID eye trackers' sensor timestamp).
    Device,
    /// The wire format carries no time: the driver counts records (and
    /// the records a resynchronisation dropped) × the nominal period,
    /// from 0 at the connection's first record (ISCAN).
    Counter {
        /// Nominal period, µs.
        period_us: f64,
    },
    /// No device time at all: the arrival time stands in for it (the
    /// mapped time is then the arrival time, and load shows in it).
    Arrival,
}

impl DeviceClock {
    /// One line for logs, session files and sidecars.
    pub fn describe(&self) -> String {
        match self {
            DeviceClock::Device => "the tracker's own timestamps (µs)".into(),
            DeviceClock::Counter { period_us } => format!(
                "derived: records counted from the connection's first record (resynchronisations add the records their dropped bytes held) × the nominal period {period_us:.3} µs"
            ),
            DeviceClock::Arrival => {
                "none: the tracker sends no time; host arrival times stand in".into()
            }
        }
    }
}

/// Where a sample's device time stands against the previous one's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TimeOrder {
    /// As a decoder leaves it: the driver's mapper has not seen it
    /// (`mapped_time_us` is still the arrival time).
    Unmapped,
    /// The first sample of a connection (no interval before it).
    First,
    /// Later than the previous sample: the interval is valid.
    Increasing,
    /// The same device time as the previous sample (no valid interval).
    Repeated,
    /// Earlier than the previous sample (no valid interval).
    Backwards,
    /// So far ahead that the capture would follow the arrival by more than
    /// [`AHEAD_US`] (no valid interval).
    Ahead,
    /// A jump of more than [`RESET_US`]: a new clock segment begins here.
    Reset,
    /// The sample has no device time; the arrival time stood in for it.
    NoDeviceTime,
}

impl TimeOrder {
    /// The name written to session files (`samples.tsv` `time_order`).
    pub fn name(self) -> &'static str {
        match self {
            TimeOrder::Unmapped => "unmapped",
            TimeOrder::First => "first",
            TimeOrder::Increasing => "ok",
            TimeOrder::Repeated => "repeated",
            TimeOrder::Backwards => "backwards",
            TimeOrder::Ahead => "ahead",
            TimeOrder::Reset => "reset",
            TimeOrder::NoDeviceTime => "no-device-time",
        }
    }

    /// Parses [`TimeOrder::name`].
    pub fn from_name(s: &str) -> Option<Self> {
        [
            TimeOrder::Unmapped,
            TimeOrder::First,
            TimeOrder::Increasing,
            TimeOrder::Repeated,
            TimeOrder::Backwards,
            TimeOrder::Ahead,
            TimeOrder::Reset,
            TimeOrder::NoDeviceTime,
        ]
        .into_iter()
        .find(|o| o.name() == s)
    }

    /// Whether the interval from the previous sample is a valid time step
    /// (a velocity may be computed over it).
    pub fn has_interval(self) -> bool {
        matches!(self, TimeOrder::Increasing | TimeOrder::NoDeviceTime)
    }

    /// Whether the sample's mapped time is its own (not the previous one's
    /// kept for a repeated or backwards device time).
    pub fn is_timed(self) -> bool {
        !matches!(
            self,
            TimeOrder::Repeated | TimeOrder::Backwards | TimeOrder::Ahead
        )
    }
}

/// The clock model's state, for logs and session files.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClockState {
    /// Samples mapped so far.
    pub samples: u64,
    /// The newest sample's device, arrival and mapped times (µs).
    pub device_us: u64,
    /// The newest sample's arrival time, µs (host clock).
    pub arrival_us: u64,
    /// The newest sample's mapped time, µs (host clock).
    pub mapped_us: u64,
    /// Host µs per device µs.
    pub rate: f64,
    /// Device-clock drift against the host, ppm (positive: the device
    /// clock runs fast).
    pub drift_ppm: f64,
    /// The unclamped fit lay beyond ±[`MAX_DRIFT`] (a wrong nominal rate).
    pub rate_clamped: bool,
    /// Mapped − device time at the newest sample (µs): the clock offset.
    pub offset_us: f64,
    /// Arrival − mapped time of the newest sample (µs): its delivery delay
    /// beyond the transport's minimum.
    pub delay_us: f64,
    /// Envelope blocks in the fit.
    pub blocks: usize,
    /// Rate refits so far.
    pub refits: u64,
    /// Steps back towards the arrival (causality corrections).
    pub corrections: u64,
    /// Samples with a repeated, backwards or ahead device time (left out).
    pub non_increasing: u64,
    /// Clock resets (new segments).
    pub resets: u64,
    /// Samples without a device time.
    pub no_device_time: u64,
}

/// The online device → host clock mapping of one connection (see the
/// module documentation).
#[derive(Debug, Clone)]
pub struct ClockMapper {
    /// Previous sample: device time, mapped time (f64, µs).
    last: Option<(u64, f64)>,
    rate: f64,
    rate_clamped: bool,
    /// The envelope's intercept: min over the window of
    /// arrival − rate·(device − `origin`) with `origin` the first device
    /// time of the segment.
    origin: u64,
    envelope: Option<f64>,
    /// Least-delayed (device, arrival) pair of each finished block.
    blocks: VecDeque<(u64, u64)>,
    block_best: Option<(u64, u64)>,
    block_len: usize,
    segment: u32,
    /// Rejected (backwards or ahead) samples in a row.
    rejected: u32,
    state: ClockState,
}

impl Default for ClockMapper {
    fn default() -> Self {
        Self::new()
    }
}

impl ClockMapper {
    /// A mapper that has seen no sample.
    pub fn new() -> Self {
        Self {
            last: None,
            rate: 1.0,
            rate_clamped: false,
            origin: 0,
            envelope: None,
            blocks: VecDeque::new(),
            block_best: None,
            block_len: 0,
            segment: 0,
            rejected: 0,
            state: ClockState {
                samples: 0,
                device_us: 0,
                arrival_us: 0,
                mapped_us: 0,
                rate: 1.0,
                drift_ppm: 0.0,
                rate_clamped: false,
                offset_us: 0.0,
                delay_us: 0.0,
                blocks: 0,
                refits: 0,
                corrections: 0,
                non_increasing: 0,
                resets: 0,
                no_device_time: 0,
            },
        }
    }

    /// The model's state after the samples mapped so far.
    pub fn state(&self) -> ClockState {
        self.state
    }

    /// Maps the samples one transport read completed (all with the same
    /// arrival time, in order): sets `mapped_time_us`, `time_order` and
    /// `clock_segment` of each.
    pub fn map_read(&mut self, samples: &mut [GazeSample]) {
        if samples.is_empty() {
            return;
        }
        // A new anchor puts the read's last record (the least delayed) at
        // its arrival: the earlier ones were captured before it.
        let last_device = samples.iter().rev().find_map(|s| s.device_time_us);
        for s in samples.iter_mut() {
            let (mapped, order) = self.map_one(s.device_time_us, s.host_time_us, last_device);
            s.mapped_time_us = mapped;
            s.time_order = order;
            s.clock_segment = self.segment;
        }
    }

    /// Maps one sample on its own (a read that completed one record).
    pub fn map_sample(&mut self, sample: &mut GazeSample) {
        self.map_read(std::slice::from_mut(sample));
    }

    fn map_one(
        &mut self,
        device: Option<u64>,
        arrival: u64,
        read_last_device: Option<u64>,
    ) -> (u64, TimeOrder) {
        self.state.samples += 1;
        self.state.arrival_us = arrival;
        let Some(d) = device else {
            // No device time: the arrival stands in, kept strictly after
            // the previous mapped time.
            self.state.no_device_time += 1;
            let m = match self.last {
                Some((_, lm)) => (arrival as f64).max(lm.floor() + 1.0),
                None => arrival as f64,
            };
            self.last = Some((arrival, m));
            return self.finish(arrival, m, TimeOrder::NoDeviceTime);
        };
        let Some((ld, lm)) = self.last else {
            let m = anchor(d, arrival, read_last_device, self.rate);
            self.start_segment(d, arrival);
            self.last = Some((d, m));
            return self.finish(d, m, TimeOrder::First);
        };
        let dd = d as f64 - ld as f64;
        let pred = lm + self.rate * dd;
        let ahead = pred - arrival as f64;
        let rejected = dd < 0.0 || ahead > AHEAD_US;
        self.rejected = if rejected { self.rejected + 1 } else { 0 };
        if dd.abs() > RESET_US || ahead > RESET_US || self.rejected >= JUMP_CONFIRM {
            // A device clock reset: a new segment, anchored at the arrival
            // and strictly after everything mapped before.
            self.state.resets += 1;
            self.segment += 1;
            self.rejected = 0;
            let m = anchor(d, arrival, read_last_device, self.rate).max(lm.floor() + 1.0);
            self.start_segment(d, arrival);
            self.last = Some((d, m));
            return self.finish(d, m, TimeOrder::Reset);
        }
        if dd <= 0.0 || rejected {
            self.state.non_increasing += 1;
            let order = if dd == 0.0 {
                TimeOrder::Repeated
            } else if dd < 0.0 {
                TimeOrder::Backwards
            } else {
                TimeOrder::Ahead
            };
            return self.finish(d, lm, order);
        }
        let step = self.rate * dd;
        let a = arrival as f64;
        let m = if pred > a {
            // Captured after it arrived: the anchor was late.
            self.state.corrections += 1;
            let back = (pred - a).min(MAX_STEP_US).min(step - 1.0).max(0.0);
            (pred - back).max(lm + 1.0)
        } else {
            let target = self
                .envelope
                .map_or(pred, |b| b + self.rate * (d as f64 - self.origin as f64));
            let slew = SLEW * step;
            (pred + (target - pred).clamp(-slew, slew))
                .min(a)
                .max(lm + 1.0)
        };
        self.observe(d, arrival);
        self.last = Some((d, m));
        self.finish(d, m, TimeOrder::Increasing)
    }

    fn finish(&mut self, d: u64, m: f64, order: TimeOrder) -> (u64, TimeOrder) {
        let mapped = m.round().max(0.0) as u64;
        let st = &mut self.state;
        st.device_us = d;
        st.mapped_us = mapped;
        st.offset_us = m - d as f64;
        st.delay_us = st.arrival_us as f64 - m;
        st.rate = self.rate;
        st.drift_ppm = (1.0 / self.rate - 1.0) * 1e6;
        st.rate_clamped = self.rate_clamped;
        st.blocks = self.blocks.len();
        (mapped, order)
    }

    fn start_segment(&mut self, d: u64, arrival: u64) {
        self.origin = d;
        self.blocks.clear();
        self.block_best = None;
        self.block_len = 0;
        self.envelope = None;
        self.observe(d, arrival);
    }

    /// Adds a (device, arrival) pair to the envelope; refits at the end of
    /// each block.
    fn observe(&mut self, d: u64, arrival: u64) {
        let delay = |p: (u64, u64)| p.1 as f64 - p.0 as f64;
        if self
            .block_best
            .is_none_or(|b| delay((d, arrival)) < delay(b))
        {
            self.block_best = Some((d, arrival));
        }
        self.block_len += 1;
        if self.block_len < BLOCK {
            return;
        }
        if let Some(b) = self.block_best.take() {
            self.blocks.push_back(b);
            if self.blocks.len() > MAX_BLOCKS {
                self.blocks.pop_front();
            }
        }
        self.block_len = 0;
        self.refit();
    }

    fn refit(&mut self) {
        if self.blocks.len() >= MIN_BLOCKS {
            let pairs: Vec<(u64, u64)> = self.blocks.iter().copied().collect();
            if let Some(fit) = ClockModel::fit(&pairs) {
                let lo = 1.0 - MAX_DRIFT;
                let hi = 1.0 + MAX_DRIFT;
                self.rate_clamped = !(lo..=hi).contains(&fit.rate);
                self.rate = fit.rate.clamp(lo, hi);
                self.state.refits += 1;
            }
        }
        let (origin, rate) = (self.origin as f64, self.rate);
        self.envelope = self
            .blocks
            .iter()
            .map(|&(d, a)| a as f64 - rate * (d as f64 - origin))
            .min_by(f64::total_cmp);
    }
}

/// The mapped time of device time `d` when the read's last record
/// (`read_last`, device time) is put at `arrival`.
fn anchor(d: u64, arrival: u64, read_last: Option<u64>, rate: f64) -> f64 {
    let last = read_last.unwrap_or(d).max(d);
    arrival as f64 - rate * (last as f64 - d as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::EyeSample;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};

    fn sample(device: Option<u64>, arrival: u64) -> GazeSample {
        GazeSample::new(0, device, arrival, EyeSample::MISSING, EyeSample::MISSING)
    }

    /// Maps `(device, arrival)` pairs, grouping equal consecutive arrivals
    /// into one read as a driver does.
    fn map_all(pairs: &[(u64, u64)]) -> (Vec<GazeSample>, ClockMapper) {
        let mut m = ClockMapper::new();
        let mut out: Vec<GazeSample> = pairs.iter().map(|&(d, a)| sample(Some(d), a)).collect();
        let mut i = 0;
        while i < out.len() {
            let a = out[i].host_time_us;
            let j = i + out[i..].iter().take_while(|s| s.host_time_us == a).count();
            m.map_read(&mut out[i..j]);
            i = j;
        }
        (out, m)
    }

    /// A 120 Hz device clock `drift_ppm` off the host, delivered with
    /// `jitter_us` of latency noise and bursts: reads every `burst`
    /// samples, each read arriving after its last record.
    fn stream(
        n: usize,
        drift_ppm: f64,
        jitter_us: u64,
        burst: usize,
        stall_every: usize,
        stall_us: u64,
        seed: u64,
    ) -> Vec<(u64, u64, u64)> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let period = 8_333.0;
        let mut out = Vec::with_capacity(n);
        let mut k = 0;
        let mut stall = 0;
        while k < n {
            let end = (k + burst).min(n);
            let true_last = 1_000_000.0 + period * (end - 1) as f64;
            if stall_every > 0 && rng.random_range(0..stall_every) == 0 {
                stall = stall_us;
            }
            let arrival = true_last as u64 + 2_000 + rng.random_range(0..=jitter_us) + stall;
            stall = stall.saturating_sub(burst as u64 * 8_333);
            for j in k..end {
                let t = 1_000_000.0 + period * j as f64;
                let device = (5e9 + t * (1.0 + drift_ppm * 1e-6)) as u64;
                out.push((device, arrival.max(t as u64), t as u64));
            }
            k = end;
        }
        out
    }

    #[test]
    fn a_quiet_stream_maps_to_capture_plus_the_minimum_latency() {
        let s = stream(20_000, 40.0, 500, 1, 0, 0, 1);
        let pairs: Vec<(u64, u64)> = s.iter().map(|p| (p.0, p.1)).collect();
        let (out, m) = map_all(&pairs);
        let st = m.state();
        assert!((st.drift_ppm - 40.0).abs() < 5.0, "{st:?}");
        // Late in the run: mapped ≈ true capture + 2 ms (the minimum).
        for (o, p) in out[15_000..].iter().zip(&s[15_000..]) {
            let err = o.mapped_time_us as f64 - p.2 as f64 - 2_000.0;
            assert!(err.abs() < 300.0, "{err} at {}", o.mapped_time_us);
        }
    }

    #[test]
    fn a_delayed_first_read_is_corrected_without_breaking_intervals() {
        // The first 30 samples arrive in one read 200 ms late.
        let mut s = stream(5_000, 0.0, 200, 1, 0, 0, 2);
        let late = s[29].1 + 200_000;
        for p in &mut s[..30] {
            p.1 = late;
        }
        let pairs: Vec<(u64, u64)> = s.iter().map(|p| (p.0, p.1)).collect();
        let (out, m) = map_all(&pairs);
        assert!(m.state().corrections > 0);
        for w in out.windows(2) {
            let dd = w[1].device_time_us.unwrap() - w[0].device_time_us.unwrap();
            let dm = w[1].mapped_time_us - w[0].mapped_time_us;
            assert!(w[1].mapped_time_us > w[0].mapped_time_us);
            assert!((dm as f64 - dd as f64).abs() <= 100.0, "{dm} vs {dd}");
        }
        // Captured no later than it arrived, once corrected.
        let tail = &out[4_500..];
        assert!(tail.iter().all(|o| o.mapped_time_us <= o.host_time_us));
    }

    #[test]
    fn repeated_backwards_and_reset_device_times_are_flagged() {
        let pairs = [
            (1_000, 10_000),
            (9_333, 18_400),
            (9_333, 18_500),
            (9_000, 18_600),
            (17_666, 26_700),
            (900_000_000_000, 35_000),
            (900_000_008_333, 43_400),
        ];
        let (out, m) = map_all(&pairs);
        let orders: Vec<TimeOrder> = out.iter().map(|s| s.time_order).collect();
        use TimeOrder::*;
        assert_eq!(
            orders,
            [First, Increasing, Repeated, Backwards, Increasing, Reset, Increasing]
        );
        assert_eq!(out[2].mapped_time_us, out[1].mapped_time_us);
        assert_eq!(out[5].clock_segment, 1);
        assert!(out[5].mapped_time_us > out[4].mapped_time_us);
        let st = m.state();
        assert_eq!((st.non_increasing, st.resets), (2, 1));
    }

    /// One corrupt timestamp 3 s ahead is skipped and does not become the
    /// reference: the samples after it stay on time. A real jump (every
    /// sample after it) is confirmed after JUMP_CONFIRM samples.
    #[test]
    fn one_timestamp_ahead_is_skipped_and_a_lasting_jump_is_a_reset() {
        let mut pairs: Vec<(u64, u64)> = (0..40).map(|k| (k * 8_333, 1_000 + k * 8_333)).collect();
        pairs[20].0 += 3_000_000;
        let (out, _) = map_all(&pairs);
        assert_eq!(out[20].time_order, TimeOrder::Ahead);
        assert!(out[21..]
            .iter()
            .all(|s| s.time_order == TimeOrder::Increasing));
        let mut pairs: Vec<(u64, u64)> = (0..40).map(|k| (k * 8_333, 1_000 + k * 8_333)).collect();
        for p in &mut pairs[20..] {
            p.0 += 3_000_000;
        }
        let (out, m) = map_all(&pairs);
        let k = 20 + JUMP_CONFIRM as usize - 1;
        assert!(out[20..k].iter().all(|s| s.time_order == TimeOrder::Ahead));
        assert_eq!(out[k].time_order, TimeOrder::Reset);
        assert!(out[k + 1..]
            .iter()
            .all(|s| s.time_order == TimeOrder::Increasing));
        assert_eq!(m.state().resets, 1);
        for w in out.windows(2) {
            assert!(w[1].mapped_time_us >= w[0].mapped_time_us);
        }
    }

    #[test]
    fn samples_without_a_device_time_take_their_arrival() {
        let mut m = ClockMapper::new();
        let mut s = [sample(None, 100), sample(None, 100), sample(None, 90)];
        m.map_read(&mut s);
        let t: Vec<u64> = s.iter().map(|s| s.mapped_time_us).collect();
        assert_eq!(t, [100, 101, 102]);
        assert!(s.iter().all(|s| s.time_order == TimeOrder::NoDeviceTime));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(48)))]

        /// Whatever the load (bursts, stalls, jitter) and drift: mapped
        /// times increase strictly, and each interval is the device's
        /// within 0.1 ms.
        #[test]
        fn mapped_times_increase_and_keep_device_intervals(
            drift in -200.0f64..200.0,
            jitter in 0u64..20_000,
            burst in 1usize..7,
            stall_every in prop_oneof![Just(0usize), 5usize..200],
            stall in 0u64..200_000,
            seed in any::<u64>(),
        ) {
            let s = stream(3_000, drift, jitter, burst, stall_every, stall, seed);
            let pairs: Vec<(u64, u64)> = s.iter().map(|p| (p.0, p.1)).collect();
            let (out, _) = map_all(&pairs);
            for w in out.windows(2) {
                prop_assert!(w[1].mapped_time_us > w[0].mapped_time_us);
                let dd = (w[1].device_time_us.unwrap() - w[0].device_time_us.unwrap()) as f64;
                let dm = (w[1].mapped_time_us - w[0].mapped_time_us) as f64;
                prop_assert!((dm - dd).abs() <= 100.0, "{} vs {}", dm, dd);
            }
        }

        /// Hostile device times (zero, huge, repeated, out of order) never
        /// panic, and the mapped times never go backwards.
        #[test]
        fn hostile_device_times_never_break_the_order(
            pairs in proptest::collection::vec(
                (prop_oneof![Just(0u64), Just(u64::MAX), any::<u64>(), 0u64..1_000_000], 0u64..10_000_000),
                1..200,
            ),
        ) {
            let mut pairs = pairs;
            pairs.sort_by_key(|p| p.1);
            let (out, _) = map_all(&pairs);
            for w in out.windows(2) {
                prop_assert!(w[1].mapped_time_us >= w[0].mapped_time_us);
                if w[1].time_order.is_timed() {
                    prop_assert!(w[1].mapped_time_us > w[0].mapped_time_us);
                }
            }
        }
    }
}
