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

#[test]
fn the_issue_names_four_set_ups_and_all_are_shipped() {
    let names: Vec<String> = display_files()
        .iter()
        .map(|p| {
            p.file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    for expected in [
        "tobii-et1750-17in.ron",
        "v8-hmd.ron",
        "desktop-24in-1080p.ron",
        "desktop-27in-4k.ron",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "missing {expected} in {names:?}"
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
