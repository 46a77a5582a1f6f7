//! Every shipped display file loads through the viewer's config loader and
//! meets the foveation crate's ray-count goal.

use std::path::{Path, PathBuf};

use foveation::{bound, mask, GeislerPerry, Layout, SamplingModel};
use gazecast_viewer::config;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn display_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("config/displays"))
        .expect("config/displays exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    files.sort();
    files
}

/// The four set-ups the seeds and the lab use, shipped with the geometry
/// each is named for (resolution, active area, viewing distance): a file
/// that goes missing, or drifts from its set-up, fails here.
/// A shipped set-up: file, resolution, size (mm), eye distance (mm).
type SetUp = (&'static str, (u32, u32), (f64, f64), f64);

#[test]
fn the_four_named_set_ups_are_shipped_with_their_geometry() {
    let expected: [SetUp; 4] = [
        // Murphy 2007 ch. 7.1: the Tobii ET-1750's 17" LCD, 54 cm.
        ("tobii-et1750-17in.ron", (1280, 1024), (337.9, 270.3), 540.0),
        // Murphy & Duchowski 2001: the V8 HMD, 640x480 per eye.
        ("v8-hmd.ron", (640, 480), (461.9, 346.4), 500.0),
        (
            "desktop-24in-1080p.ron",
            (1920, 1080),
            (531.4, 298.9),
            600.0,
        ),
        ("desktop-27in-4k.ron", (3840, 2160), (596.7, 335.7), 600.0),
    ];
    let files = display_files();
    for (name, resolution, size, distance) in expected {
        let path = files
            .iter()
            .find(|p| p.file_name().is_some_and(|n| n == name))
            .unwrap_or_else(|| panic!("missing config/displays/{name}"));
        let d = config::load_display(path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.resolution_px, resolution, "{name}");
        assert!(
            (d.size_mm.0 - size.0).abs() < 0.05 && (d.size_mm.1 - size.1).abs() < 0.05,
            "{name}: size {:?}",
            d.size_mm
        );
        assert!((d.eye_distance_mm - distance).abs() < 0.05, "{name}");
        // Square pixels within 1 % (a typo in one size would break it).
        let (px, py) = (
            d.size_mm.0 / f64::from(resolution.0),
            d.size_mm.1 / f64::from(resolution.1),
        );
        assert!(
            (px / py - 1.0).abs() < 0.01,
            "{name}: pixel aspect {}",
            px / py
        );
    }
}

#[test]
fn every_display_file_loads_and_the_nyquist_layout_is_within_25_percent_of_the_bound() {
    for file in display_files() {
        let display = config::load_display(&file).unwrap_or_else(|e| panic!("{e}"));
        let g = display.geometry().expect("validated by the loader");
        let model = SamplingModel::new(g, GeislerPerry::default(), 1.0, 17.0).expect("model");
        for por in [
            g.centre_px(),
            [0.5, 0.5],
            [f64::from(g.width_px) - 0.5, f64::from(g.height_px) - 0.5],
        ] {
            let rays = mask::build(&model, Layout::Nyquist, por)
                .expect("mask")
                .rays() as f64;
            let b = bound::nyquist_bound_rays(&model, por);
            assert!(
                rays <= 1.25 * b,
                "{}: POR {por:?}: {rays} rays vs bound {b:.0}",
                file.display()
            );
        }
    }
}

#[test]
fn the_default_config_names_a_display_that_loads() {
    let defaults = repo().join("config/default.ron");
    let (d, _): (config::Defaults, String) =
        config::load(&defaults).unwrap_or_else(|e| panic!("{e}"));
    let display = repo().join("config").join(d.display);
    config::load_display(&display).unwrap_or_else(|e| panic!("{e}"));
}
