//! The `gazecast mask` command-line contract (issue 2), checked on the real binary.

mod common;

use common::{gazecast, Run};

fn json(args: &[&str]) -> serde_json::Value {
    let out = gazecast().args(["mask", "--json"]).args(args).succeed();
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn json_has_the_contract_fields() {
    let v = json(&["--display", "config/displays/desktop-24in-1080p.ron"]);
    for key in [
        "width_px",
        "height_px",
        "ppd",
        "fovea_radius_px",
        "rays",
        "nyquist_bound_rays",
        "layout",
        "mask_build_ms",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert_eq!(v["width_px"], 1920);
    assert_eq!(v["height_px"], 1080);
    assert_eq!(v["layout"], "nyquist");
    // Default gaze is the screen centre.
    assert_eq!(v["gaze_px"][0], 960.0);
    assert_eq!(v["gaze_px"][1], 540.0);
}

#[test]
fn default_display_is_the_dissertation_set_up() {
    let v = json(&[]);
    assert_eq!(v["width_px"], 1280);
    assert_eq!(v["height_px"], 1024);
}

#[test]
fn seed_layout_costs_more_rays_and_lower_contrast_fewer() {
    let base = json(&["--gaze", "100,900"]);
    let seed = json(&["--gaze", "100,900", "--layout", "seed"]);
    let low_c = json(&["--gaze", "100,900", "--contrast", "0.25"]);
    let rays = |v: &serde_json::Value| v["rays"].as_u64().expect("rays");
    assert_eq!(seed["layout"], "seed");
    assert!(rays(&seed) > rays(&base));
    assert!(rays(&low_c) < rays(&base));
    // A closer eye means fewer pixels per degree, so more rays are needed.
    let near = json(&["--gaze", "100,900", "--eye-distance-mm", "300"]);
    assert!(rays(&near) > rays(&base));
}

#[test]
fn points_csv_lists_exactly_the_rays_inside_the_screen() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("rays.csv");
    let csv_arg = csv.to_str().expect("utf-8 path");
    let v = json(&[
        "--display",
        "config/displays/v8-hmd.ron",
        "--gaze",
        "0,0",
        "--points",
        csv_arg,
    ]);
    let text = std::fs::read_to_string(&csv).expect("csv written");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("x_px,y_px"));
    let mut n = 0u64;
    for line in lines {
        let (x, y) = line.split_once(',').expect("two columns");
        let (x, y): (f64, f64) = (x.parse().expect("x"), y.parse().expect("y"));
        assert!(
            (0.0..640.0).contains(&x) && (0.0..480.0).contains(&y),
            "{line}"
        );
        n += 1;
    }
    assert_eq!(Some(n), v["rays"].as_u64());
}

#[test]
fn png_writes_the_mask_and_the_csf_plot() {
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("m.png");
    gazecast()
        .args(["mask", "--display", "config/displays/v8-hmd.ron", "--png"])
        .arg(&png)
        .succeed();
    for f in [png.clone(), dir.path().join("m-csf.png")] {
        let bytes = std::fs::read(&f).expect("png written");
        assert!(
            bytes.starts_with(b"\x89PNG"),
            "{} is not a PNG",
            f.display()
        );
        assert!(
            bytes.len() > 10_000,
            "{} is suspiciously small",
            f.display()
        );
    }
}

#[test]
fn bad_input_is_a_clear_error_not_a_panic() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, "Display(\n name: \"x\",\n resolution_px: (10, 10),\n size_mm: (1.0, 1.0),\n eye_distance_mm: -5.0,\n)")
        .expect("write");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["--display".into(), bad.display().to_string()],
            "bad.ron:5:",
        ),
        (
            vec!["--display".into(), "/nonexistent.ron".into()],
            "/nonexistent.ron: cannot read",
        ),
        (vec!["--contrast".into(), "0.01".into()], "contrast"),
        (vec!["--gaze".into(), "1,nan".into()], "not a finite number"),
        (
            vec!["--eye-distance-mm".into(), "0".into()],
            "eye_distance_mm",
        ),
        (vec!["--layout".into(), "spiral".into()], "unknown layout"),
    ];
    for (args, needle) in cases {
        let out = gazecast().arg("mask").args(&args).output().expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(
            err.contains(needle),
            "{args:?}: expected `{needle}` in: {err}"
        );
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
}

/// Negative numbers are values, not flags: a gaze left of and above the
/// screen is a point, and a negative distance gets the range error.
#[test]
fn negative_values_reach_their_checks() {
    let out = gazecast()
        .args(["mask", "--json", "--gaze", "-5,-5"])
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = gazecast()
        .args(["mask", "--eye-distance-mm", "-5"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("must be a finite number greater than zero"),
        "{err}"
    );
}
