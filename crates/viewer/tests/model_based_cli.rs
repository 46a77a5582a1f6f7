//! The model-based methods' command lines (issue 16) on the real binary:
//! `render --method simplify --budget N` and `bench lod`.

mod common;

use common::{gazecast, Run};

/// A small display so the binary renders quickly in tests.
fn small_display(dir: &std::path::Path) -> std::path::PathBuf {
    let p = dir.join("small.ron");
    std::fs::write(&p, "Display(name: \"small\", resolution_px: (320, 256), size_mm: (337.9, 270.3), eye_distance_mm: 540.0)")
        .expect("write");
    p
}

/// `render` with a triangle budget prints and writes the budget outcome:
/// the triangles drawn (never above the budget, more for a larger one) and
/// the distance at which the folds left become imperceptible.
#[test]
fn render_reports_the_budget_outcome() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let mut last = 0;
    for (budget, no_gaze) in [("300", false), ("3000", false), ("3000", true)] {
        let stats = dir.path().join(format!("s-{budget}-{no_gaze}.json"));
        let mut cmd = gazecast();
        cmd.args([
            "render",
            "--scene",
            "config/scenes/bunny.ron",
            "--method",
            "simplify",
            "--budget",
            budget,
            "--gaze",
            "40,200",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(dir.path().join("f.png"))
        .arg("--stats")
        .arg(&stats);
        if no_gaze {
            cmd.arg("--no-gaze");
        }
        let out = cmd.succeed();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains(&format!("budget {budget}: stopped by")),
            "{text}"
        );
        assert!(text.contains("imperceptible from"), "{text}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).expect("json")).expect("json");
        let m = &v["model"];
        let drawn = m["triangles_drawn"].as_u64().expect("drawn");
        let b: u64 = budget.parse().expect("number");
        assert!(drawn <= b, "{drawn} > {b}");
        assert!(m["imperceptible_distance_mm"].as_f64().expect("distance") > 0.0);
        assert_eq!(m["no_gaze"].as_bool(), Some(no_gaze));
        if !no_gaze {
            assert!(drawn >= last);
            last = drawn;
        }
    }
}

#[test]
fn budget_errors_name_the_flag() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    for (method, budget, extra) in [
        ("simplify", "0", None),
        ("simplify", "12x", None),
        ("simplify", "2000000000", None),
        ("lod", "1000", None),
        ("hybrid", "1000", None),
        ("full", "", Some("--no-gaze")),
    ] {
        let mut cmd = gazecast();
        cmd.args([
            "render",
            "--scene",
            "config/scenes/bunny.ron",
            "--method",
            method,
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(dir.path().join("f.png"));
        if !budget.is_empty() {
            cmd.args(["--budget", budget]);
        }
        cmd.args(extra);
        let out = cmd.output().expect("runs");
        assert!(!out.status.success(), "{method} {budget} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        let flag = extra.unwrap_or("--budget");
        assert!(err.contains(flag), "{method} {budget}: {err}");
    }
}

/// `bench lod --quick` writes Table 2's shape: per mesh, the three methods
/// with faces min ≤ avg ≤ max ≤ the full count, and one Fig. 8 row each.
#[test]
fn bench_lod_writes_table_2_and_fig_8() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("lod");
    let run = gazecast()
        .args(["bench", "lod", "--quick", "--frames", "5", "--out"])
        .arg(&out)
        .succeed();
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(text.contains("Table 2"), "{text}");
    let md = std::fs::read_to_string(out.join("lod.md")).expect("lod.md");
    assert!(md.contains("| torus-256 | lod |"), "{md}");
    let csv = std::fs::read_to_string(out.join("lod.csv")).expect("lod.csv");
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some(gazecast_viewer::bench::lod::LOD_CSV_HEADER)
    );
    // 2 tori × 3 methods × 5 frames.
    assert_eq!(lines.count(), 30);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("lod.json")).expect("json"))
            .expect("json");
    let rows = v["summaries"].as_array().expect("summaries");
    assert_eq!(rows.len(), 6);
    for r in rows {
        let n = |k: &str| r[k].as_f64().expect(k);
        assert!(
            n("faces_min") <= n("faces_avg") && n("faces_avg") <= n("faces_max"),
            "{r}"
        );
        assert!(n("faces_max") <= n("faces_full"), "{r}");
        assert!(n("frame_ms_min") <= n("frame_ms_avg") && n("frame_ms_avg") <= n("frame_ms_max"));
        assert_eq!(n("frames"), 5.0);
    }
    let fig8 = v["fig8"].as_array().expect("fig8");
    assert_eq!(fig8.len(), 2);
    for f in fig8 {
        assert!(
            (f["eccentricity_deg"].as_f64().expect("deg") - 29.0).abs() < 0.05,
            "{f}"
        );
        assert!(f["faces"].as_u64().expect("faces") <= f["faces_full"].as_u64().expect("full"));
    }
    let e = gazecast()
        .args(["bench", "lod", "--frames", "0", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    assert!(!e.status.success());
    assert!(String::from_utf8_lossy(&e.stderr).contains("--frames"));
}

/// `demo --headless` and `view` take the same options: demo prints each
/// frame's budget outcome; view refuses a budget for another method.
#[test]
fn demo_and_view_take_the_budget() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = gazecast()
        .args([
            "demo",
            "--headless",
            "--fps",
            "2",
            "--method",
            "simplify",
            "--budget",
            "3000",
            "--out",
        ])
        .arg(dir.path())
        .succeed();
    let text = String::from_utf8_lossy(&run.stdout);
    let lines: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("model-based:"))
        .collect();
    assert!(!lines.is_empty(), "{text}");
    for l in lines {
        assert!(l.contains("budget 3000: stopped by"), "{l}");
        let drawn: usize = l
            .split("model-based: ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|n| n.parse().ok())
            .expect("a count");
        assert!(drawn <= 3000, "{l}");
    }
    let out = gazecast()
        .args([
            "view",
            "--explain",
            "--method",
            "hybrid",
            "--budget",
            "100",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--budget"));
}
