//! The live mouse device: a cursor script in, gaze samples out through the
//! same stream driver a serial tracker uses.

use std::time::Duration;

use tracker_hal::mouse::{spawn_device, CursorEvent, MouseConfig, MouseDecoder};
use tracker_hal::{clock::monotonic_us, GazeSource, MonotonicClock, StreamDriver};

#[test]
fn cursor_positions_come_back_as_gaze_at_the_configured_rate() {
    let (tx, rx) = crossbeam_channel::unbounded();
    let cfg = MouseConfig {
        rate_hz: 200.0,
        ..MouseConfig::default()
    };
    let link = spawn_device(cfg, rx).expect("device thread");
    let mut driver = StreamDriver::new(link, MouseDecoder::new(), Box::new(MonotonicClock));
    tx.send(CursorEvent {
        t_us: monotonic_us(),
        position_px: [100.0, 50.0],
        blink: false,
    })
    .expect("send");
    driver.start().expect("start");
    let mut samples = Vec::new();
    while samples.len() < 40 {
        samples.push(driver.next_sample().expect("sample").expect("stream open"));
        if samples.len() == 20 {
            tx.send(CursorEvent {
                t_us: monotonic_us(),
                position_px: [300.0, 400.0],
                blink: true,
            })
            .expect("send");
        }
    }
    assert_eq!(samples[0].gaze(), Some([100.0, 50.0]));
    assert_eq!(samples[39].gaze(), None, "a held button is a blink");
    // 200 Hz: the device clock advances ~5 ms per sample.
    let span = samples[39].device_time_us.expect("t") - samples[0].device_time_us.expect("t");
    assert!(
        (150_000..260_000).contains(&span),
        "39 periods took {span} µs"
    );
    driver.stop().expect("stop");
    // Closing the cursor channel ends the device: the driver sees end of stream.
    drop(tx);
    let end = std::time::Instant::now() + Duration::from_secs(5);
    loop {
        match driver.next_sample() {
            Ok(None) => break,
            Ok(Some(_)) => assert!(std::time::Instant::now() < end, "stream did not end"),
            Err(e) => panic!("{e}"),
        }
    }
}
