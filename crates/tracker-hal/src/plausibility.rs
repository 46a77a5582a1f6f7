//! Whether a gaze sample's values can be believed, and what the two eyes
//! measure beyond the point of regard: a mapped gaze's plausibility, the
//! eyes' distance from the screen, and the vergence depth. Policy that
//! every consumer of samples shares (the live view, the experiment
//! runner), kept beside the samples.

use screen_geometry::{ScreenGeometry, EYE_DISTANCE_RANGE_MM};

use crate::GazeSample;

/// Whether a mapped gaze is usable: finite and, when the screen size is
/// known, not more than one screen diagonal outside the screen.
pub fn plausible(p: [f64; 2], screen_px: Option<[f64; 2]>) -> bool {
    if !(p[0].is_finite() && p[1].is_finite()) {
        return false;
    }
    let Some([w, h]) = screen_px else {
        return true;
    };
    let d = w.hypot(h);
    (-d..=w + d).contains(&p[0]) && (-d..=h + d).contains(&p[1])
}

/// The eyes' distance from the screen (mm) in a sample: the mean z of its
/// valid eye positions (µm in the tracker's frame, whose z is the distance
/// from the tracker, mounted in the screen plane), when it lies in
/// [`EYE_DISTANCE_RANGE_MM`].
pub fn eye_distance_mm(s: &GazeSample) -> Option<f64> {
    let (sum, n) = s
        .eye_position_um
        .iter()
        .flatten()
        .map(|p| p[2] / 1000.0)
        .filter(|z| z.is_finite())
        .fold((0.0, 0u32), |(s, n), z| (s + z, n + 1));
    let d = sum / f64::from(n.max(1));
    (n > 0 && EYE_DISTANCE_RANGE_MM.contains(&d)).then_some(d)
}

/// Interocular distance for vergence, mm: the adult mean (Dodgson 2004);
/// the trackers' eye positions are not used for it yet.
pub const INTEROCULAR_MM: f64 = 63.0;

/// Farthest vergence point accepted, in eye-to-screen distances: beyond
/// it the lines of sight are treated as parallel (no depth).
pub const VERGENCE_MAX_SCALE: f64 = 100.0;

/// The eye distance (mm) of the 3-D gaze point where the two eyes' lines
/// of sight through their points of regard (`eyes_px`: left, right; screen
/// px) meet (Murphy & Duchowski eqs. 1–3, [`crate::events::vergence_point`]),
/// the eyes [`INTEROCULAR_MM`] apart about the display's eye point
/// (`geometry`); `None` when they are parallel, diverge or meet beyond
/// [`VERGENCE_MAX_SCALE`] screen distances.
pub fn vergence_mm(geometry: &ScreenGeometry, eyes_px: [[f64; 2]; 2]) -> Option<f64> {
    let [w, h] = geometry.size_px();
    let (px, py) = (geometry.pitch_x_mm, geometry.pitch_y_mm);
    // Screen mm from the screen's centre, x right, y up.
    let on_screen = |p: [f64; 2]| [(p[0] - w / 2.0) * px, (h / 2.0 - p[1]) * py];
    let eye = on_screen(geometry.eye_point_px);
    let z = geometry.eye_distance_mm;
    // Coordinates of eqs. 1–3: the eyes' plane at z = 0, the screen at z = d.
    let g = crate::events::vergence_point(
        on_screen(eyes_px[0]),
        on_screen(eyes_px[1]),
        INTEROCULAR_MM,
        [eye[0], eye[1], 0.0],
        z,
        VERGENCE_MAX_SCALE,
    )?;
    let d = (g[0] - eye[0]).hypot(g[1] - eye[1]).hypot(g[2]);
    (d.is_finite() && d > 0.0).then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_eye_distance_is_the_mean_z_of_the_valid_eyes_when_plausible() {
        let sample = |l: Option<[f64; 3]>, r: Option<[f64; 3]>| crate::GazeSample {
            seq: 0,
            device_time_us: None,
            host_time_us: 0,
            mapped_time_us: 0,
            time_order: crate::timing::TimeOrder::Unmapped,
            clock_segment: 0,
            left: crate::EyeSample::MISSING,
            right: crate::EyeSample::MISSING,
            combined: None,
            eye_position_um: [l, r],
        };
        let at = |z: f64| Some([30_000.0, -5_000.0, z]);
        assert_eq!(eye_distance_mm(&sample(at(600e3), at(620e3))), Some(610.0));
        assert_eq!(eye_distance_mm(&sample(None, at(620e3))), Some(620.0));
        assert_eq!(
            eye_distance_mm(&sample(at(f64::NAN), at(620e3))),
            Some(620.0)
        );
        assert_eq!(eye_distance_mm(&sample(None, None)), None);
        assert_eq!(eye_distance_mm(&sample(at(f64::NAN), None)), None);
        for z in [0.0, -600e3, 50e3, 5e6, f64::INFINITY] {
            assert_eq!(eye_distance_mm(&sample(at(z), None)), None, "{z}");
        }
    }

    /// Mapped gaze that is not finite or more than one screen diagonal
    /// outside the screen is not a gaze (a 1e7-px POR used to reach the
    /// renderer); anything nearer is, off-screen or not.
    #[test]
    fn gaze_far_off_the_screen_or_not_finite_is_implausible() {
        let screen = Some([300.0, 400.0]); // diagonal 500
        for p in [[0.0, 0.0], [300.0, 400.0], [-499.0, 899.0], [799.0, -500.0]] {
            assert!(plausible(p, screen), "{p:?}");
        }
        for p in [
            [-501.0, 0.0],
            [801.0, 0.0],
            [0.0, 901.0],
            [1.0e7, 1.0e7],
            [f64::NAN, 1.0],
            [1.0, f64::INFINITY],
        ] {
            assert!(!plausible(p, screen), "{p:?}");
        }
        assert!(plausible([1.0e7, 0.0], None));
        assert!(!plausible([f64::NAN, 0.0], None));
    }

    /// Eqs. 1–3 on the display: eyes converging on the screen give the
    /// screen's distance, the disparity of a point at depth D gives D, and
    /// parallel or diverging lines of sight give none.
    #[test]
    fn vergence_depth_from_the_two_eyes_points() {
        let d = screen_geometry::Display::seed_17in(1280, 1024);
        let g = d.geometry().expect("geometry");
        let pitch = g.pitch_x_mm;
        let centre = [640.0, 512.0];
        let got = vergence_mm(&g, [centre, centre]).expect("on the screen");
        assert!((got - 540.0).abs() < 1e-6, "{got}");
        for depth in [300.0, 1000.0, 5000.0] {
            // Where each eye's line of sight to the point crosses the screen.
            let half = 0.5 * INTEROCULAR_MM * (1.0 - 540.0 / depth) / pitch;
            let eyes = [[640.0 - half, 512.0], [640.0 + half, 512.0]];
            let got = vergence_mm(&g, eyes).expect("converging");
            assert!((got - depth).abs() < 1e-6 * depth, "{depth}: {got}");
        }
        let parallel = INTEROCULAR_MM / pitch;
        assert_eq!(
            vergence_mm(&g, [[600.0, 512.0], [600.0 + parallel, 512.0]]),
            None
        );
        assert_eq!(vergence_mm(&g, [[600.0, 512.0], [900.0, 512.0]]), None);
        assert_eq!(vergence_mm(&g, [[f64::NAN, 0.0], centre]), None);
    }
}
