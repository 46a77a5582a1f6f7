//! Real serial I/O: a recorded ISCAN stream written into one end of a
//! pseudo-terminal at 19200 baud pacing, decoded from the other end through
//! the normal `serialport` path.

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

use tracker_hal::csv::csv_row;
use tracker_hal::{GazeSource, MonotonicClock, Recording, StreamDriver};

#[test]
fn iscan_stream_decodes_through_a_pseudo_terminal() {
    let rec = Recording::read(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("data/iscan-binary-60hz.gzrec"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let expected: Vec<String> = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/iscan-binary-60hz.csv"),
    )
    .expect("expected csv")
    .lines()
    .skip(1)
    .map(String::from)
    .collect();
    // The first 120 records: 2 s of data at the tracker's 60 Hz.
    let records = 120;
    let bytes: Vec<u8> = rec
        .device_chunks()
        .flat_map(|c| c.payload.iter().copied())
        .collect();
    let bytes = bytes[..records * 10].to_vec();

    use serialport::SerialPort as _;
    let (mut master, slave) = serialport::TTYPort::pair().expect("pseudo-terminal pair");
    let path = slave.name().expect("slave has a path");
    // serialport locks ports exclusively: release the slave before opening it by path.
    drop(slave);
    let port = tracker_hal::serial::open(&path, 19_200, Duration::from_millis(200))
        .unwrap_or_else(|e| panic!("{e}"));

    let writer = std::thread::spawn(move || {
        // Pace the records as the tracker sends them, one every 1/60 s (a
        // record counter's device time runs at that rate: records sent
        // faster than the tracker samples would run the device clock more
        // than 1 s ahead of their arrival, and be marked `ahead`).
        let start = Instant::now();
        for (k, chunk) in bytes.chunks(10).enumerate() {
            let due = start + Duration::from_micros(k as u64 * 1_000_000 / 60);
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            master.write_all(chunk).expect("write to the pty");
        }
        master.flush().expect("flush");
        // Keep the master open until the reader is done.
        std::thread::sleep(Duration::from_millis(500));
    });

    let mut driver = StreamDriver::new(
        port,
        tracker_hal::iscan::IscanDecoder::new(tracker_hal::iscan::IscanConfig::binocular(
            tracker_hal::iscan::IscanMode::Binary,
        )),
        Box::new(MonotonicClock),
    );
    driver.start().expect("start byte goes out");
    let mut got = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(10);
    while got.len() < records && Instant::now() < deadline {
        match driver.next_sample() {
            Ok(Some(s)) => got.push(s),
            Ok(None) => break,
            Err(e) if e.kind == tracker_hal::ErrorKind::TimedOut => continue,
            Err(e) => panic!("{e}"),
        }
    }
    writer.join().expect("writer");
    assert_eq!(got.len(), records);
    // Same sequence, device times (the record-counting clock does not
    // depend on when bytes arrive) and positions as the expected CSV; the
    // arrival and mapped times (columns 3 and 4) are live.
    for (s, want) in got.iter().zip(&expected) {
        let row = csv_row(s, &|p| Some(p));
        let fixed = |r: &str| {
            let c: Vec<String> = r.split(',').map(String::from).collect();
            [&c[..2], &c[4..]].concat()
        };
        assert_eq!(fixed(&row), fixed(want));
    }
    assert_eq!(driver.stats().dropped_bytes, 0);
    // Host times follow the pacing: 120 records over ~2 s.
    let span = got[records - 1].host_time_us - got[0].host_time_us;
    assert!(
        span > 1_500_000,
        "records arrived in {span} µs: the pacing was not seen"
    );
}
