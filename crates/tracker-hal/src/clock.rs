//! Host time: a monotonic microsecond clock, replaceable for replay and tests.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

/// A source of host monotonic time in microseconds.
pub trait Clock: Send {
    /// The current time, µs.
    fn now_us(&self) -> u64;
}

fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

/// Microseconds since the first use of the process-wide epoch (monotonic).
pub fn monotonic_us() -> u64 {
    epoch().elapsed().as_micros() as u64
}

/// The real host clock.
#[derive(Debug, Clone, Copy, Default)]
pub struct MonotonicClock;

impl Clock for MonotonicClock {
    fn now_us(&self) -> u64 {
        monotonic_us()
    }
}

/// A clock set by someone else: replay sets it to each chunk's recorded
/// arrival time; tests set it by hand. Clones share the time.
#[derive(Debug, Clone, Default)]
pub struct SharedClock(Arc<AtomicU64>);

impl SharedClock {
    /// Sets the time every clone reads, µs.
    pub fn set_us(&self, t: u64) {
        self.0.store(t, Ordering::Release);
    }
}

impl Clock for SharedClock {
    fn now_us(&self) -> u64 {
        self.0.load(Ordering::Acquire)
    }
}
