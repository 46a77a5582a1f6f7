//! Every numeric field of every kind of configuration file, set to each of
//! NaN, ±inf, 0, a negative number, 1e308 and 1e-308, is either refused
//! with an error naming the file, the line and the field, or accepted and
//! then loads, maps and renders with finite results:
//!
//! * the display file (`config/displays/tobii-et1750-17in.ron`): the ray
//!   mask of `gazecast mask` is built, its pixels per degree and rays finite;
//! * each tracker file (`config/trackers/*.ron`): a grid of the tracker's
//!   range (mouse: a 1280 × 1024 screen) maps to finite points near the
//!   screen;
//! * a scene (`config/scenes/search-task.ron`, meshes made small): the
//!   scene builds and a tiny display's rays hit, shade and miss finitely;
//! * calibration files of each model: the raw range maps finitely.
//!
//! Every field is tried with every value (exhaustively); a proptest then
//! changes two fields at once.

use std::path::{Path, PathBuf};

use gazecast_viewer::config;
use proptest::prelude::*;
use tracker_hal::calibration::{Calibration, Model};
use tracker_hal::{Driver, Mapping};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(repo().join(rel)).expect("shipped config file")
}

/// A number in a RON text: byte range, and whether it is an integer.
#[derive(Debug, Clone, Copy)]
struct Num {
    start: usize,
    end: usize,
    integer: bool,
}

/// Every number in `text` outside comments and strings, with its sign.
fn numbers(text: &str) -> Vec<Num> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    let mut in_string = false;
    while i < b.len() {
        let c = b[i];
        if in_string {
            if c == b'\\' {
                i += 1;
            } else if c == b'"' {
                in_string = false;
            }
            i += 1;
            continue;
        }
        if c == b'"' {
            in_string = true;
            i += 1;
            continue;
        }
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        let ident_before = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if c.is_ascii_digit() && !ident_before {
            let start = if i > 0 && b[i - 1] == b'-' { i - 1 } else { i };
            let mut j = i;
            let mut integer = true;
            if b[j] == b'0' && matches!(b.get(j + 1), Some(b'x')) {
                j += 2;
                while j < b.len() && b[j].is_ascii_hexdigit() {
                    j += 1;
                }
            } else {
                while j < b.len() && b[j].is_ascii_digit() {
                    j += 1;
                }
                if j + 1 < b.len() && b[j] == b'.' && b[j + 1].is_ascii_digit() {
                    integer = false;
                    j += 1;
                    while j < b.len() && b[j].is_ascii_digit() {
                        j += 1;
                    }
                }
                if j < b.len() && (b[j] == b'e' || b[j] == b'E') {
                    integer = false;
                    j += 1;
                    if j < b.len() && (b[j] == b'-' || b[j] == b'+') {
                        j += 1;
                    }
                    while j < b.len() && b[j].is_ascii_digit() {
                        j += 1;
                    }
                }
            }
            out.push(Num {
                start,
                end: j,
                integer,
            });
            i = j;
            continue;
        }
        i += 1;
    }
    out
}

/// The values every field is tried with (zero and the negative number
/// written as integers for integer fields).
fn values(integer: bool) -> [&'static str; 7] {
    let (zero, negative) = if integer {
        ("0", "-3")
    } else {
        ("0.0", "-2.5")
    };
    ["NaN", "inf", "-inf", zero, negative, "1e308", "1e-308"]
}

fn replace(text: &str, edits: &[(Num, &str)]) -> String {
    let mut edits = edits.to_vec();
    edits.sort_by_key(|(n, _)| std::cmp::Reverse(n.start));
    let mut t = text.to_string();
    for (n, v) in edits {
        t.replace_range(n.start..n.end, v);
    }
    t
}

/// An error must name the file, a line and a field, and print no number
/// longer than 20 characters (no 300-digit decimals).
fn check_error(path: &Path, message: &str, field: Option<&str>, line: usize) -> Result<(), String> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    if !message.contains(name) {
        return Err(format!("the error does not name the file: {message}"));
    }
    if field.is_none() || line == 0 {
        return Err(format!(
            "the error does not name a field and line ({field:?}, line {line}): {message}"
        ));
    }
    let longest = message
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .map(str::len)
        .max()
        .unwrap_or(0);
    if longest > 20 {
        return Err(format!("a {longest}-character number in: {message}"));
    }
    Ok(())
}

/// `field `x`` and the line of a scene error's text `path:line:col: …`.
fn scene_error_parts(message: &str) -> (Option<&str>, usize) {
    let field = message
        .split_once("field `")
        .and_then(|(_, rest)| rest.split_once('`'))
        .map(|(f, _)| f);
    let line = message
        .split(".ron:")
        .nth(1)
        .and_then(|rest| rest.split(':').next())
        .and_then(|l| l.parse().ok())
        .unwrap_or(0);
    (field, line)
}

struct Files {
    dir: tempfile::TempDir,
}

impl Files {
    fn new() -> Self {
        Self {
            dir: tempfile::tempdir().expect("tempdir"),
        }
    }
    fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.dir.path().join(name);
        std::fs::write(&path, text).expect("write");
        path
    }
}

// ---- display --------------------------------------------------------------

fn check_display(files: &Files, text: &str) -> Result<bool, String> {
    let path = files.write("display.ron", text);
    match config::load_display(&path) {
        Err(e) => check_error(&path, &e.to_string(), e.field(), e.line()).map(|_| false),
        Ok(_) => {
            let args = gazecast_viewer::mask_cmd::MaskArgs {
                display: Some(path.clone()),
                gaze: None,
                eye_distance_mm: None,
                contrast: 1.0,
                layout: foveation::Layout::Nyquist,
                max_spacing_px: foveation::sampling::SEED_MAX_SPACING_PX,
                json: false,
                points: None,
                png: None,
            };
            let built = gazecast_viewer::mask_cmd::build(&args)
                .map_err(|e| format!("accepted, but the mask fails: {e}"))?;
            let r = &built.report;
            let finite = [r.ppd, r.fovea_radius_px, r.nyquist_bound_rays]
                .iter()
                .all(|v| v.is_finite() && *v > 0.0);
            let rays_ok = built
                .mask
                .ray_positions()
                .all(|p| p[0].is_finite() && p[1].is_finite());
            if !(finite && rays_ok && r.rays > 0) {
                return Err(format!(
                    "accepted, but ppd {} fovea {} bound {} rays {}",
                    r.ppd, r.fovea_radius_px, r.nyquist_bound_rays, r.rays
                ));
            }
            Ok(true)
        }
    }
}

// ---- trackers -------------------------------------------------------------

const TRACKERS: [&str; 4] = [
    "config/trackers/iscan-ascii.ron",
    "config/trackers/iscan-binary.ron",
    "config/trackers/mouse.ron",
    "config/trackers/tobii-hid.ron",
];

/// A tracker file with a Corners mapping (the one iscan-binary.ron
/// suggests), so its fields are tried too.
fn corners_tracker() -> String {
    read("config/trackers/iscan-binary.ron").replace(
        "mapping: Frame(screen_px: (1280, 1024)),\n)",
        "mapping: Corners(window_in_tracker: (56.0, 80.0, 456.0, 380.0), window_px: (1280, 1024), \
         window_origin_px: (10.0, 20.0)),\n)",
    )
}

fn check_tracker(files: &Files, text: &str) -> Result<bool, String> {
    let path = files.write("tracker.ron", text);
    let t = match config::load_tracker(&path) {
        Err(e) => return check_error(&path, &e.to_string(), e.field(), e.line()).map(|_| false),
        Ok(t) => t,
    };
    // The range the samples fall in: the frame, or a screen for the mouse.
    let (w, h) = t.range().unwrap_or((1280.0, 1024.0));
    let frame = t.frame();
    let screen: [f64; 4] = match &t.mapping {
        Mapping::Identity => [0.0, 0.0, w, h],
        Mapping::Frame { screen_px } => [0.0, 0.0, f64::from(screen_px.0), f64::from(screen_px.1)],
        Mapping::Corners {
            window_px,
            window_origin_px,
            ..
        } => [
            window_origin_px.0,
            window_origin_px.1,
            window_origin_px.0 + f64::from(window_px.0),
            window_origin_px.1 + f64::from(window_px.1),
        ],
    };
    let d = (screen[2] - screen[0]).hypot(screen[3] - screen[1]);
    for i in 0..=8 {
        for j in 0..=8 {
            let p = [w * (f64::from(i) / 8.0), h * (f64::from(j) / 8.0)];
            let q = t.mapping.to_screen(p, frame);
            let near = q[0] >= screen[0] - d
                && q[0] <= screen[2] + d
                && q[1] >= screen[1] - d
                && q[1] <= screen[3] + d;
            if !(q[0].is_finite() && q[1].is_finite() && near) {
                return Err(format!("accepted, but {p:?} maps to {q:?}"));
            }
        }
    }
    // A HID tracker's recorded log decodes and maps finitely too.
    if let Driver::TobiiHid(_) = t.driver {
        use tracker_hal::source::Decoder;
        let log = std::fs::read(repo().join("tests/data/tobii-hid-50hz.hidlog")).expect("log");
        let mut dec = t.decoder();
        let mut out = std::collections::VecDeque::new();
        dec.push(&log, 0, &mut out);
        dec.finish();
        let frame = dec.frame_hint().unwrap_or(frame);
        for s in out.iter().take(200) {
            if let Some(g) = s.gaze() {
                let q = t.mapping.to_screen(g, frame);
                if !(q[0].is_finite() && q[1].is_finite()) {
                    return Err(format!("accepted, but the log's {g:?} maps to {q:?}"));
                }
            }
        }
    }
    Ok(true)
}

// ---- calibration ----------------------------------------------------------

/// A calibration of `model` fitted on a mildly projective tracker, as RON.
fn calibration_text(model: Model) -> String {
    let mut pairs = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            let t = [128.0 + 341.0 * f64::from(i), 102.0 + 273.0 * f64::from(j)];
            let (x, y) = (t[0] / 1280.0, t[1] / 1024.0);
            let w = 1.0 + 0.1 * x - 0.05 * y;
            pairs.push((
                [512.0 * (0.8 * x + 0.1) / w, 512.0 * (0.75 * y + 0.1) / w],
                t,
            ));
        }
    }
    let c = Calibration::fit(model, &pairs).expect("fits");
    ron::ser::to_string_pretty(&c, ron::ser::PrettyConfig::default()).expect("ron")
}

fn check_calibration(files: &Files, text: &str) -> Result<bool, String> {
    let path = files.write("calibration.ron", text);
    let c = match config::load_calibration(&path) {
        Err(e) => return check_error(&path, &e.to_string(), e.field(), e.line()).map(|_| false),
        Ok(c) => c,
    };
    let (raw, screen) = c.ranges();
    let mut grid = [[[0.0f64; 2]; 9]; 9];
    for i in 0..=8 {
        for j in 0..=8 {
            let p = [
                raw[0] + (raw[2] - raw[0]) * (f64::from(i) / 8.0),
                raw[1] + (raw[3] - raw[1]) * (f64::from(j) / 8.0),
            ];
            match c.map(p) {
                Some(q) if q[0].is_finite() && q[1].is_finite() => grid[i as usize][j as usize] = q,
                q => return Err(format!("accepted, but {p:?} maps to {q:?}")),
            }
        }
    }
    // The tracker's range lands on an area of the screen: every cell of the
    // grid keeps one orientation and at least (diagonal/16/8)²/8 px², the
    // first-order area the Jacobian bound gives with a margin of 8.
    let diagonal = (screen[2] - screen[0]).hypot(screen[3] - screen[1]);
    let least = (diagonal * tracker_hal::calibration::MIN_STRETCH / 8.0).powi(2) / 8.0;
    let mut sign = 0.0f64;
    for i in 0..8 {
        for j in 0..8 {
            let (a, b, d) = (grid[i][j], grid[i + 1][j], grid[i][j + 1]);
            let cross = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
            if sign == 0.0 {
                sign = cross.signum();
            }
            if !(cross.abs() >= least && cross.signum() == sign) {
                return Err(format!(
                    "accepted, but the grid cell ({i}, {j}) maps to {cross} px² (at least {least}, one orientation)"
                ));
            }
        }
    }
    Ok(true)
}

// ---- scene ----------------------------------------------------------------

/// search-task.ron with small meshes, so that every variant builds fast.
fn scene_text() -> String {
    read("config/scenes/search-task.ron")
        .replace("triangles: 8000", "triangles: 40")
        .replace("segments: 64, sides: 24", "segments: 8, sides: 6")
}

fn tiny_geometry() -> foveation::ScreenGeometry {
    foveation::Display {
        name: "tiny".into(),
        resolution_px: (16, 12),
        size_mm: (337.9, 270.3),
        eye_distance_mm: 540.0,
        eye_point_px: None,
    }
    .geometry()
    .expect("tiny display")
}

fn check_scene(files: &Files, text: &str) -> Result<bool, String> {
    let path = files.write("scene.ron", text);
    let scene = match config::load_scene(&path) {
        Err(message) => {
            let (field, line) = scene_error_parts(&message);
            return check_error(&path, &message, field, line).map(|_| false);
        }
        Ok(s) => s,
    };
    if !scene.background.is_finite() {
        return Err(format!(
            "accepted, but the background is {}",
            scene.background
        ));
    }
    let g = tiny_geometry();
    let camera = raycast::Camera::new(&g);
    let mut hits = 0;
    for y in 0..12 {
        for x in 0..16 {
            let ray = camera.pixel_ray(x, y);
            if let Some(hit) = scene.intersect(&ray, 0.0, raycast::ray::TriangleTest::Watertight) {
                hits += 1;
                let position = ray.origin + ray.dir * hit.t;
                let colour =
                    raycast::shade::shade(&scene, hit.object, position, hit.normal, ray.origin);
                if !(hit.t.is_finite() && hit.normal.is_finite() && colour.is_finite()) {
                    return Err(format!(
                        "accepted, but pixel ({x}, {y}) hits at t {} normal {} colour {colour}",
                        hit.t, hit.normal
                    ));
                }
            }
        }
    }
    let _ = hits;
    Ok(true)
}

// ---- the sweep ------------------------------------------------------------

type Check = fn(&Files, &str) -> Result<bool, String>;

fn subjects() -> Vec<(String, String, Check)> {
    let mut s: Vec<(String, String, Check)> = vec![(
        "tobii-et1750-17in.ron".into(),
        read("config/displays/tobii-et1750-17in.ron"),
        check_display,
    )];
    for t in TRACKERS {
        s.push((t.into(), read(t), check_tracker));
    }
    s.push(("corners tracker".into(), corners_tracker(), check_tracker));
    for m in [Model::Affine, Model::Homography, Model::Polynomial2] {
        s.push((
            format!("{m:?} calibration"),
            calibration_text(m),
            check_calibration,
        ));
    }
    s.push((
        "search-task.ron (small meshes)".into(),
        scene_text(),
        check_scene,
    ));
    s
}

/// Every numeric field × every value, one at a time.
#[test]
fn every_numeric_field_is_refused_by_name_or_works() {
    let files = Files::new();
    let mut failures = Vec::new();
    for (name, text, check) in subjects() {
        // The shipped file itself is accepted.
        match check(&files, &text) {
            Ok(true) => {}
            other => panic!("{name} as shipped: {other:?}"),
        }
        let (mut accepted, mut refused) = (0, 0);
        for n in numbers(&text) {
            for v in values(n.integer) {
                let t = replace(&text, &[(n, v)]);
                match check(&files, &t) {
                    Ok(true) => accepted += 1,
                    Ok(false) => refused += 1,
                    Err(e) => failures.push(format!(
                        "{name}: `{}` → {v} (line {}): {e}",
                        &text[n.start..n.end],
                        text[..n.start].matches('\n').count() + 1
                    )),
                }
            }
        }
        assert!(refused > 0, "{name}: nothing refused");
        eprintln!("{name}: {accepted} accepted, {refused} refused");
    }
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(48), failure_persistence: None, ..ProptestConfig::default() })]
    /// Two fields changed at once.
    #[test]
    fn two_fields_at_once_are_refused_by_name_or_work(
        subject in any::<prop::sample::Index>(),
        a in any::<prop::sample::Index>(),
        b in any::<prop::sample::Index>(),
        va in 0usize..7,
        vb in 0usize..7,
    ) {
        let files = Files::new();
        let subjects = subjects();
        let (name, text, check) = subject.get(&subjects);
        let nums = numbers(text);
        let (na, nb) = (*a.get(&nums), *b.get(&nums));
        let edits = if na.start == nb.start {
            vec![(na, values(na.integer)[va])]
        } else {
            vec![(na, values(na.integer)[va]), (nb, values(nb.integer)[vb])]
        };
        let t = replace(text, &edits);
        let result = check(&files, &t);
        prop_assert!(result.is_ok(), "{name}: {:?}: {:?}", edits.iter().map(|(n, v)| (&text[n.start..n.end], *v)).collect::<Vec<_>>(), result);
    }
}

/// Several objects on one line: the error points at the right one.
#[test]
fn a_scene_error_points_at_the_object_on_a_shared_line() {
    let files = Files::new();
    let text = "Scene(\n  name: \"x\",\n  meshes: { \"s\": Icosphere(subdivisions: 0) },\n  objects: [\n    \
                (mesh: \"s\", translate_mm: (0.0, 0.0, -5.0), scale_mm: 1.0), (mesh: \"s\", translate_mm: (1.0, 0.0, -5.0), scale_mm: 1.0),\n    \
                (mesh: \"s\", translate_mm: (2.0, 0.0, -5.0), scale_mm: 1.0), (mesh: \"nope\", translate_mm: (3.0, 0.0, -5.0), scale_mm: 1.0),\n  ],\n)";
    let path = files.write("shared.ron", text);
    let err = config::load_scene(&path).expect_err("no mesh `nope`");
    assert!(err.contains("objects[3].mesh"), "{err}");
    let col = text
        .lines()
        .nth(5)
        .expect("line 6")
        .find("(mesh: \"nope\"")
        .expect("object 3")
        + 2;
    assert!(err.contains(&format!("shared.ron:6:{col}:")), "{err}");
}

/// A NaN parameter says which one.
#[test]
fn a_nan_calibration_parameter_is_named() {
    let files = Files::new();
    let text = calibration_text(Model::Affine);
    let nums = numbers(&text);
    let params = text.find("params").expect("params");
    let third = nums
        .iter()
        .filter(|n| n.start > params)
        .nth(2)
        .copied()
        .expect("3 params");
    let path = files.write("cal.ron", &replace(&text, &[(third, "NaN")]));
    let err = config::load_calibration(&path).expect_err("NaN");
    let msg = err.to_string();
    assert_eq!(err.field(), Some("params[2]"), "{msg}");
    assert!(msg.contains("parameter 2 is NaN"), "{msg}");
}

/// The examples, each refused naming the field.
#[test]
fn mappings_that_cannot_reach_the_screen_are_refused() {
    let files = Files::new();
    let mouse_frame = read("config/trackers/mouse.ron").replace(
        "mapping: Identity",
        "mapping: Frame(screen_px: (1280, 1024))",
    );
    let path = files.write("mouse.ron", &mouse_frame);
    let err = config::load_tracker(&path).expect_err("mouse has no frame");
    assert_eq!(err.field(), Some("mapping"), "{err}");
    let huge = corners_tracker().replace(
        "(56.0, 80.0, 456.0, 380.0)",
        "(-1e308, -1e308, 1e308, 1e308)",
    );
    let path = files.write("corners.ron", &huge);
    let err = config::load_tracker(&path).expect_err("±1e308 corners");
    assert_eq!(err.field(), Some("mapping.window_in_tracker"), "{err}");
    let cal = calibration_text(Model::Affine);
    let scale_at = cal.rfind("scale:").expect("screen scale");
    let n = numbers(&cal)
        .into_iter()
        .find(|n| n.start > scale_at)
        .expect("number");
    let path = files.write("cal.ron", &replace(&cal, &[(n, "1e-300")]));
    let err = config::load_calibration(&path).expect_err("scale 1e-300");
    assert_eq!(err.field(), Some("screen.scale"), "{err}");
    assert!(err.to_string().len() < 400, "{err}");
}

/// Calibrations that map the tracker's range onto a line or a point —
/// rank 1, parameters of 1e-300, a screen scale of 1e308 — are refused on
/// the load path `replay`, `view` and `calibrate` use, naming file, line
/// and field.
#[test]
fn degenerate_calibrations_are_refused() {
    let files = Files::new();
    let good = Calibration::fit(Model::Affine, &{
        let mut pairs = Vec::new();
        for t in [
            [128.0, 102.0],
            [1152.0, 102.0],
            [128.0, 922.0],
            [1152.0, 922.0],
            [640.0, 512.0],
        ] {
            pairs.push(([t[0] / 2.5, t[1] / 4.0], t));
        }
        pairs
    })
    .expect("fits");
    let write = |name: &str, c: &Calibration| {
        let text = ron::ser::to_string_pretty(c, ron::ser::PrettyConfig::default()).expect("ron");
        files.write(name, &text)
    };
    config::load_calibration(&write("good.ron", &good)).expect("the fitted one loads");
    let mut cases = Vec::new();
    // Rank 1: v follows u.
    let mut rank1 = good.clone();
    rank1.params[3] = rank1.params[0];
    rank1.params[4] = rank1.params[1];
    cases.push(("rank1.ron", rank1, "params"));
    let mut tiny = good.clone();
    for p in &mut tiny.params {
        *p *= 1e-300;
    }
    cases.push(("tiny.ron", tiny, "params"));
    let mut far = good.clone();
    far.screen.scale = 1e308;
    cases.push(("far.ron", far, "params"));
    let mut hand = good.clone();
    hand.points.clear();
    hand.screen.scale = 1e308;
    cases.push(("hand.ron", hand, "screen.scale"));
    for (name, c, field) in cases {
        let err = config::load_calibration(&write(name, &c)).expect_err(name);
        let msg = err.to_string();
        assert_eq!(err.field(), Some(field), "{name}: {msg}");
        assert!(
            msg.contains(name) && err.line() > 0 && msg.len() < 600,
            "{name}: {msg}"
        );
    }
}

/// An OBJ that cannot be opened says why, with the path.
#[test]
fn an_obj_that_cannot_be_opened_says_why() {
    let files = Files::new();
    let text = "Scene(name: \"x\", meshes: { \"m\": Obj(path: \"missing.obj\") }, objects: [])";
    let path = files.write("obj.ron", text);
    let err = config::load_scene(&path).expect_err("missing OBJ");
    assert!(err.contains("missing.obj"), "{err}");
    assert!(
        err.contains("No such file or directory") || err.contains("os error"),
        "{err}"
    );
}

/// `mask --eye-distance-mm 1e308` is refused, with the accepted range.
#[test]
fn absurd_eye_distances_are_refused_by_mask() {
    for d in [1e308, 1e-308, 0.5, 200_000.0] {
        let args = gazecast_viewer::mask_cmd::MaskArgs {
            display: Some(repo().join("config/displays/tobii-et1750-17in.ron")),
            gaze: None,
            eye_distance_mm: Some(d),
            contrast: 1.0,
            layout: foveation::Layout::Nyquist,
            max_spacing_px: foveation::sampling::SEED_MAX_SPACING_PX,
            json: true,
            points: None,
            png: None,
        };
        let mut out = Vec::new();
        let err = gazecast_viewer::mask_cmd::run(&args, &mut out).expect_err("absurd distance");
        assert!(
            err.contains("--eye-distance-mm") && err.contains("100 m"),
            "{d}: {err}"
        );
        assert!(err.len() < 200, "{err}");
    }
}

/// NaN or negative colours and light intensities are refused by name.
#[test]
fn bad_colours_and_intensities_name_their_field() {
    let files = Files::new();
    let base = scene_text();
    assert!(
        base.contains("\n    sampling:"),
        "the shipped scene's sampling line"
    );
    let lit = base.replace(
        "\n    sampling:",
        "\n    lights: [Headlight(intensity: 1.0), Point(position_mm: (0.0, 0.0, 500.0), intensity: 0.5)],\n    sampling:",
    );
    for (from, to, field) in [
        (
            "background: (0.06, 0.06, 0.08)",
            "background: (0.06, NaN, 0.08)",
            "background",
        ),
        (
            "background: (0.06, 0.06, 0.08)",
            "background: (0.06, -1.0, 0.08)",
            "background",
        ),
        (
            "(diffuse: (0.75, 0.62, 0.5))",
            "(diffuse: (0.75, -0.62, 0.5))",
            "materials.clay.diffuse",
        ),
        (
            "(diffuse: (0.45, 0.55, 0.8))",
            "(diffuse: (NaN, 0.55, 0.8))",
            "materials.blue.diffuse",
        ),
        ("intensity: 0.5", "intensity: -0.5", "lights[1].intensity"),
        ("intensity: 0.5", "intensity: NaN", "lights[1].intensity"),
    ] {
        let path = files.write("colours.ron", &lit.replacen(from, to, 1));
        let err = config::load_scene(&path).expect_err(to);
        assert!(err.contains(&format!("field `{field}`")), "{to}: {err}");
        assert!(!err.contains("ron:0:0"), "{to}: {err}");
    }
}
