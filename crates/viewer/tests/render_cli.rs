//! The `gazecast render` contract (issue 5) on the real binary.

mod common;

use common::{gazecast, Run};

/// A small display so the binary renders quickly in tests.
fn small_display(dir: &std::path::Path) -> std::path::PathBuf {
    let p = dir.join("small.ron");
    std::fs::write(&p, "Display(name: \"small\", resolution_px: (320, 256), size_mm: (337.9, 270.3), eye_distance_mm: 540.0)")
        .expect("write");
    p
}

#[test]
fn render_writes_the_image_layers_and_the_stats_contract() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let (png, layers, stats) = (
        dir.path().join("f.png"),
        dir.path().join("l.png"),
        dir.path().join("s.json"),
    );
    gazecast()
        .args([
            "render",
            "--scene",
            "config/scenes/search-task.ron",
            "--gaze",
            "100,80",
            "--repeat",
            "3",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(&png)
        .arg("--layers")
        .arg(&layers)
        .arg("--stats")
        .arg(&stats)
        .succeed();
    for f in [&png, &layers] {
        assert!(std::fs::read(f).expect("png").starts_with(b"\x89PNG"));
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).expect("json")).expect("valid json");
    for key in [
        "rays_fovea",
        "rays_mask",
        "rays_refine",
        "rays_total",
        "cells_total",
        "cells_refined",
        "time_ms",
        "backend",
        "threads",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    assert_eq!(v["backend"], "cpu");
    assert_eq!(v["times_ms"].as_array().expect("times").len(), 3);
    let n = |k: &str| v[k].as_u64().expect("count");
    assert_eq!(
        n("rays_total"),
        n("rays_fovea") + n("rays_mask") + n("rays_refine")
    );
    assert!(n("rays_total") < 320 * 256);

    let full_stats = dir.path().join("full.json");
    gazecast()
        .args([
            "render",
            "--scene",
            "config/scenes/search-task.ron",
            "--mode",
            "full",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(&png)
        .arg("--stats")
        .arg(&full_stats)
        .succeed();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&full_stats).expect("json")).expect("json");
    assert_eq!(v["rays_total"], 320 * 256);
    // Full-resolution rays are counted as such, not as refinement.
    assert_eq!(v["rays_full"], 320 * 256);
    assert_eq!(v["rays_refine"], 0);
}

#[test]
fn bad_scenes_name_file_line_and_field() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let obj_nan = dir.path().join("nan.obj");
    std::fs::write(
        &obj_nan,
        "# a triangle\nv 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n",
    )
    .expect("write");
    let obj_index = dir.path().join("index.obj");
    std::fs::write(&obj_index, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").expect("write");
    let scene = |meshes: &str, objects: &str| {
        format!("Scene(\n  name: \"t\",\n  meshes: {{\n    {meshes}\n  }},\n  objects: [\n    {objects}\n  ],\n)\n")
    };
    let ok_obj = "(mesh: \"m\", translate_mm: (0.0, 0.0, -50.0), scale_mm: 10.0),";
    let cases: Vec<(String, String)> = vec![
        (
            scene(
                "\"m\": Icosphere(subdivisions: 2),",
                &format!(
                    "{ok_obj}\n    (mesh: \"nope\", translate_mm: (0.0, 0.0, 0.0), scale_mm: 1.0),"
                ),
            ),
            "s.ron:8:".into(),
        ),
        (
            scene(
                "\"m\": Icosphere(subdivisions: 2),",
                "(mesh: \"m\", translate_mm: (0.0, 0.0, 0.0), scale_mm: -1.0),",
            ),
            "objects[0].scale_mm".into(),
        ),
        (
            scene(
                &format!("\"m\": Obj(path: \"{}\"),", obj_nan.display()),
                ok_obj,
            ),
            "nan.obj:4:".into(),
        ),
        (
            scene(
                &format!("\"m\": Obj(path: \"{}\"),", obj_index.display()),
                ok_obj,
            ),
            "index.obj".into(),
        ),
        (
            scene("\"m\": Obj(path: \"missing.obj\"),", ok_obj),
            "missing.obj".into(),
        ),
        (
            scene("\"m\": Icosphere(subdivisions: \"two\"),", ok_obj),
            "s.ron:4:".into(),
        ),
    ];
    for (text, needle) in cases {
        let s = dir.path().join("s.ron");
        std::fs::write(&s, &text).expect("write");
        let out = gazecast()
            .arg("render")
            .arg("--scene")
            .arg(&s)
            .arg("--display")
            .arg(&d)
            .arg("--out")
            .arg(dir.path().join("o.png"))
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "should fail: {text}");
        assert!(err.contains(&needle), "expected `{needle}` in: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn the_gpu_backend_renders_foveated_frames_and_reports_its_adapter() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let (gpu_png, cpu_png, stats) = (
        dir.path().join("g.png"),
        dir.path().join("c.png"),
        dir.path().join("s.json"),
    );
    let render = |backend: &str, png: &std::path::Path| {
        let mut c = gazecast();
        c.args([
            "render",
            "--scene",
            "config/scenes/search-task.ron",
            "--gaze",
            "100,80",
            "--backend",
            backend,
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(png);
        c
    };
    render("gpu", &gpu_png).arg("--stats").arg(&stats).succeed();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).expect("json")).expect("valid json");
    assert_eq!(v["backend"], "gpu");
    assert_eq!(v["mode"], "hybrid");
    assert!(v["adapter"].as_str().is_some_and(|a| !a.is_empty()), "{v}");
    assert!(v["gpu_stages_ms"].is_array());
    // The CPU backend casts exactly as many rays.
    let cpu = render("cpu", &cpu_png).succeed();
    let line = String::from_utf8_lossy(&cpu.stdout);
    let rays = v["rays_total"].as_u64().expect("rays");
    assert!(line.contains(&format!(": {rays} rays")), "{line} vs {rays}");
    // auto names what it used and why.
    let auto = render("auto", &cpu_png).succeed();
    let text = String::from_utf8_lossy(&auto.stdout);
    assert!(
        text.contains(" on gpu (") || text.contains("auto: "),
        "{text}"
    );
    // The grid is CPU-only: --backend gpu refuses it clearly.
    let out = render("gpu", &cpu_png)
        .args(["--accel", "grid"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("choose the CPU backend"), "{err}");
}

/// Every command renders through the one frame entry, so a scene without
/// `FoveatedSampling` is full resolution on both backends — `view --backend
/// gpu` once rendered it foveated.
#[test]
fn every_command_honours_the_scene_effects_on_both_backends() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let plain = dir.path().join("plain.ron");
    let text = std::fs::read_to_string("../../config/scenes/bunny.ron").expect("bunny");
    let text = text.replace(
        "sampling: Foveated(refine: [Silhouette, Crease(angle_deg: 30.0), Depth(jump: 0.05)]),\n    passes: [],",
        "effects: [],",
    );
    assert!(
        text.contains("effects: [],"),
        "the bunny's effect line changed"
    );
    std::fs::write(&plain, text).expect("write");
    for backend in ["cpu", "gpu"] {
        let stats = dir.path().join(format!("{backend}.json"));
        gazecast()
            .args(["render", "--backend", backend, "--scene"])
            .arg(&plain)
            .arg("--display")
            .arg(&d)
            .arg("--out")
            .arg(dir.path().join(format!("{backend}.png")))
            .arg("--stats")
            .arg(&stats)
            .succeed();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).expect("json")).expect("json");
        assert_eq!(v["mode"], "full", "{backend}: {v}");
        assert_eq!(v["backend"], backend, "{backend}: {v}");
        assert_eq!(v["rays_total"], 320 * 256, "{backend}: {v}");
        let out = gazecast()
            .args(["view", "--explain", "--backend", backend, "--scene"])
            .arg(&plain)
            .arg("--display")
            .arg(&d)
            .succeed();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains(&format!("method: full on {backend}")),
            "{backend}: {text}"
        );
        assert!(!text.contains("classify"), "{backend}: {text}");
    }
}

/// An effect's parameter out of range names file, line and field.
#[test]
fn a_bad_effect_parameter_names_file_line_and_field() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.ron");
    let text = std::fs::read_to_string("../../config/scenes/bunny.ron").expect("bunny");
    let text = text.replace(
        "sampling: Foveated(refine: [Silhouette, Crease(angle_deg: 30.0), Depth(jump: 0.05)]),\n    passes: [],",
        "effects: [FoveatedSampling,\n        PorOverlay(half_px: 0)],",
    );
    std::fs::write(&bad, &text).expect("write");
    let line = text
        .lines()
        .position(|l| l.contains("half_px"))
        .expect("line")
        + 1;
    let out = gazecast()
        .args(["render", "--scene"])
        .arg(&bad)
        .args([
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--out",
        ])
        .arg(dir.path().join("x.png"))
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("bad.ron:{line}:")) && err.contains("effects[1].half_px"),
        "{err}"
    );
    assert!(!dir.path().join("x.png").exists());
}

/// `--coc` and `--dof-level` write the depth-of-field pass's maps: the
/// stress scene's slivers before the eye are blurred (bright), its focus
/// sharp (black); a scene without the effect is refused naming the flag.
#[test]
fn render_writes_the_dof_coc_and_level_maps_and_refuses_them_without_the_effect() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let (png, coc, level) = (
        dir.path().join("f.png"),
        dir.path().join("coc.png"),
        dir.path().join("level.png"),
    );
    gazecast()
        .args([
            "render",
            "--scene",
            "config/scenes/stress-dof.ron",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(&png)
        .arg("--coc")
        .arg(&coc)
        .arg("--dof-level")
        .arg(&level)
        .succeed();
    for f in [&coc, &level] {
        let file = std::fs::File::open(f).expect("written");
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .expect("a PNG");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("a frame");
        assert_eq!((info.width, info.height), (320, 256));
        // Below the legend band: some pixels sharp (black), some blurred.
        let body = &buf[3 * 320 * 30..3 * 320 * 256];
        let black = body.chunks(3).filter(|p| *p == [0, 0, 0]).count();
        let lit = body.len() / 3 - black;
        assert!(
            black > 100 && lit > 100,
            "{}: {black} sharp, {lit} blurred",
            f.display()
        );
    }
    let out = gazecast()
        .args([
            "render",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(dir.path().join("g.png"))
        .arg("--coc")
        .arg(dir.path().join("c2.png"))
        .output()
        .expect("runs");
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(e.contains("--coc") && e.contains("DepthOfField"), "{e}");
    assert!(
        !dir.path().join("g.png").exists(),
        "nothing written on a refused flag"
    );
}

/// A registered method (`--method layers`) and the registered debug maps
/// (`--map NAME=FILE.png`) reach the command line through pipeline's
/// lists: no flag of their own. An unknown map name lists the known ones.
#[test]
fn registered_methods_and_maps_are_on_the_command_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let (png, ecc, cut, stats) = (
        dir.path().join("f.png"),
        dir.path().join("ecc.png"),
        dir.path().join("cut.png"),
        dir.path().join("s.json"),
    );
    gazecast()
        .args([
            "render",
            "--scene",
            "config/scenes/search-task.ron",
            "--gaze",
            "100,80",
            "--method",
            "layers",
            "--backend",
            "cpu",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(&png)
        .arg("--map")
        .arg(format!("eccentricity={}", ecc.display()))
        .arg("--map")
        .arg(format!("cutoff={}", cut.display()))
        .arg("--stats")
        .arg(&stats)
        .succeed();
    for f in [&png, &ecc, &cut] {
        assert!(std::fs::read(f).expect("png").starts_with(b"\x89PNG"));
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).expect("json")).expect("json");
    assert_eq!(v["mode"], "layers", "{v}");
    // On this coarse display the inner layer holds the whole screen.
    assert_eq!(v["rays_total"].as_u64(), Some(320 * 256), "{v}");
    let out = gazecast()
        .args([
            "render",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(dir.path().join("g.png"))
        .args(["--map", "eccentricty=x.png"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("known: eccentricity, cutoff"), "{err}");
    let help = gazecast()
        .args(["render", "--help"])
        .output()
        .expect("runs");
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(
        help.contains("layers:") && help.contains("Guenter"),
        "{help}"
    );
}
