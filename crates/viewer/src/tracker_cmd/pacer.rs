//! Real-time pacing of `gazecast replay --realtime`.

use std::io::Write;
use std::time::{Duration, Instant};

use crate::interrupt;

/// The longest pacing wait of `replay --realtime`: a longer silent gap in
/// the data is skipped, with a warning.
const MAX_PACING_SLEEP: Duration = Duration::from_secs(5);

/// Real-time pacing of `replay --realtime`: each sample is released at its
/// recorded host time's offset from the first, less the gaps skipped.
pub(super) struct Pacer {
    /// Wall time and host time of the first sample.
    start: Option<(Instant, u64)>,
    /// Recorded time skipped so far (gaps beyond [`MAX_PACING_SLEEP`]).
    skipped_us: u64,
}

impl Pacer {
    pub(super) fn new() -> Self {
        Self {
            start: None,
            skipped_us: 0,
        }
    }

    /// Waits until a sample recorded at `host_us` is due (never more than
    /// [`MAX_PACING_SLEEP`]); false when interrupted while waiting.
    pub(super) fn wait(&mut self, host_us: u64, err: &mut dyn Write) -> bool {
        let (start, first) = *self.start.get_or_insert((Instant::now(), host_us));
        let offset = host_us
            .saturating_sub(first)
            .saturating_sub(self.skipped_us);
        let mut due = start + Duration::from_micros(offset);
        let now = Instant::now();
        if due > now + MAX_PACING_SLEEP {
            let gap = due - now;
            let _ = writeln!(
                err,
                "warning: gap of {:.0} s skipped (replay --realtime waits at most {} s)",
                gap.as_secs_f64(),
                MAX_PACING_SLEEP.as_secs()
            );
            self.skipped_us = self
                .skipped_us
                .saturating_add(u64::try_from(gap.as_micros()).unwrap_or(u64::MAX));
            due = now;
        }
        loop {
            if interrupt::interrupted() {
                return false;
            }
            let now = Instant::now();
            if due <= now {
                return true;
            }
            std::thread::sleep((due - now).min(Duration::from_millis(50)));
        }
    }
}
