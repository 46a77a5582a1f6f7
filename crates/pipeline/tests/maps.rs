//! The registered debug maps (Murphy 2007 Figs. 4.1 and 4.2): found by
//! name, equal to the sampling model's own functions, 0° at the gaze,
//! growing (eccentricity) and falling (cut-off) away from it; a gaze that
//! is not finite or a screen too large is refused.

use pipeline::registry::{map, MapInput, MAPS, MAX_MAP_PIXELS};

fn model() -> foveation::SamplingModel {
    let d = fixtures::display_17in(320, 256);
    pipeline::sampling_model(d.geometry().expect("geometry"), 1.0).expect("model")
}

#[test]
fn the_maps_are_the_models_eccentricity_and_cutoff() {
    let names: Vec<&str> = MAPS.iter().map(|m| m.name).collect();
    assert_eq!(names, ["eccentricity", "cutoff"]);
    let m = model();
    let gaze = [100.5, 60.5];
    let input = MapInput {
        model: &m,
        gaze_px: gaze,
        width_px: 320,
        height_px: 256,
    };
    let ecc = (map("eccentricity").expect("registered").make)(&input).expect("map");
    let cut = (map("cutoff").expect("registered").make)(&input).expect("map");
    assert_eq!(
        (ecc.width_px, ecc.height_px, ecc.values.len()),
        (320, 256, 320 * 256)
    );
    assert_eq!((ecc.unit, cut.unit), ("deg", "cycles/deg"));
    let at = |v: &[f32], x: usize, y: usize| v[y * 320 + x];
    // At the gaze's pixel: 0°, the highest cut-off.
    assert!(at(&ecc.values, 100, 60) < 1e-3);
    let peak = cut.values.iter().copied().fold(f32::MIN, f32::max);
    assert_eq!(at(&cut.values, 100, 60), peak);
    // Along the row to the right: eccentricity up, cut-off down.
    for x in 101..319 {
        assert!(at(&ecc.values, x + 1, 60) > at(&ecc.values, x, 60), "{x}");
        assert!(at(&cut.values, x + 1, 60) < at(&cut.values, x, 60), "{x}");
    }
    // The model's own numbers at a few pixels.
    for (x, y) in [(0usize, 0usize), (319, 255), (200, 30)] {
        let p = [x as f64 + 0.5, y as f64 + 0.5];
        let e = m.geometry.eccentricity_deg(gaze, p);
        assert!(
            (f64::from(at(&ecc.values, x, y)) - e).abs() < 1e-3,
            "{x},{y}"
        );
        let f = m.csf.cutoff_frequency_cpd(m.contrast, e);
        assert!(
            (f64::from(at(&cut.values, x, y)) - f).abs() < 1e-3 * f,
            "{x},{y}"
        );
    }
}

#[test]
fn a_bad_gaze_or_a_huge_screen_is_refused() {
    let m = model();
    for gaze in [[f64::NAN, 0.0], [0.0, f64::INFINITY]] {
        let input = MapInput {
            model: &m,
            gaze_px: gaze,
            width_px: 4,
            height_px: 4,
        };
        for d in MAPS {
            let e = (d.make)(&input).expect_err("refused");
            assert!(e.contains("finite"), "{e}");
        }
    }
    let huge = MapInput {
        model: &m,
        gaze_px: [0.0, 0.0],
        width_px: u32::MAX,
        height_px: 2,
    };
    assert!(u64::from(u32::MAX) * 2 > MAX_MAP_PIXELS);
    for d in MAPS {
        assert!((d.make)(&huge).is_err());
    }
    // An empty screen is an empty map.
    let empty = MapInput {
        model: &m,
        gaze_px: [0.0, 0.0],
        width_px: 0,
        height_px: 7,
    };
    assert!((map("cutoff").expect("registered").make)(&empty)
        .expect("empty")
        .values
        .is_empty());
}
