//! The ray masks follow a measured eye distance (Murphy 2007 §8.2.2): a
//! nearer eye needs more rays, a farther one fewer; small changes (the
//! tracker's noise) keep the mask; implausible measurements are ignored;
//! the picture's camera stays the display file's.

use std::path::Path;

use foveation::Display;
use pipeline::{Method, Options, Renderer, EYE_DISTANCE_STEP};
use raycast::{Camera, Scene, SceneFile};

fn scene() -> Scene {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let path = root.join("config/scenes/search-task.ron");
    let text = std::fs::read_to_string(&path).expect("scene file");
    let file: SceneFile = ron::from_str(&text).expect("scene");
    Scene::build(&file, path.parent().expect("dir")).expect("scene builds")
}

#[test]
fn masks_follow_the_measured_eye_distance() {
    let scene = scene();
    let g = Display::seed_17in(320, 256).geometry().expect("geometry");
    let options = Options {
        method: Method::Hybrid,
        reuse: true,
        ..Options::default()
    };
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    let mut r = Renderer::new(&scene, Camera::new(&g), model, &options).expect("renderer");
    let gaze = [160.0, 128.0];
    let rays = |r: &mut Renderer<'_>| {
        let (frame, stats) = r.render_at(gaze, 0.0).expect("frame");
        r.recycle(frame);
        stats.rays_total
    };
    let nominal = rays(&mut r);
    assert_eq!(r.eye_distance_mm(), 540.0);
    // Nearer: more rays; farther: fewer.
    assert!(r.set_eye_distance_mm(Some(400.0)));
    let near = rays(&mut r);
    assert!(r.set_eye_distance_mm(Some(800.0)));
    let far = rays(&mut r);
    assert!(near > nominal && nominal > far, "{near} {nominal} {far}");
    // Within the step: the model (and so the mask) stays.
    let small = 800.0 * (1.0 + 0.5 * EYE_DISTANCE_STEP);
    assert!(!r.set_eye_distance_mm(Some(small)));
    assert_eq!(r.eye_distance_mm(), 800.0);
    assert_eq!(rays(&mut r), far);
    assert!(r.reuse_stats().mask_reused, "the same mask: kept");
    // Implausible or broken measurements change nothing.
    for bad in [f64::NAN, f64::INFINITY, -600.0, 0.0, 50.0, 1e7] {
        assert!(!r.set_eye_distance_mm(Some(bad)), "{bad}");
        assert_eq!(r.eye_distance_mm(), 800.0);
    }
    // No measurement: the display file's distance, and its mask again.
    assert!(r.set_eye_distance_mm(None));
    assert_eq!(r.eye_distance_mm(), 540.0);
    assert_eq!(rays(&mut r), nominal);
    // The camera never moved.
    assert_eq!(r.camera().eye, Camera::new(&g).eye);
}
