//! `gazecast replay`, `record`, `devices` and `simulate`: the tracker side of
//! the command line, one command a module ([`replay`], [`record`],
//! [`devices`], [`simulate`]); the decoding, recording and simulating are
//! tracker-hal's.

mod devices;
mod pacer;
mod record;
mod replay;
mod sample_csv;
mod simulate;

use std::path::Path;

use tracker_hal::TrackerConfig;

pub use devices::devices;
pub use record::{record, RecordArgs};
pub use replay::{replay, InputFormat, ReplayArgs};
pub use simulate::{simulate, simulated, HidLayoutArg, ScriptArg, SimulateArgs};

/// A tracker file, with the error as a message.
pub(crate) fn load_tracker(path: &Path) -> Result<TrackerConfig, String> {
    crate::config::load_tracker(path).map_err(|e| e.to_string())
}
