//! The mouse emulator on a virtual clock: the same device (cursor in,
//! records out: [`MouseEmulator`]) and the same decoder
//! ([`MouseDecoder`]), ticked synchronously at the times a caller names
//! instead of by a thread on the host clock. A headless simulated session
//! (`gazecast experiment run --headless`) runs on it: its participant's
//! looks go in as cursor events, every tick up to the session's virtual
//! "now" comes out as a [`TrackerMsg::Gaze`], and the record bytes go to
//! the session's recording like a live device's, so the recording replays.
//!
//! **Clock.** The virtual clock is the device's clock and the host's: a
//! sample's device time, arrival and mapped time are the tick's time (the
//! transport adds no delay; the emulator's own `latency_ms` still delays
//! the gaze behind the cursor). Nothing here reads the host's clock, so a
//! session's samples are the same however fast or loaded the machine is.

use std::collections::VecDeque;

use crate::mouse::{CursorEvent, MouseConfig, MouseDecoder, MouseEmulator};
use crate::recording::Tap;
use crate::source::Decoder;
use crate::supervisor::{Faults, TrackerMsg};
use crate::timing::TimeOrder;

/// The emulated mouse tracker, ticked on a virtual clock.
pub struct VirtualMouse {
    emulator: MouseEmulator,
    decoder: MouseDecoder,
    period_us: u64,
    next_tick_us: u64,
    tap: Option<Tap>,
    first: bool,
    decoded: VecDeque<crate::GazeSample>,
    samples: u64,
    missing: u64,
}

impl VirtualMouse {
    /// A device whose first tick is at `start_us` (virtual µs); its record
    /// bytes go to `tap` (the session's recording) when given.
    pub fn new(config: MouseConfig, start_us: u64, tap: Option<Tap>) -> Self {
        let period_us = config.period_us();
        Self {
            emulator: MouseEmulator::new(config),
            decoder: MouseDecoder::new(),
            period_us,
            next_tick_us: start_us,
            tap,
            first: true,
            decoded: VecDeque::new(),
            samples: 0,
            missing: 0,
        }
    }

    /// The cursor (the simulated eye's target) moved at `event.t_us`.
    /// Events must come in time order.
    pub fn cursor(&mut self, event: CursorEvent) {
        self.emulator.cursor(event);
    }

    /// Runs every tick at or before `now_us`, appending each sample to
    /// `out` (raw = the screen point, the mouse's tracker units; `gaze_px`
    /// the same when it is finite).
    pub fn advance_to(&mut self, now_us: u64, out: &mut Vec<TrackerMsg>) {
        while self.next_tick_us <= now_us {
            let t = self.next_tick_us;
            self.next_tick_us = t.saturating_add(self.period_us.max(1));
            let record = self.emulator.tick(t);
            if let Some(tap) = &self.tap {
                tap.device_to_host(t, &record);
            }
            self.decoder.push(&record, t, &mut self.decoded);
            while let Some(s) = self.decoded.pop_front() {
                let raw = s.gaze().filter(|p| p[0].is_finite() && p[1].is_finite());
                let time_order = if std::mem::take(&mut self.first) {
                    TimeOrder::First
                } else {
                    TimeOrder::Increasing
                };
                self.samples += 1;
                self.missing += u64::from(raw.is_none());
                let device_us = s.device_time_us.unwrap_or(t);
                out.push(TrackerMsg::Gaze {
                    received_us: t,
                    device_us: Some(device_us),
                    arrival_us: t,
                    mapped_us: device_us,
                    time_order,
                    segment: 0,
                    raw,
                    gaze_px: raw,
                    eyes_px: None,
                    eye_distance_mm: None,
                    // The mouse measures no eyes (its decoder copies one
                    // point into both).
                    eyes: [crate::EyeSample::MISSING; 2],
                    eye_px: [None, None],
                });
            }
        }
    }

    /// The counts a supervised device's session log shows: samples,
    /// samples without a gaze, the decoder's totals (a virtual device has
    /// no silences, undecodable stretches or reconnects).
    pub fn faults(&self) -> Faults {
        Faults {
            samples: self.samples,
            missing: self.missing,
            decode: self.decoder.stats(),
            ..Faults::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> MouseConfig {
        MouseConfig {
            rate_hz: 100.0,
            jitter_rms_deg: 0.1,
            saccades: true,
            ..MouseConfig::default()
        }
    }

    fn run(steps: &[u64]) -> Vec<(u64, Option<[f64; 2]>)> {
        let mut m = VirtualMouse::new(config(), 0, None);
        m.cursor(CursorEvent {
            t_us: 0,
            position_px: [100.0, 100.0],
            blink: false,
        });
        m.cursor(CursorEvent {
            t_us: 50_000,
            position_px: [600.0, 300.0],
            blink: false,
        });
        let mut out = Vec::new();
        for &s in steps {
            m.advance_to(s, &mut out);
        }
        out.into_iter()
            .filter_map(|m| match m {
                TrackerMsg::Gaze {
                    mapped_us, gaze_px, ..
                } => Some((mapped_us, gaze_px)),
                _ => None,
            })
            .collect()
    }

    /// Samples depend on the virtual times alone: advancing in one step or
    /// in many gives the same samples, one per period, in time order.
    #[test]
    fn samples_do_not_depend_on_how_the_clock_is_advanced() {
        let one = run(&[300_000]);
        let many = run(&[1, 9_999, 10_000, 123_456, 123_457, 299_999, 300_000]);
        assert_eq!(one, many);
        assert_eq!(one.len(), 31);
        assert!(one.windows(2).all(|w| w[1].0 == w[0].0 + 10_000));
        // The eye went from the first point to the second by a saccade.
        let first = one[0].1.expect("valid");
        let last = one[30].1.expect("valid");
        assert!((first[0] - 100.0).abs() < 20.0 && (last[0] - 600.0).abs() < 20.0);
        let between = one
            .iter()
            .filter_map(|s| s.1)
            .filter(|p| p[0] > 150.0 && p[0] < 550.0)
            .count();
        assert!(between >= 1, "a saccade passes through the middle");
    }

    #[test]
    fn the_first_sample_is_first_and_the_rest_increase() {
        let mut m = VirtualMouse::new(config(), 5_000, None);
        let mut out = Vec::new();
        m.advance_to(4_999, &mut out);
        assert!(out.is_empty());
        m.advance_to(25_000, &mut out);
        let orders: Vec<TimeOrder> = out
            .iter()
            .filter_map(|m| match m {
                TrackerMsg::Gaze { time_order, .. } => Some(*time_order),
                _ => None,
            })
            .collect();
        assert_eq!(
            orders,
            vec![
                TimeOrder::First,
                TimeOrder::Increasing,
                TimeOrder::Increasing
            ]
        );
        assert_eq!(m.faults().decode.records, 3);
        assert_eq!(m.faults().samples, 3);
    }
}
