//! The synthesised streams in tests/data are exactly what the simulator
//! makes today (scripts/make-test-data.sh), and every tracker file loads.

use std::path::{Path, PathBuf};

use gazecast_viewer::args::PlanArgs;
use gazecast_viewer::config;
use gazecast_viewer::tracker_cmd::{simulated, HidLayoutArg, ScriptArg, SimulateArgs};
use tracker_hal::csv::{csv_row, CSV_HEADER};
use tracker_hal::Recording;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn test_data_matches_the_simulator() {
    let cases = [
        (
            "config/trackers/iscan-binary.ron",
            "iscan-binary-60hz",
            60.0,
            1,
            HidLayoutArg::Reference,
        ),
        (
            "config/trackers/iscan-ascii.ron",
            "iscan-ascii-60hz",
            60.0,
            2,
            HidLayoutArg::Reference,
        ),
        (
            "tests/data/iscan-binary-115200.ron",
            "iscan-binary-240hz",
            240.0,
            3,
            HidLayoutArg::Reference,
        ),
        (
            "tests/data/mouse-realistic.ron",
            "mouse-120hz",
            120.0,
            4,
            HidLayoutArg::Reference,
        ),
        (
            "config/trackers/tobii-hid.ron",
            "tobii-hid-50hz",
            50.0,
            7,
            HidLayoutArg::Reference,
        ),
        (
            "config/trackers/tobii-hid.ron",
            "tobii-hid-compact-120hz",
            120.0,
            9,
            HidLayoutArg::Compact,
        ),
    ];
    for (tracker, name, rate, seed, hid_layout) in cases {
        let cfg = config::load_tracker(&repo().join(tracker)).unwrap_or_else(|e| panic!("{e}"));
        let args = SimulateArgs {
            tracker: tracker.into(),
            out: PathBuf::new(),
            csv: None,
            seconds: 10.0,
            rate: Some(rate),
            seed,
            hid_layout,
            hid_log: None,
            script: ScriptArg::Search,
            display: None,
            plan: PlanArgs {
                points: 9,
                validation_points: 4,
                settle_ms: 400,
                collect_ms: 800,
                shuffle: None,
            },
            closed_target: None,
        };
        let (header, stream) = simulated(&cfg, &args).unwrap_or_else(|e| panic!("{e}"));
        let rec = Recording::read(&repo().join(format!("tests/data/{name}.gzrec")))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(rec.header, header, "{name}: header");
        assert_eq!(
            rec.chunks, stream.chunks,
            "{name}: chunks differ: run scripts/make-test-data.sh"
        );
        let csv: Vec<String> = std::iter::once(CSV_HEADER.to_string())
            .chain(stream.expected.iter().map(|s| csv_row(s, &|p| Some(p))))
            .collect();
        let on_disk =
            std::fs::read_to_string(repo().join(format!("tests/data/{name}.csv"))).expect("csv");
        assert_eq!(
            on_disk.lines().collect::<Vec<_>>(),
            csv,
            "{name}: expected CSV differs"
        );
    }
}

#[test]
fn every_tracker_file_loads_and_a_bad_one_names_line_and_field() {
    for dir in ["config/trackers", "tests/data"] {
        for entry in std::fs::read_dir(repo().join(dir)).expect("dir") {
            let p = entry.expect("entry").path();
            if p.extension().is_some_and(|e| e == "ron") {
                config::load_tracker(&p).unwrap_or_else(|e| panic!("{e}"));
            }
        }
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("t.ron");
    let text = std::fs::read_to_string(repo().join("config/trackers/iscan-binary.ron"))
        .expect("file")
        .replace("start_command: 0x84", "start_command: 0x04");
    std::fs::write(&bad, &text).expect("write");
    let err = config::load_tracker(&bad).expect_err("marker byte as a command");
    let line = text
        .lines()
        .position(|l| l.contains("start_command"))
        .expect("line")
        + 1;
    assert_eq!(err.field(), Some("driver.start_command"));
    assert_eq!(err.line(), line, "{err}");
}
