//! Ctrl-C and SIGTERM: caught once per process, then seen by the window
//! loops and commands as a request to shut down cleanly (devices stopped,
//! recordings closed).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use tracker_hal::clock::monotonic_us;

/// Set by Ctrl-C (SIGINT) or SIGTERM; the window loops check it every frame
/// and shut down as if the window had been closed.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// Host monotonic time (µs) of the first interrupt.
static INTERRUPTED_AT_US: AtomicU64 = AtomicU64::new(0);

/// Installs the Ctrl-C / SIGTERM handler (once per process).
pub fn catch_interrupts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            let _ = INTERRUPTED_AT_US.compare_exchange(
                0,
                monotonic_us().max(1),
                Ordering::SeqCst,
                Ordering::SeqCst,
            );
            INTERRUPTED.store(true, Ordering::SeqCst);
        });
    });
}

/// When the first Ctrl-C or SIGTERM arrived (host monotonic µs).
pub fn interrupted_at_us() -> Option<u64> {
    Some(INTERRUPTED_AT_US.load(Ordering::SeqCst)).filter(|&t| t > 0)
}

/// Whether Ctrl-C or SIGTERM has arrived.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}
