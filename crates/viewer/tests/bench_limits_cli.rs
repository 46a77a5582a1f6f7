//! `gazecast bench` refuses sizes it cannot hold before allocating
//! anything: `--gazes 4294967295` used to abort on allocation.

mod common;

use std::process::Output;

use common::gazecast;

fn accuracy(extra: &[&str]) -> Output {
    let dir = tempfile::tempdir().expect("tempdir");
    gazecast()
        .args([
            "bench",
            "accuracy",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--out",
        ])
        .arg(dir.path().join("out"))
        .args(extra)
        .output()
        .expect("runs")
}

fn refused(out: &Output, code: i32, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{stderr} lacks {n}");
    }
}

#[test]
fn out_of_range_gazes_and_repeats_are_refused() {
    let out = accuracy(&["--gazes", "4294967295"]);
    refused(&out, 2, &["--gazes", "4294967295", "1..=10000"]);
    let out = accuracy(&["--gazes", "18446744073709551615"]);
    refused(&out, 2, &["--gazes"]);
    let out = accuracy(&["--repeats", "4294967295"]);
    refused(&out, 2, &["--repeats", "1..=1000"]);
    let out = accuracy(&["--repeats", "0"]);
    refused(&out, 2, &["--repeats"]);
    let dir = tempfile::tempdir().expect("tempdir");
    let out = gazecast()
        .args(["bench", "scaling", "--repeats", "1001", "--out"])
        .arg(dir.path().join("out"))
        .output()
        .expect("runs");
    refused(&out, 2, &["--repeats", "1..=1000"]);
}

/// Within the range but beyond memory at the display's resolution: every
/// gaze keeps a 1280×1024 reference (about 43 MB).
#[test]
fn gazes_beyond_memory_are_refused_with_the_estimate() {
    let out = accuracy(&["--gazes", "10000"]);
    refused(
        &out,
        1,
        &[
            "--gazes 10000",
            "1280x1024",
            "432.5 GB",
            "at most 184 gazes",
        ],
    );
}
