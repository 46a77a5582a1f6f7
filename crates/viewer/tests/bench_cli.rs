//! `gazecast bench` (issue 8) on the real binary: a quick sweep on a tiny
//! scene writes well-formed results, plot and report.

mod common;

use common::{gazecast, Run};

#[test]
fn a_quick_accuracy_sweep_writes_csv_plot_and_report() {
    let dir = tempfile::tempdir().expect("tempdir");
    let display = dir.path().join("tiny.ron");
    std::fs::write(
        &display,
        "Display(name: \"tiny\", resolution_px: (96, 72), size_mm: (337.9, 253.4), eye_distance_mm: 540.0)",
    )
    .expect("write");
    let out = dir.path().join("sweep");
    let run = gazecast()
        .args([
            "bench",
            "accuracy",
            "--scene",
            "config/scenes/search-task.ron",
            "--quick",
            "--display",
        ])
        .arg(&display)
        .arg("--out")
        .arg(&out)
        .succeed();
    let stdout = String::from_utf8_lossy(&run.stdout);
    // 13 built in, plus every registered method module.
    let n = gazecast_viewer::bench::configs::configurations(true).len();
    assert_eq!(n, 13 + pipeline::registry::METHODS.len());
    assert!(
        stdout.contains(&format!("{n} configurations x 2 gazes")),
        "{stdout}"
    );

    let csv = std::fs::read_to_string(out.join("results.csv")).expect("results.csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(
        header.join(","),
        gazecast_viewer::bench::report::RESULTS_HEADER
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), n * 2, "one row per configuration and gaze");
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    for r in &rows {
        assert_eq!(r.len(), header.len(), "{r:?}");
        let time: f64 = r[col("time_ms")].parse().expect("time");
        assert!(time > 0.0);
        let psnr = r[col("psnr_db")];
        if r[col("layout")] == "full" {
            assert_eq!(psnr, "inf", "the reference against itself");
            assert_eq!(r[col("silhouette_error")], "0.000000");
        } else {
            let p: f64 = psnr.parse().expect("psnr");
            assert!(p > 10.0, "{r:?}");
            if r[col("layout")] == "image" {
                // Only colour is blurred: the geometry is the full frame's.
                assert_eq!(r[col("silhouette_error")], "0.000000", "{r:?}");
            }
            let e: f64 = r[col("silhouette_error")].parse().expect("error");
            assert!((0.0..=1.0).contains(&e));
        }
        let f: f64 = r[col("foveated_psnr_db")].parse().expect("foveated psnr");
        assert!(f >= 0.0);
    }
    let image_rows = rows.iter().filter(|r| r[col("layout")] == "image").count();
    assert_eq!(
        image_rows,
        2 * 2,
        "two image-based configurations at two gazes"
    );
    let png = std::fs::read(out.join("pareto.png")).expect("pareto.png");
    assert!(png.starts_with(b"\x89PNG"));
    let report = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    for needle in [
        "| configuration |",
        "(default)",
        "foveated PSNR",
        "Machine:",
        "pareto.png",
    ] {
        assert!(report.contains(needle), "report lacks {needle}");
    }
}

#[test]
fn bench_errors_are_clear() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = gazecast()
        .args([
            "bench",
            "accuracy",
            "--scene",
            "config/scenes/nope.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.ron"));
    let out = gazecast()
        .args([
            "bench",
            "accuracy",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--gazes",
            "0",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--gazes"));
}

/// The cells of the row of `scene` in a `bench stages` table, after the
/// header named `columns`.
fn stage_row(stdout: &str, scene: &str) -> (Vec<String>, Vec<String>) {
    let mut lines = stdout.lines().filter(|l| l.starts_with('|'));
    let cells = |l: &str| -> Vec<String> {
        l.trim_matches('|')
            .split('|')
            .map(|c| c.trim().to_string())
            .collect()
    };
    let header = cells(lines.next().expect("header"));
    let row = lines
        .find(|l| l.contains(scene))
        .map(cells)
        .unwrap_or_default();
    (header, row)
}

#[test]
fn bench_stages_breaks_a_frame_down_on_the_cpu_and_the_gpu() {
    let dir = tempfile::tempdir().expect("tempdir");
    let display = dir.path().join("small.ron");
    std::fs::write(
        &display,
        "Display(name: \"small\", resolution_px: (160, 128), size_mm: (337.9, 270.3), eye_distance_mm: 540.0)",
    )
    .expect("write");
    let run = |backend: &str| {
        let out = gazecast()
            .args([
                "bench",
                "stages",
                "--scene",
                "config/scenes/bunny.ron",
                "--repeats",
                "1",
                "--backend",
                backend,
                "--display",
            ])
            .arg(&display)
            .succeed();
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    let cpu = run("cpu");
    let (header, row) = stage_row(&cpu, "bunny");
    for column in [
        "full ms",
        "foveated ms",
        "mask",
        "vertex rays",
        "classify",
        "margin",
        "ownership",
        "pixels",
        "effects",
    ] {
        assert!(header.iter().any(|h| h == column), "{column}: {cpu}");
    }
    assert_eq!(header.len(), row.len(), "{cpu}");
    for (h, v) in header.iter().zip(&row).skip(2) {
        let x: f64 = v.parse().unwrap_or_else(|_| panic!("{h} = {v}: {cpu}"));
        assert!(x.is_finite() && x >= 0.0, "{h} = {v}");
    }
    assert!(cpu.contains("cpu, threads:"), "{cpu}");
    // The GPU core's passes by name (lavapipe here: a software adapter).
    let gpu = run("gpu");
    let (header, row) = stage_row(&gpu, "bunny");
    assert_eq!(header.len(), row.len(), "{gpu}");
    assert!(gpu.contains("\ngpu: "), "{gpu}");
    let has = |name: &str| header.iter().any(|h| h == name);
    if gpu.contains("stage times from the adapter's timestamp queries") {
        // lavapipe has them: every pass of the foveated frame by name.
        for pass in [
            "cast vertices",
            "classify cells",
            "interpolate or list pixels",
            "cast listed pixels",
        ] {
            assert!(has(pass), "{pass}: {gpu}");
        }
    } else {
        assert!(gpu.contains("no timestamp queries"), "{gpu}");
        assert!(!has("cast vertices"), "{gpu}");
    }
    assert!(!has("vertex rays"), "CPU stage names on the GPU: {gpu}");
}

/// `bench/gpu.sh --quick` (issue 35's prepared script) on this binary:
/// it names the adapter, says when it is a CPU one, and writes the table
/// and the JSON with every figure; the traffic it reports is the GPU
/// core's: a kept mask uploads the 128 B of uniforms only, a new mask its
/// pixel owners (4 B a pixel) besides; every frame reads its colour back.
/// Without an adapter it fails with a clear message.
#[test]
#[ignore = "slow tier: runs bench/gpu.sh --quick end to end"]
fn the_gpu_script_runs_its_quick_mode_and_fails_clearly_without_an_adapter() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().expect("tempdir");
    let script = |out: &std::path::Path| {
        let mut c = std::process::Command::new("bash");
        c.current_dir(&root)
            .arg("bench/gpu.sh")
            .arg(out)
            .arg("--quick")
            .env("GAZECAST_BIN", env!("CARGO_BIN_EXE_gazecast"));
        c
    };
    let out = dir.path().join("gpu");
    let run = script(&out).output().expect("bash runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let md = std::fs::read_to_string(out.join("gpu.md")).expect("gpu.md");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("gpu.json")).expect("gpu.json"))
            .expect("gpu.json parses");
    let adapter = json["adapter"].as_str().expect("an adapter");
    assert!(md.contains(&format!("Adapter: **{adapter}**")), "{md}");
    if adapter.contains(", Cpu,") {
        assert!(json["software_adapter"].as_bool().expect("a flag"));
        assert!(md.contains("say nothing about a GPU's speed"), "{md}");
    }
    let rows = json["stages"]["rows"].as_array().expect("rows");
    assert_eq!(
        rows.len(),
        3,
        "the search task on two displays, stress-dof on one: {json}"
    );
    for r in rows {
        let pixels = r["width_px"].as_u64().expect("width") * r["height_px"].as_u64().expect("h");
        let traffic = r["traffic"].as_array().expect("traffic");
        let of = |frame: &str, field: &str| {
            traffic
                .iter()
                .find(|t| t["frame"] == frame)
                .map(|t| t[field]["p50"].as_u64().expect("a count"))
                .unwrap_or_else(|| panic!("no {frame} frame: {r}"))
        };
        // A new mask uploads itself (the GPU builds its pixel owners; the
        // exact bytes are checked in crates/raycast/tests/gpu.rs): more
        // than the kept mask's uniforms.
        assert!(of("foveated, new mask", "uploaded_bytes") > 128, "{r}");
        assert!(of("full", "read_back_bytes") >= 4 * pixels, "{r}");
        if r["scene"] == "search-task" {
            // No GPU pass: the kept mask's frame uploads its uniforms only.
            assert_eq!(of("foveated, kept mask", "uploaded_bytes"), 128, "{r}");
            assert_eq!(of("full", "uploaded_bytes"), 80, "{r}");
        }
        assert!(r["loop_fps_new_mask"].as_f64().expect("a rate") > 0.0);
    }
    assert_eq!(json["methods"].as_array().expect("methods").len(), 3);
    assert!(md.contains("| hybrid | search-task | 128x72 |"), "{md}");

    // No adapter (wgpu asked for Metal on a machine without it): a clear
    // failure, nothing half written.
    let none = dir.path().join("none");
    let run = script(&none)
        .env("WGPU_BACKEND", "metal")
        .output()
        .expect("bash runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no GPU adapter could render"), "{stderr}");
    assert!(!none.join("gpu.md").exists());
}
