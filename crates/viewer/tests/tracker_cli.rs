//! The tracker command-line contract (issue 3) on the real binary.

mod common;

use common::{gazecast, Run};

use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

const HEADER: &str =
    "seq,device_time_us,host_time_us,mapped_time_us,time_order,left_x,left_y,left_valid,right_x,right_y,right_valid,gaze_x,gaze_y,gaze_valid";

#[test]
fn replay_writes_the_contract_csv_and_a_summary_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("out.csv");
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/iscan-binary.ron",
            "--input",
            "tests/data/iscan-binary-60hz.gzrec",
            "--csv",
        ])
        .arg(&csv)
        .succeed();
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "records=600 dropped_bytes=0 resyncs=0"
    );
    let text = std::fs::read_to_string(&csv).expect("csv");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 600);
    // Screen pixels (1280×1024 mapping): x within the screen; a missing eye has empty coordinates.
    for r in &rows {
        assert_eq!(r.len(), 14);
        for (x, y, v) in [(5, 6, 7), (8, 9, 10), (11, 12, 13)] {
            match r[v] {
                "1" => {
                    let (x, y): (f64, f64) = (r[x].parse().expect("x"), r[y].parse().expect("y"));
                    assert!((0.0..1280.0).contains(&x) && (0.0..1024.0).contains(&y));
                }
                "0" => assert!(r[x].is_empty() && r[y].is_empty()),
                other => panic!("valid column {other}"),
            }
        }
    }
    // --raw gives tracker units: exactly the simulator's expected CSV.
    gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/iscan-binary.ron",
            "--input",
            "tests/data/iscan-binary-60hz.gzrec",
            "--raw",
            "--csv",
        ])
        .arg(&csv)
        .succeed();
    assert_eq!(
        std::fs::read_to_string(&csv).expect("csv"),
        std::fs::read_to_string(repo().join("tests/data/iscan-binary-60hz.csv")).expect("expected")
    );
}

#[test]
fn replay_of_raw_bytes_with_garbage_exits_zero_and_counts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let raw = dir.path().join("dump.bin");
    let mut bytes = b"\x01\x02garbage".to_vec();
    for k in 0..50u16 {
        bytes.extend([0x44, 0x44]);
        for v in [100 + k, 200, 300, 400] {
            bytes.extend((v * 10).to_le_bytes());
        }
        if k == 20 {
            bytes.extend([0xAA, 0x44, 0x01]);
        }
    }
    std::fs::write(&raw, &bytes).expect("write");
    let csv = dir.path().join("out.csv");
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/iscan-binary.ron",
            "--format",
            "raw-bytes",
            "--input",
        ])
        .arg(&raw)
        .arg("--csv")
        .arg(&csv)
        .succeed();
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "records=50 dropped_bytes=12 resyncs=2"
    );
}

#[test]
fn replay_fails_clearly_on_bad_files_and_configs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad_tracker = dir.path().join("bad.ron");
    std::fs::write(
        &bad_tracker,
        "Tracker(\n  driver: Mouse((\n    rate_hz: -5.0,\n  )),\n)\n",
    )
    .expect("write");
    let not_rec = dir.path().join("not.gzrec");
    std::fs::write(&not_rec, b"hello").expect("write");
    let csv = dir.path().join("o.csv");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "--tracker".into(),
                bad_tracker.display().to_string(),
                "--input".into(),
                "tests/data/mouse-120hz.gzrec".into(),
            ],
            "bad.ron:3:",
        ),
        (
            vec![
                "--tracker".into(),
                "config/trackers/mouse.ron".into(),
                "--input".into(),
                "/nonexistent.gzrec".into(),
            ],
            "/nonexistent.gzrec",
        ),
        (
            vec![
                "--tracker".into(),
                "config/trackers/mouse.ron".into(),
                "--input".into(),
                not_rec.display().to_string(),
            ],
            "not a gazecast recording",
        ),
    ];
    for (args, needle) in cases {
        let out = gazecast()
            .arg("replay")
            .args(&args)
            .arg("--csv")
            .arg(&csv)
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(
            err.contains(needle),
            "{args:?}: expected `{needle}` in {err}"
        );
        assert!(!err.contains("panicked"));
    }
    let err = String::from_utf8_lossy(
        &gazecast()
            .args(["replay", "--tracker"])
            .arg(&bad_tracker)
            .args(["--input", "x", "--csv", "y"])
            .output()
            .expect("runs")
            .stderr,
    )
    .into_owned();
    assert!(err.contains("rate_hz"), "{err}");
}

#[test]
fn a_torn_recording_still_replays_with_a_warning() {
    let dir = tempfile::tempdir().expect("tempdir");
    let torn = dir.path().join("torn.gzrec");
    let bytes = std::fs::read(repo().join("tests/data/mouse-120hz.gzrec")).expect("data");
    std::fs::write(&torn, &bytes[..bytes.len() / 2]).expect("write");
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/mouse.ron",
            "--input",
        ])
        .arg(&torn)
        .arg("--csv")
        .arg(dir.path().join("o.csv"))
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("ends early"), "{err}");
}

#[test]
fn devices_never_fails_without_hardware() {
    let out = gazecast().arg("devices").succeed();
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("serial ports:"));
}

#[test]
fn record_refuses_the_mouse_and_a_missing_port_clearly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = gazecast()
        .args(["record", "--tracker", "config/trackers/mouse.ron", "--out"])
        .arg(dir.path().join("r.gzrec"))
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("serial tracker"));
    let out = gazecast()
        .args([
            "record",
            "--tracker",
            "config/trackers/iscan-binary.ron",
            "--seconds",
            "1",
            "--out",
        ])
        .arg(dir.path().join("r.gzrec"))
        .output()
        .expect("runs");
    // No /dev/ttyUSB0 here: a clear error naming the port.
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/dev/ttyUSB0"));
}

#[test]
fn replay_of_a_hid_log_follows_the_raw_contract_and_maps_to_pixels() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("raw.csv");
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/tobii-hid.ron",
            "--format",
            "hid-log",
            "--input",
            "tests/data/tobii-hid-50hz.hidlog",
            "--raw",
            "--csv",
        ])
        .arg(&csv)
        .succeed();
    let summary = String::from_utf8_lossy(&out.stderr);
    assert!(summary.contains("dropped_bytes=0 resyncs=0"), "{summary}");
    // --raw: µm, the sensor timestamp, per-eye columns empty with valid 0 —
    // exactly the simulator's expected CSV (the .gzrec carries the same text).
    assert_eq!(
        std::fs::read_to_string(&csv).expect("csv"),
        std::fs::read_to_string(repo().join("tests/data/tobii-hid-50hz.csv")).expect("expected")
    );
    // Without --raw: pixels through the device's calibrated screen size.
    let px = dir.path().join("px.csv");
    gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/tobii-hid.ron",
            "--input",
            "tests/data/tobii-hid-50hz.gzrec",
            "--csv",
        ])
        .arg(&px)
        .succeed();
    let text = std::fs::read_to_string(&px).expect("csv");
    for r in text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
    {
        assert_eq!((r[7], r[10], r[13]), ("0", "0", "1"), "{r:?}");
        let (x, y): (f64, f64) = (r[11].parse().expect("x"), r[12].parse().expect("y"));
        assert!((0.0..=1280.0).contains(&x) && (0.0..=1024.0).contains(&y));
    }
    // A calibration file replaces the mapping: this one doubles x. (Its
    // normalisers span ±512 units, 2/scale: a calibration must spread its
    // targets over at least 16 px.)
    let cal = dir.path().join("cal.ron");
    std::fs::write(
        &cal,
        "Calibration(model: Affine, params: [2.0, 0.0, 0.0, 0.0, 1.0, 0.0], \
         raw: (centre: (0.0, 0.0), scale: 0.00390625), \
         screen: (centre: (0.0, 0.0), scale: 0.00390625), rms_residual_px: 0.0, points: [])",
    )
    .expect("write");
    let calibrated = dir.path().join("cal.csv");
    replay_hid_log(&cal, &calibrated).succeed();
    let raw = std::fs::read_to_string(&csv).expect("csv");
    let cal_text = std::fs::read_to_string(&calibrated).expect("csv");
    let (a, b) = (
        raw.lines()
            .nth(1)
            .expect("row")
            .split(',')
            .collect::<Vec<_>>(),
        cal_text
            .lines()
            .nth(1)
            .expect("row")
            .split(',')
            .collect::<Vec<_>>(),
    );
    let ax: f64 = a[11].parse().expect("x");
    let bx: f64 = b[11].parse().expect("x");
    assert_eq!(bx, 2.0 * ax);
    // A calibration with the wrong parameter count names the field.
    std::fs::write(
        &cal,
        "Calibration(model: Homography, params: [1.0], raw: (centre: (0.0, 0.0), scale: 1.0), \
         screen: (centre: (0.0, 0.0), scale: 1.0), rms_residual_px: 0.0, points: [])",
    )
    .expect("write");
    let out = replay_hid_log(&cal, &calibrated).output().expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cal.ron:1") && err.contains("params"), "{err}");
    // hid-log with a serial tracker file is refused clearly.
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/iscan-binary.ron",
            "--format",
            "hid-log",
            "--input",
            "tests/data/tobii-hid-50hz.hidlog",
            "--csv",
        ])
        .arg(&calibrated)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("TobiiHid"));
}

/// `gazecast replay` of the synthesised HID log with a calibration file.
fn replay_hid_log(calibration: &std::path::Path, csv: &std::path::Path) -> std::process::Command {
    let mut c = gazecast();
    c.args([
        "replay",
        "--tracker",
        "config/trackers/tobii-hid.ron",
        "--format",
        "hid-log",
        "--input",
        "tests/data/tobii-hid-50hz.hidlog",
        "--calibration",
    ])
    .arg(calibration)
    .arg("--csv")
    .arg(csv);
    c
}

/// Every HID descriptor shape the simulator emits — the reference and
/// compact layouts, Microsoft's virtual eye-gaze device with named
/// collections and units, its earlier descriptor with unnamed collections
/// and no units (eight one-byte timestamp fields, positions from
/// 0x80000000), and 32-bit positions from 0x80000000 before a 64-bit
/// timestamp — is written as a hid-log by `simulate` and decoded by
/// `replay --format hid-log`: raw samples exactly the simulator's, and
/// without `--raw` on the screen through the device's own screen size
/// (before, the unnamed shape lost its screen size and gaze landed at
/// 2265 px on a 1280-px display).
#[test]
fn replay_decodes_every_hid_descriptor_shape() {
    let dir = tempfile::tempdir().expect("tempdir");
    for layout in ["reference", "compact", "named", "unnamed", "wide"] {
        let log = dir.path().join(format!("{layout}.hidlog"));
        let expected = dir.path().join(format!("{layout}-expected.csv"));
        gazecast()
            .args(["simulate", "--tracker", "config/trackers/tobii-hid.ron"])
            .args(["--seconds", "2", "--hid-layout", layout, "--out"])
            .arg(dir.path().join(format!("{layout}.gzrec")))
            .arg("--hid-log")
            .arg(&log)
            .arg("--csv")
            .arg(&expected)
            .succeed();
        let raw = dir.path().join(format!("{layout}-raw.csv"));
        let replay = |csv: &std::path::Path, raw: bool| {
            let mut c = gazecast();
            c.args(["replay", "--tracker", "config/trackers/tobii-hid.ron"])
                .args(["--format", "hid-log", "--input"])
                .arg(&log)
                .arg("--csv")
                .arg(csv);
            if raw {
                c.arg("--raw");
            }
            c.succeed()
        };
        let out = replay(&raw, true);
        let summary = String::from_utf8_lossy(&out.stderr);
        assert!(
            summary.contains("dropped_bytes=0 resyncs=0"),
            "{layout}: {summary}"
        );
        assert_eq!(
            std::fs::read_to_string(&raw).expect("raw"),
            std::fs::read_to_string(&expected).expect("expected"),
            "{layout}"
        );
        let px = dir.path().join(format!("{layout}-px.csv"));
        replay(&px, false);
        let text = std::fs::read_to_string(&px).expect("csv");
        let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
        let (xc, yc, vc) = (col("gaze_x"), col("gaze_y"), col("gaze_valid"));
        let mut valid = 0;
        for r in text
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
        {
            if r[vc] != "1" {
                continue;
            }
            valid += 1;
            let (x, y): (f64, f64) = (r[xc].parse().expect("x"), r[yc].parse().expect("y"));
            assert!(
                (0.0..=1280.0).contains(&x) && (0.0..=1024.0).contains(&y),
                "{layout}: gaze ({x}, {y}) off the 1280x1024 screen"
            );
        }
        assert!(valid > 50, "{layout}: {valid} valid samples");
    }
}
