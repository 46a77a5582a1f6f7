//! A tracker file's decoder says how its device times are made, through
//! the box every driver is handled in: an ISCAN (no time on the wire) by
//! its record counter, the mouse emulator by its own timestamps. The boxed
//! decoder once fell back to the trait's default and called an ISCAN's
//! counted times the tracker's own.

use tracker_hal::config::{Driver, TrackerConfig};
use tracker_hal::iscan::{IscanConfig, IscanMode};
use tracker_hal::{Decoder, DeviceClock};

#[test]
fn a_boxed_decoder_reports_its_own_device_clock() {
    let iscan = TrackerConfig {
        driver: Driver::Iscan(IscanConfig::binocular(IscanMode::Binary)),
        mapping: Default::default(),
    };
    let boxed = iscan.decoder();
    assert!(
        matches!(boxed.device_clock(), DeviceClock::Counter { period_us } if period_us > 0.0),
        "{:?}",
        boxed.device_clock()
    );
    let mouse = TrackerConfig {
        driver: Driver::Mouse(Default::default()),
        mapping: Default::default(),
    };
    assert_eq!(mouse.decoder().device_clock(), DeviceClock::Device);
}
