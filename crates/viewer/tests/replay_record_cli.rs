//! `replay` against a recording's header, `record` under Ctrl-C, and the
//! argument checks of `record`, `simulate`, `view` and `replay --realtime`.

mod common;

use common::gazecast;

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant};

use serialport::SerialPort;
use tracker_hal::recording::{write_recording, Chunk, ChunkKind};

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(p)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Waits for `child` at most `limit`; kills it (and fails) past that.
fn wait_for(mut child: Child, limit: Duration, what: &str) -> Output {
    let deadline = Instant::now() + limit;
    while child.try_wait().expect("wait").is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!("{what}: still running after {limit:?}: {}", stderr(&out));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

fn replay_240(tracker: Option<&str>, extra: &[&str], csv: &Path) -> Output {
    let mut c = gazecast();
    c.arg("replay");
    if let Some(t) = tracker {
        c.args(["--tracker", t]);
    }
    c.args(["--input", "tests/data/iscan-binary-240hz.gzrec", "--raw"])
        .args(extra)
        .arg("--csv")
        .arg(csv)
        .output()
        .expect("runs")
}

#[test]
fn a_recording_decodes_with_its_headers_tracker_without_tracker() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("o.csv");
    let expected =
        std::fs::read_to_string(repo("tests/data/iscan-binary-240hz.csv")).expect("expected");
    let out = replay_240(None, &[], &csv);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(std::fs::read_to_string(&csv).expect("csv"), expected);
    // A tracker file that agrees with the header is accepted.
    let out = replay_240(Some("tests/data/iscan-binary-115200.ron"), &[], &csv);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(std::fs::read_to_string(&csv).expect("csv"), expected);
    // So is one that differs only in how the live device is reached (the
    // mouse's realism, baked into the stream) — the pairing older tests use.
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/mouse.ron",
            "--input",
            "tests/data/mouse-120hz.gzrec",
            "--csv",
        ])
        .arg(&csv)
        .output()
        .expect("runs");
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn a_tracker_that_disagrees_with_the_header_is_an_error_listing_each_field() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("o.csv");
    // The 19200-baud ISCAN file on the 115200-baud recording: every device
    // time used to come out 4.3 ms off, silently.
    let out = replay_240(Some("config/trackers/iscan-binary.ron"), &[], &csv);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    for needle in [
        "driver.baud: header 115200, --tracker 19200",
        "driver.start_command: header 128, --tracker 132",
        "mapping.screen_px: header [1920,1080], --tracker [1280,1024]",
        "--tracker-overrides-header",
    ] {
        assert!(err.contains(needle), "`{needle}` not in {err}");
    }
    assert!(!err.contains("port"), "the port is not compared: {err}");
    assert!(!csv.exists());
    // Another driver altogether.
    let out = replay_240(Some("config/trackers/mouse.ron"), &[], &csv);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("driver: header iscan, --tracker mouse"),
        "{err}"
    );
    // The override decodes with --tracker, and says what differs.
    let out = replay_240(
        Some("config/trackers/iscan-binary.ron"),
        &["--tracker-overrides-header"],
        &csv,
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("warning:"), "{err}");
    assert!(
        err.contains("driver.baud: header 115200, --tracker 19200"),
        "{err}"
    );
    // Raw bytes have no header: --tracker stays required.
    let out = gazecast()
        .args([
            "replay",
            "--format",
            "raw-bytes",
            "--input",
            "tests/data/iscan-binary-60hz.csv",
            "--csv",
        ])
        .arg(&csv)
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("needs --tracker"), "{}", stderr(&out));
}

#[test]
fn view_refuses_a_tracker_that_disagrees_with_its_replay() {
    let view = |tracker: &str| {
        gazecast()
            .args([
                "view",
                "--scene",
                "config/scenes/search-task.ron",
                "--display",
                "config/displays/tobii-et1750-17in.ron",
                "--replay",
                "tests/data/iscan-binary-240hz.gzrec",
                "--tracker",
                tracker,
                "--explain",
            ])
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .expect("runs")
    };
    let out = view("config/trackers/iscan-binary.ron");
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("driver.baud: header 115200, --tracker 19200"),
        "{}",
        stderr(&out)
    );
    // Agreeing, it is only redundant.
    let out = view("tests/data/iscan-binary-115200.ron");
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn record_refuses_seconds_that_are_not_a_positive_number() {
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = dir.path().join("r.gzrec");
    for s in ["-1", "0", "NaN", "inf"] {
        let out = gazecast()
            .args([
                "record",
                "--tracker",
                "config/trackers/iscan-binary.ron",
                "--seconds",
                s,
                "--out",
            ])
            .arg(&rec)
            .output()
            .expect("runs");
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{s}: {err}");
        assert!(
            err.contains(&format!("--seconds {}", s.to_lowercase()))
                || err.contains(&format!("--seconds {s}")),
            "{s}: {err}"
        );
        assert!(!rec.exists(), "{s}");
    }
}

#[test]
fn simulate_checks_the_rate_before_generating_anything() {
    let dir = tempfile::tempdir().expect("tempdir");
    let start = Instant::now();
    let child = gazecast()
        .args([
            "simulate",
            "--tracker",
            "config/trackers/mouse.ron",
            "--rate",
            "1e9",
            "--seconds",
            "1",
            "--out",
        ])
        .arg(dir.path().join("s.gzrec"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let out = wait_for(child, Duration::from_secs(20), "simulate --rate 1e9");
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--rate 1000000000"),
        "{}",
        stderr(&out)
    );
    assert!(start.elapsed() < Duration::from_secs(5));
}

/// The first `keep_s` seconds of the mouse test recording, and with
/// `gap_us`, the next `keep_s` seconds shifted that much later.
fn cut_recording(path: &Path, keep_s: f64, gap_us: Option<u64>) -> usize {
    let rec = tracker_hal::Recording::read(&repo("tests/data/mouse-120hz.gzrec")).expect("data");
    let t0 = rec.chunks.first().map_or(0, |c| c.time_us);
    let keep = (keep_s * 1e6) as u64;
    let mut chunks: Vec<Chunk> = Vec::new();
    for c in &rec.chunks {
        let t = c.time_us - t0;
        if t < keep {
            chunks.push(c.clone());
        } else if let Some(gap) = gap_us.filter(|_| t < 2 * keep) {
            chunks.push(Chunk {
                time_us: c.time_us + gap,
                ..c.clone()
            });
        }
    }
    write_recording(path, &rec.header, &chunks).expect("write");
    chunks
        .iter()
        .filter(|c| c.kind == ChunkKind::DeviceToHost)
        .count()
}

fn realtime_replay(input: &Path, csv: &Path) -> Child {
    gazecast()
        .args(["replay", "--realtime", "--raw", "--input"])
        .arg(input)
        .arg("--csv")
        .arg(csv)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs")
}

#[test]
fn realtime_replay_skips_a_huge_gap_with_a_warning() {
    let dir = tempfile::tempdir().expect("tempdir");
    let input = dir.path().join("gap.gzrec");
    cut_recording(&input, 0.4, Some(1_000_000_000_000));
    let csv = dir.path().join("o.csv");
    let out = wait_for(
        realtime_replay(&input, &csv),
        Duration::from_secs(30),
        "replay --realtime over a 10^12 µs gap",
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("gap of 1000000 s skipped"), "{err}");
    let records: usize = err
        .split("records=")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .expect("summary");
    assert!(records > 50, "{err}");
    let text = std::fs::read_to_string(&csv).expect("csv");
    assert_eq!(text.lines().count(), records + 1);
}

#[test]
fn a_killed_realtime_replay_keeps_the_rows_it_played() {
    let dir = tempfile::tempdir().expect("tempdir");
    let input = dir.path().join("short.gzrec");
    cut_recording(&input, 5.0, None);
    let csv = dir.path().join("o.csv");
    let mut child = realtime_replay(&input, &csv);
    std::thread::sleep(Duration::from_millis(1500));
    child.kill().expect("kill"); // SIGKILL: nothing can be caught
    let _ = child.wait();
    let text = std::fs::read_to_string(&csv).expect("the CSV is there");
    let rows = text.lines().count() - 1;
    // 120 Hz for about 1.5 s (the process needs a moment to start).
    assert!(rows >= 30, "{rows} rows");
    assert!(text.ends_with('\n'), "a row written whole");
}

#[test]
fn ctrl_c_stops_record_cleanly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut master, tracker, device) = iscan_on_pty(dir.path());
    let out_path = dir.path().join("session.gzrec");
    let mut child = gazecast()
        .args(["record", "--tracker"])
        .arg(&tracker)
        .arg("--out")
        .arg(&out_path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("record starts");
    let mut byte = [0u8; 1];
    wait_for_start(&mut master);
    let mut sent = 0;
    for c in device.device_chunks().take(30) {
        master.write_all(&c.payload).expect("write to the pty");
        sent += c.payload.len();
    }
    std::thread::sleep(Duration::from_millis(500));
    let ok = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(ok.success());
    // The stop command (0x88) reaches the device.
    let mut stop_seen = false;
    let deadline = Instant::now() + Duration::from_secs(10);
    while !stop_seen && Instant::now() < deadline {
        if let Ok(1) = master.read(&mut byte) {
            stop_seen = byte[0] == 0x88;
        }
        if child.try_wait().expect("wait").is_some() {
            // Whatever it wrote before exiting is still buffered in the pty.
            while let Ok(1) = master.read(&mut byte) {
                stop_seen |= byte[0] == 0x88;
            }
            break;
        }
    }
    let out = wait_for(child, Duration::from_secs(20), "record after Ctrl-C");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}\n{}", stderr(&out));
    assert!(stdout.contains("records="), "{stdout}");
    assert!(stdout.contains("interrupted"), "{stdout}");
    assert!(stop_seen, "no stop command reached the device");
    let rec = tracker_hal::Recording::read(&out_path).expect("the recording reads");
    assert!(rec.summary().closed, "no end chunk");
    assert!(rec.warnings().is_empty(), "{:?}", rec.warnings());
    let got: usize = rec.device_chunks().map(|c| c.payload.len()).sum();
    assert_eq!(got, sent);
    let host: Vec<u8> = rec
        .chunks
        .iter()
        .filter(|c| c.kind == ChunkKind::HostToDevice)
        .flat_map(|c| c.payload.iter().copied())
        .collect();
    assert_eq!(host, [0x84, 0x88], "start and stop commands recorded");
}

/// A full disk during `record` is reported at once, not when the
/// recording would have ended: `record` stops by itself within seconds
/// of the error (sending the device its stop command), exits 1 naming it, and the file
/// keeps every chunk written before it. Before, the recording silently
/// stopped and the error came only at Ctrl-C or the end of --seconds.
#[test]
fn a_write_error_stops_record_at_once_and_keeps_what_was_written() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut master, tracker, device) = iscan_on_pty(dir.path());
    let out_path = dir.path().join("session.gzrec");
    let mut record = gazecast();
    // --seconds 600: only the write error can end it within the test.
    record
        .args(["record", "--seconds", "600", "--tracker"])
        .arg(&tracker)
        .arg("--out")
        .arg(&out_path);
    let mut child = common::with_file_limit(&record, 4)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("record starts");
    let mut byte = [0u8; 1];
    wait_for_start(&mut master);
    // Far more than 4 KiB of device data, paced so the writer sees it.
    master
        .set_timeout(Duration::from_millis(5))
        .expect("timeout");
    let mut full_at = None;
    let chunks: Vec<_> = device.device_chunks().collect();
    for c in chunks.iter().cycle().take(5000) {
        let _ = master.write_all(&c.payload);
        while let Ok(1) = master.read(&mut byte) {}
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        if full_at.is_none() && std::fs::metadata(&out_path).is_ok_and(|m| m.len() >= 4096) {
            full_at = Some(Instant::now());
        }
    }
    let out = wait_for(child, Duration::from_secs(20), "record after a write error");
    let full_at = full_at.expect("the recording reached the file size limit");
    assert!(
        full_at.elapsed() < Duration::from_secs(5),
        "record went on for {:?} after the write error",
        full_at.elapsed()
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("RECORDING STOPPED") && err.contains("File too large"),
        "{err}"
    );
    // (The stop command is sent as after Ctrl-C; it is not asserted here:
    // written just before the slave closes, a pty may drop it.)
    let rec = tracker_hal::Recording::read(&out_path).expect("what was written reads");
    assert!(rec.device_chunks().count() > 5, "{:?}", rec.summary());
    assert!(std::fs::metadata(&out_path).expect("meta").len() <= 4096);
}

/// An ISCAN tracker file in `dir` on a fresh pseudo-terminal (the master
/// end, 100 ms timeouts, is the device) and the stream a device sends.
fn iscan_on_pty(dir: &Path) -> (serialport::TTYPort, PathBuf, tracker_hal::Recording) {
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let slave_name = slave.name().expect("pty name");
    drop(slave); // ports are locked exclusively: `record` opens it by path
    master
        .set_timeout(Duration::from_millis(100))
        .expect("timeout");
    let tracker = dir.join("iscan.ron");
    std::fs::write(
        &tracker,
        std::fs::read_to_string(repo("config/trackers/iscan-binary.ron"))
            .expect("tracker")
            .replace("Some(\"/dev/ttyUSB0\")", &format!("Some({slave_name:?})")),
    )
    .expect("write tracker");
    let device = tracker_hal::Recording::read(&repo("tests/data/iscan-binary-60hz.gzrec"))
        .expect("device stream");
    (master, tracker, device)
}

/// Waits up to 30 s for the start command (0x84): `record` has the port
/// open.
fn wait_for_start(master: &mut serialport::TTYPort) {
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut byte = [0u8; 1];
    loop {
        assert!(Instant::now() < deadline, "no start command from record");
        if let Ok(1) = master.read(&mut byte) {
            if byte[0] == 0x84 {
                return;
            }
        }
    }
}
